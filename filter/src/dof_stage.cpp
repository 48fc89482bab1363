// The lens-blur stage (see dof_stage.h).
#include <filter/dof_stage.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <system_error>
#include <cstdio>
#include <stdexcept>

#include <fmt/core.h>

#include <dof/deep_exr.h>
#include <dof/highlights.h>
#include <dof/ray_cache.h>
#include <dof/renderer.h>
#include <filter/option_checks.h>
#include <filter/output_files.h>
#include <flare/cache.h>
#include <flare/flare.h>
#include <optics/system.h>
#include <optics/stopwatch.h>
#include <optics/text_pairs.h>

#include "exr_io.h"

namespace lensfx::filter {

// A rectangle of the frame's raster (pixels from the data window's corner).
struct DofRegion {
    int x = 0, y = 0, width = 0, height = 0;
};

struct DofShared {
    int x = 0, y = 0, width = 0, height = 0;  // data window the plates cover
    std::vector<float> sharp, blurred;        // RGB interleaved
};

namespace {

// A sensor tilt beyond this (degrees, either axis) is refused: view cameras tilt up to about 45, tilt-shift lenses 8-15.
constexpr double kMaxTiltDeg = 45.0;

std::array<double, 2> parse_pair(const std::string& text, const char* what) {
    if (const auto xy = parse_pair_of<double>(text, ','); xy && std::abs((*xy)[0]) <= kMaxTiltDeg && std::abs((*xy)[1]) <= kMaxTiltDeg) return *xy;
    throw std::runtime_error(fmt::format("{} must be AX,AY in degrees, each within +-{}, not \"{}\"", what, kMaxTiltDeg, text));
}

// "X,Y,METRES" of --focus-point, in display-window pixels: X and Y within a million pixels (as a track
// file's positions), METRES positive and at most a light year.
dof::FocusPoint parse_focus_point(const std::string& text) {
    constexpr double kMaxPixels = 1e6, kMaxMetres = 1e16;
    dof::FocusPoint p;
    char tail = 0;
    if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &p.x, &p.y, &p.metres, &tail) != 3 || !(std::abs(p.x) <= kMaxPixels) ||
        !(std::abs(p.y) <= kMaxPixels) || !(p.metres > 0.0) || !(p.metres <= kMaxMetres))
        throw std::runtime_error(fmt::format("--focus-point must be X,Y,METRES (pixels within 1e6, 0 < metres <= 1e16), not \"{}\"", text));
    return p;
}

// A focus point's distance must be one the lens can focus at (beyond its focal length), checked here: the
// focal surface between points stays within their distances, so no ray thread meets a bad one.
void check_focus_distance(const optics::System& system, double metres, const std::string& text) {
    try {
        (void)dof::focus_of(system, metres);
    } catch (const std::exception& e) {
        throw std::runtime_error(fmt::format("--focus-point {}: {}", text, e.what()));
    }
}

// The distance a focal surface through `points` ("X,Y,METRES") stands for where no --focus is given: the mean of
// their inverse distances (the focal surface is interpolated in inverse distance).
double mean_focus(const std::vector<std::string>& points) {
    double inverse = 0.0;
    for (const std::string& p : points) inverse += 1.0 / parse_focus_point(p).metres;
    return static_cast<double>(points.size()) / inverse;
}

// Refuses deep samples (--deep) over another display window than the frame's: they would land elsewhere or nowhere.
void check_deep_window(const dof::DeepImage& deep, const std::string& files, const ImageSpec& spec) {
    if (deep.full_x == spec.full_x && deep.full_y == spec.full_y && deep.full_width == spec.full_width && deep.full_height == spec.full_height)
        return;
    throw std::runtime_error(fmt::format("--deep {}: its display window is {}x{} at ({}, {}), the frame's {}x{} at ({}, {})", files,
                                         deep.full_width, deep.full_height, deep.full_x, deep.full_y, spec.full_width, spec.full_height,
                                         spec.full_x, spec.full_y));
}

// What the lens blur of a frame holds at most, per pixel of its display window: the frame grown to it and its R, G,
// B; the layers (two for a flat image, up to eight of deep samples) on the CPU and as the GL's textures (inverse
// depth, colour); the pyramids, the gathered sums and the result read back.
double dof_frame_bytes(const ImageSpec& spec, bool deep) {
    const double layers = deep ? 8.0 : 2.0;
    const double per_layer = 2.0 * (2 * sizeof(float) + 4 * sizeof(float));  // CPU and GL: depth pair and RGBA
    const double per_pixel = static_cast<double>(spec.pixel_bytes()) + 2.0 * 3 * sizeof(float) + layers * per_layer + 110.0;
    return bytes_of(spec.full_width, spec.full_height, per_pixel);
}

}  // namespace

void add_dof_options(CLI::App& app, DofSettings& s) {
    const std::string group = "Lens blur";
    app.add_flag("--dof", s.enabled, "Lens blur (depth of field) from Z or deep samples through --lens")->group(group);
    app.add_option("--focus", s.focus_m, "Focus distance in metres from the entrance pupil (with --dof)")->group(group)->check(CLI::PositiveNumber);
    app.add_option("--depth-channel", s.depth_channel, "Channel holding depth along the view axis")->capture_default_str()->group(group);
    app.add_option("--depth-scale", s.depth_scale, "Metres per depth unit")->capture_default_str()->group(group)->check(CLI::PositiveNumber);
    app.add_option("--deep", s.deep, "Deep EXR files (comma-separated, merged) whose samples are the scene's layers")->group(group);
    app.add_option("--dof-rays", s.rays, "Lens rays per pixel and channel")->capture_default_str()->group(group)->check(CLI::Range(1, 1024));
    app.add_option("--dof-max-rays", s.max_rays, "Up to this many where the blur is wide, so its rays land 2.5 px apart (default 4 x --dof-rays, at most 256)")
        ->group(group)
        ->check(CLI::Range(1, 4096));
    app.add_flag("!--no-chromatic-blur", s.chromatic, "Trace green's rays for all channels (3x faster, no chromatic blur)")->group(group);
    app.add_option("--tilt", s.tilt, "Sensor tilt AX,AY in degrees (tilt-shift, Scheimpflug)")
        ->group(group)
        ->check(parsed_by([](const std::string& t) { parse_pair(t, "--tilt"); }, "--tilt", "AX,AY"));
    app.add_option("--focus-point", s.focus_points,
                   "X,Y,METRES (display-window pixels; repeat): a focal surface through these, instead of the plane at --focus")
        ->group(group)
        ->check(parsed_by([](const std::string& t) { parse_focus_point(t); }, "--focus-point", "X,Y,METRES"));
    app.add_flag("--dof-only", s.dof_only, "Lens blur without the flare")->group(group);
}

namespace {

std::vector<std::string> split_commas(const std::string& text) {
    std::vector<std::string> out;
    for (std::size_t b = 0; b <= text.size();) {
        const std::size_t e = std::min(text.find(',', b), text.size());
        if (e > b) out.push_back(text.substr(b, e - b));
        b = e + 1;
    }
    return out;
}

int channel_index(const Frame& frame, const std::string& name) {
    const auto& names = frame.spec.channelnames;
    const auto it = std::find(names.begin(), names.end(), name);
    return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

// The `work` part of an image `width` pixels wide with `channels` values per pixel.
std::vector<float> crop(const std::vector<float>& image, int width, int channels, const DofRegion& work) {
    if (image.empty()) return {};
    const auto n = static_cast<std::size_t>(channels);
    std::vector<float> out(n * static_cast<std::size_t>(work.width) * static_cast<std::size_t>(work.height));
    for (int y = 0; y < work.height; ++y)
        std::copy_n(image.begin() + static_cast<std::ptrdiff_t>(n * (static_cast<std::size_t>(y + work.y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(work.x))),
                    n * static_cast<std::size_t>(work.width), out.begin() + static_cast<std::ptrdiff_t>(n * static_cast<std::size_t>(y) * static_cast<std::size_t>(work.width)));
    return out;
}

// The `work` part's values pasted into an image `width` x `height` of zeros.
std::vector<float> uncrop(const std::vector<float>& part, int width, int height, int channels, const DofRegion& work) {
    const auto n = static_cast<std::size_t>(channels);
    std::vector<float> out(n * static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0.0f);
    for (int y = 0; y < work.height; ++y)
        std::copy_n(part.begin() + static_cast<std::ptrdiff_t>(n * static_cast<std::size_t>(y) * static_cast<std::size_t>(work.width)), n * static_cast<std::size_t>(work.width),
                    out.begin() + static_cast<std::ptrdiff_t>(n * (static_cast<std::size_t>(y + work.y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(work.x))));
    return out;
}

// What of a flat frame is not empty (black, alpha 0, at infinity: the fill around a data window), and
// the nearest depth there (metres, 0: none).
struct FlatContent {
    DofRegion box;
    double nearest_m = 0.0;
};

FlatContent flat_content(const Frame& frame, int z, double scale) {
    const std::vector<float> depth = channels_as_float(frame, {z});
    const int a = channel_index(frame, "A");
    const std::vector<float> alpha = a >= 0 ? channels_as_float(frame, {a}) : std::vector<float>{};
    const int w = frame.spec.width, h = frame.spec.height;
    int x0 = w, y0 = h, x1 = 0, y1 = 0;
    FlatContent c;
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
            const double m = static_cast<double>(depth[i]) * scale;
            const bool at_depth = std::isfinite(m) && m > 0.0;
            if (at_depth && (c.nearest_m == 0.0 || m < c.nearest_m)) c.nearest_m = m;
            if (!at_depth && frame.rgb[3 * i] == 0.0f && frame.rgb[3 * i + 1] == 0.0f && frame.rgb[3 * i + 2] == 0.0f && (alpha.empty() || alpha[i] == 0.0f))
                continue;
            x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x + 1), y1 = std::max(y1, y + 1);
        }
    }
    c.box = {x0, y0, std::max(0, x1 - x0), std::max(0, y1 - y0)};
    return c;
}

// The part of the frame whose blur can differ from the empty fill (black, alpha 0, at infinity) around its
// content: the content grown by the farthest from its pixel a ray can meet a surface, for depths from the
// content's nearest to infinity (the fill).
DofRegion blur_extent(const ImageSpec& spec, const FlatContent& content, const dof::RayTable& table) {
    const double w_near = content.nearest_m > 0.0 ? 1.0 / content.nearest_m : table.focus_w;
    const double reach = table.max_slope * std::max(std::abs(w_near - table.focus_w), table.focus_w) + 2.0 * table.focus_spread +
                         dof::convergence_offset_px(table);
    // no wider than the frame (a depth of 1e-10 m reaches 1e10 pixels: the whole frame, not an overflowed int)
    const double frame_side = std::max(spec.width, spec.height);
    const int margin = std::isfinite(reach) ? static_cast<int>(std::min(std::ceil(reach) + 8.0, frame_side)) : static_cast<int>(frame_side);
    const DofRegion& b = content.box;
    // at a multiple of 64 pixels, so the hierarchy's cells are the uncropped raster's
    const int x0 = std::max(0, b.x - margin) / 64 * 64, y0 = std::max(0, b.y - margin) / 64 * 64;
    const int x1 = std::min(spec.width, b.x + b.width + margin), y1 = std::min(spec.height, b.y + b.height + margin);
    return {x0, y0, std::max(0, x1 - x0), std::max(0, y1 - y0)};
}

}  // namespace

struct DofStage::State {
    DofSettings settings;
    std::shared_ptr<GpuSession> gpu;
    FlareStage::PrimariesSource primaries;  // the working space's RGB -> XYZ, for --bands
    bool flare_follows = false;
    optics::System system;
    std::optional<dof::DeepImage> deep;
    std::unique_ptr<dof::Renderer> renderer;
    std::optional<dof::RayTable> table;
    std::optional<dof::RayTable> bokeh_table;  // the highlights' bokeh shapes: many samples on a coarse grid
    dof::Camera camera;
    std::shared_ptr<DofShared> shared = std::make_shared<DofShared>();
    dof::RayTableSource table_source;
    double layers_ms = 0, rays_ms = 0, trace_ms = 0;

    std::string cache_dir() const;
    // lens rays per pixel where the blur is widest (--dof-max-rays; default 4 x --dof-rays, at most 256)
    int max_rays() const { return std::max(settings.rays, settings.max_rays > 0 ? settings.max_rays : std::min(4 * settings.rays, 256)); }

    dof::Camera camera_for(const Frame& frame) const;
    // The scene's layers over `work`; a flat frame's highlights (dof/highlights.h) are taken out into `highlights`.
    // deep_input: the frame itself is a deep EXR (dof::is_deep_exr of its source).
    dof::LayerStack layers_of(const Frame& frame, bool deep_input, const dof::RayTable& table, const DofRegion& work,
                              std::vector<dof::Highlight>& highlights) const;
};

// Sensor points across the raster's width in the ray table.
constexpr int kRayGrid = 17;
// The bokeh table's lens rays per sensor point (its hull is the highlights' bokeh: corners within about
// 1/30 of its width) and its sensor points across the raster (the pupil's shape changes slowly).
constexpr int kBokehSamples = 1024, kBokehGrid = 9;

std::string DofStage::State::cache_dir() const {
    return flare::cache_dir_of(settings.cache_dir);
}

dof::Camera DofStage::State::camera_for(const Frame& frame) const {
    const ImageSpec& spec = frame.spec;
    dof::Camera c;
    c.system = system;
    c.focus_m = *settings.focus_m;
    c.width = spec.width, c.height = spec.height;
    c.display_width = spec.full_width;
    c.centre_x = spec.full_x + 0.5 * spec.full_width - spec.x;
    c.centre_y = spec.full_y + 0.5 * spec.full_height - spec.y;
    const double efl = dof::focus_of(system, c.focus_m).efl_mm;
    c.sensor_width_mm = settings.fov_deg ? 2.0 * efl * std::tan(0.5 * *settings.fov_deg * std::acos(-1.0) / 180.0)
                                         : parse_sensor(settings.sensor)[0];
    if (!settings.tilt.empty()) {
        const auto t = parse_pair(settings.tilt, "--tilt");
        c.tilt_x_deg = t[0], c.tilt_y_deg = t[1];
    }
    for (const std::string& text : settings.focus_points) {
        dof::FocusPoint p = parse_focus_point(text);
        check_focus_distance(system, p.metres, text);
        p.x += 0.5 - spec.x, p.y += 0.5 - spec.y;  // the pixel's centre, in the raster
        c.focus_points.push_back(p);
    }
    if (settings.bands != 0) {  // mixed into the working space's R, G, B, as the flare's bands
        for (const flare::SpectralPass& p : flare::spectral_passes(settings.bands, working_xyz_to_rgb(primaries))) c.bands.push_back({p.wavelength_nm, p.weight});
    }
    return c;
}

dof::LayerStack DofStage::State::layers_of(const Frame& frame, bool deep_input, const dof::RayTable& t, const DofRegion& work,
                                           std::vector<dof::Highlight>& highlights) const {
    const ImageSpec& spec = frame.spec;
    const int x = spec.x + work.x, y = spec.y + work.y;
    if (deep) return dof::layers_from_deep(dof::reframe(*deep, x, y, work.width, work.height), settings.depth_scale);
    if (deep_input) {  // its samples are the layers
        const dof::DeepImage own = dof::read_deep_exr(frame.source, settings.memory);
        return dof::layers_from_deep(dof::reframe(own, x, y, work.width, work.height), settings.depth_scale);
    }
    const int z = channel_index(frame, settings.depth_channel);
    if (z < 0) throw std::runtime_error(fmt::format("no depth channel \"{}\" for --dof (see --depth-channel)", settings.depth_channel));
    std::vector<float> depth = crop(channels_as_float(frame, {z}), spec.width, 1, work);
    const int a = channel_index(frame, "A");
    const std::vector<float> alpha = a >= 0 ? crop(channels_as_float(frame, {a}), spec.width, 1, work) : std::vector<float>{};
    std::vector<float> rgb = crop(frame.rgb, spec.width, 3, work);
    float zmin = 1e30f, zmax = 0.0f;
    for (float& d : depth) {
        d = static_cast<float>(static_cast<double>(d) * settings.depth_scale);
        if (std::isfinite(d) && d > 0.0f) zmin = std::min(zmin, d), zmax = std::max(zmax, d);
    }
    dof::FlatLayerOptions options;
    // the hidden layer reaches as far as the widest blur of the frame's depth range
    const double reach = t.max_slope * std::max(std::abs(1.0 / static_cast<double>(zmin) - t.focus_w),
                                                std::abs(1.0 / static_cast<double>(std::max(zmax, zmin)) - t.focus_w));
    options.hidden_radius_px = std::clamp(reach + 2.0, 2.0, 64.0);
    highlights = dof::take_highlights(rgb, depth, work.width, work.height, t, work.x, work.y);  // scattered after the gather
    return dof::layers_from_flat(rgb.data(), depth.data(), work.width, work.height, options, alpha.empty() ? nullptr : alpha.data());
}

DofStage::DofStage(DofSettings settings, std::shared_ptr<GpuSession> gpu, bool flare_follows, FlareStage::PrimariesSource working_rgb_to_xyz)
    : state_(std::make_unique<State>()) {
    State& s = *state_;
    if (settings.lens.lens.empty()) throw std::runtime_error("--dof needs --lens");
    if (!settings.focus_m && !settings.focus_points.empty()) settings.focus_m = mean_focus(settings.focus_points);
    if (!settings.focus_m) throw std::runtime_error("--dof needs --focus METRES (or --focus-point X,Y,METRES)");
    s.system = realize_lens(settings.lens).system;
    if (!settings.deep.empty()) {
        std::vector<dof::DeepImage> images;
        for (const std::string& f : split_commas(settings.deep)) {
            require_regular_file(f, "--deep");  // a named pipe would block the open
            if (std::error_code ec; !std::filesystem::exists(f, ec)) throw std::runtime_error(fmt::format("--deep {}: file does not exist", f));
            try {
                check_exr_header(f);  // before OpenEXR reads what the headers declare
            } catch (const std::runtime_error& e) {
                throw std::runtime_error(fmt::format("--deep {}: {}", f, e.what()));
            }
            if (!dof::is_deep_exr(f)) throw std::runtime_error(fmt::format("--deep {}: not a deep EXR (a flat image's depth is its own Z channel)", f));
            images.push_back(dof::read_deep_exr(f, settings.memory));
        }
        s.deep = images.size() == 1 ? std::move(images.front()) : dof::merge_deep(images, settings.memory);
    }
    if (!settings.tilt.empty()) parse_pair(settings.tilt, "--tilt");  // a bad value fails before the first frame
    if (settings.bands != 0) flare::spectral_passes(settings.bands);     // and a bad band count
    for (const std::string& p : settings.focus_points) parse_focus_point(p);
    s.settings = std::move(settings);
    s.gpu = gpu ? std::move(gpu) : std::make_shared<GpuSession>();
    s.flare_follows = flare_follows;
    s.primaries = std::move(working_rgb_to_xyz);
}

DofStage::~DofStage() = default;

std::shared_ptr<DofShared> DofStage::shared() const { return state_->shared; }

void DofStage::process(Frame& frame) {
    State& s = *state_;
    auto t0 = std::chrono::steady_clock::now();
    // the blur spreads over the whole sensor: the display window
    const ImageSpec& spec = frame.spec;
    if (s.deep) check_deep_window(*s.deep, s.settings.deep, spec);
    const bool deep_input = !s.deep && dof::is_deep_exr(frame.source);  // (opens the file: asked once a frame)
    s.settings.memory.check(dof_frame_bytes(spec, s.deep || deep_input),
                            fmt::format("the lens blur over the {}x{} display window", spec.full_width, spec.full_height));
    grow_data_window(frame, spec.full_x, spec.full_y, spec.full_x + spec.full_width, spec.full_y + spec.full_height);
    const dof::Camera camera = s.camera_for(frame);
    if (!s.table || camera.width != s.camera.width || camera.height != s.camera.height || camera.centre_x != s.camera.centre_x ||
        camera.centre_y != s.camera.centre_y) {
        s.table = dof::cached_ray_table(camera, std::max(64, s.max_rays()), kRayGrid, s.cache_dir(), &s.table_source);
        s.bokeh_table.reset();
        s.camera = camera;
    }
    s.rays_ms = ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    // a flat frame's fill around its data window stays black: only the part the blur reaches is traced
    DofRegion work{0, 0, spec.width, spec.height};
    const int z = channel_index(frame, s.settings.depth_channel);
    if (!s.deep && !deep_input && z >= 0) {
        const DofRegion reached = blur_extent(spec, flat_content(frame, z, s.settings.depth_scale), *s.table);
        if (reached.width > 0 && reached.height > 0) work = reached;
    }
    std::vector<dof::Highlight> highlights;
    const dof::LayerStack layers = s.layers_of(frame, deep_input, *s.table, work, highlights);
    s.layers_ms = ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    if (!highlights.empty() && !s.bokeh_table) s.bokeh_table = dof::cached_ray_table(s.camera, kBokehSamples, kBokehGrid, s.cache_dir());
    s.rays_ms += ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    s.gpu->get();
    if (!s.renderer) s.renderer = std::make_unique<dof::Renderer>();
    dof::TraceSettings trace;
    trace.rays = s.settings.rays;
    trace.max_rays = s.max_rays();
    trace.chromatic = s.settings.chromatic;
    trace.origin_x = work.x, trace.origin_y = work.y;
    const int alpha_channel = channel_index(frame, "A");
    std::vector<float> alpha;
    std::vector<float> traced = s.renderer->render(layers, *s.table, trace, alpha_channel >= 0 ? &alpha : nullptr);
    if (!highlights.empty()) {  // the first layer is the visible surface, which hides a farther light
        const std::vector<float> visible(layers.front.begin(), layers.front.begin() + static_cast<std::ptrdiff_t>(traced.size() / 3));
        dof::splat_highlights(highlights, *s.bokeh_table, work.x, work.y, trace.chromatic, visible, work.width, work.height, traced);
    }
    std::vector<float> blurred = uncrop(traced, spec.width, spec.height, 3, work);
    // the alpha blurs with the colour
    if (alpha_channel >= 0) store_channels(frame, {alpha_channel}, uncrop(alpha, spec.width, spec.height, 1, work));
    s.trace_ms = ms_since(t0);
    if (!s.flare_follows) {
        frame.rgb = std::move(blurred);
        return;
    }
    DofShared& sh = *s.shared;
    sh.x = frame.spec.x, sh.y = frame.spec.y, sh.width = frame.spec.width, sh.height = frame.spec.height;
    sh.sharp = frame.rgb;
    sh.blurred = std::move(blurred);
}

std::vector<std::pair<std::string, double>> DofStage::part_times() const {
    return {{"rays", state_->rays_ms}, {"layers", state_->layers_ms}, {"trace", state_->trace_ms}};
}

void DofComposeStage::process(Frame& frame) {
    DofShared& sh = *shared_;
    const ImageSpec& spec = frame.spec;
    for (int y = 0; y < sh.height; ++y) {
        for (int x = 0; x < sh.width; ++x) {
            const std::size_t src = 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(sh.width) + static_cast<std::size_t>(x));
            const std::size_t dst = 3 * (static_cast<std::size_t>(y + sh.y - spec.y) * static_cast<std::size_t>(spec.width) +
                                         static_cast<std::size_t>(x + sh.x - spec.x));
            for (std::size_t c = 0; c < 3; ++c) frame.rgb[dst + c] += sh.blurred[src + c] - sh.sharp[src + c];
        }
    }
}

}  // namespace lensfx::filter

namespace lensfx::filter {

Frame read_deep_exr_frame(const std::string& path, const MemoryBudget& budget) {
    const dof::DeepImage deep = dof::read_deep_exr(path, budget);
    std::vector<float> z;
    const std::vector<float> rgba = dof::flatten_deep(deep, &z);
    Frame frame;
    frame.source = path;
    frame.format = "openexr";
    ImageSpec& spec = frame.spec;
    spec.x = deep.x, spec.y = deep.y, spec.width = deep.width, spec.height = deep.height;
    spec.full_x = deep.full_x, spec.full_y = deep.full_y, spec.full_width = deep.full_width, spec.full_height = deep.full_height;
    spec.compression = "zip";
    for (const char* name : {"R", "G", "B", "A", "Z"}) {
        spec.channelnames.push_back(name);
        spec.channeltypes.push_back(PixelType::float32);
    }
    const std::size_t n = static_cast<std::size_t>(deep.width) * static_cast<std::size_t>(deep.height);
    frame.pixels = PixelBuffer(spec.image_bytes());
    auto* out = reinterpret_cast<float*>(frame.pixels.data());
    for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t c = 0; c < 4; ++c) out[5 * i + c] = rgba[4 * i + c];
        out[5 * i + 4] = z[i];
    }
    find_rgb_channels(frame);
    return frame;
}

DofStages make_dof_stages(DofSettings settings, const FlareSettings& flare, std::shared_ptr<GpuSession> gpu, bool& flare_runs,
                          FlareStage::PrimariesSource working_rgb_to_xyz) {
    flare_runs = !flare.lens.empty() && !(settings.enabled && settings.dof_only);
    if (!settings.enabled) return {};
    settings.lens = flare, settings.sensor = flare.sensor, settings.fov_deg = flare.fov_deg;
    settings.cache_dir = flare.accel.cache_dir;
    settings.bands = flare.bands;
    settings.memory = flare.memory;
    auto blur = std::make_unique<DofStage>(std::move(settings), std::move(gpu), flare_runs, std::move(working_rgb_to_xyz));
    DofStages stages;
    if (flare_runs) stages.compose = std::make_unique<DofComposeStage>(blur->shared());
    stages.blur = std::move(blur);
    return stages;
}

}  // namespace lensfx::filter
