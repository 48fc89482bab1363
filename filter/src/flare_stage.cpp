// The flare stage: lights -> directions and strengths -> GPU ghost images -> added to the frame.
#include <filter/flare_stage.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <fmt/core.h>
#include <opencv2/imgproc.hpp>
#include <unistd.h>

#include <detect/detector.h>
#include <detect/threshold.h>
#include <detect/track_file.h>
#include <detect/tracker.h>
#include <flare/cache.h>
#include <flare/direct_power.h>
#include <flare/footprint.h>
#include <flare/starburst_cache.h>
#include <gpu/band_filter.h>
#include <gpu/acceleration.h>
#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <gpu/measured_renderer.h>
#include <measured/model_file.h>
#include <optics/coating.h>
#include <optics/flare_look.h>
#include <optics/ghosts.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/starburst.h>
#include <optics/system.h>
#include <optics/tracer.h>

#include <filter/float_range.h>
#include <filter/output_files.h>
#include <filter/visibility.h>

#include <filter/option_checks.h>

namespace lensfx::filter {

using flare::FootprintGroup;
using flare::add_extended_starburst;
using flare::convolve_footprint;
using flare::footprint_groups;

namespace {

constexpr double kDegrees = 180.0 / std::numbers::pi;

// "36" or "36x24" (mm); height 0 when not given.
std::array<double, 2> parse_sensor(const std::string& text) {
    double w = 0.0, h = 0.0;
    const auto x = text.find('x');
    try {
        std::size_t used = 0;
        w = std::stod(text.substr(0, x), &used);
        if (used != (x == std::string::npos ? text.size() : x)) throw std::invalid_argument(text);
        if (x != std::string::npos) {
            h = std::stod(text.substr(x + 1), &used);
            if (used != text.size() - x - 1) throw std::invalid_argument(text);
        }
    } catch (const std::exception&) {
        throw std::invalid_argument(fmt::format("--sensor must be WIDTH or WIDTHxHEIGHT in mm, not \"{}\"", text));
    }
    if (!(w > 0.0) || !std::isfinite(w) || h < 0.0 || !std::isfinite(h))
        throw std::invalid_argument(fmt::format("--sensor {}: sizes must be positive", text));
    return {w, h};
}

}  // namespace

void add_flare_options(CLI::App& app, FlareSettings& s) {
    const std::string group = "Flare";
    app.add_option("--lens", s.lens, "Lens preset (lensfx lens list) or lens file (.toml, pbrt .dat, lentil .fx)")->group(group);
    app.add_option("--zoom", s.zoom, "Zoom position: 0..1, or a focal-length label such as 135mm")->group(group);
    app.add_option("--fstop", s.fstop, "Stop the iris down to this f-number")->group(group)->check(CLI::PositiveNumber)->check(finite_number());
    app.add_option("--blades", s.blades, "Iris blade count (0 = round), overriding the lens's")->group(group)->check(CLI::Range(0, 64));
    add_coating_options(app, s.coating, s.coating_spread, group);
    app.add_option("--threshold", s.threshold, "Light-source threshold: luminance (20) or stops above the median (+6ev)")->capture_default_str()->group(group);
    app.add_option("--max-lights", s.max_lights, "The brightest lights rendered per frame")->capture_default_str()->group(group)->check(CLI::Range(0, 4096));
    app.add_option("--sensor", s.sensor, "Sensor width in mm, or WxH (the height follows the frame's aspect)")->capture_default_str()->group(group);
    app.add_option("--fov", s.fov_deg, "Horizontal field of view in degrees (instead of the lens's focal length)")->group(group)->check(CLI::Range(0.1, 179.0))->check(finite_number());
    app.add_option("--gain", s.gain, "Scale of the whole flare (1 = physical)")->capture_default_str()->group(group)->check(CLI::NonNegativeNumber)->check(finite_number());
    app.add_option("--source-gain", s.source_gain, "Strength multiplier for clipped sources")->capture_default_str()->group(group)->check(CLI::NonNegativeNumber)->check(finite_number());
    app.add_flag("--flare-only", s.flare_only, "Write the flare alone, on black")->group(group);
    app.add_option("--tracks", s.tracks, "Render the lights of this track file (lensfx track) instead of detecting")->group(group);
    app.add_option("--gpu", s.gpu, "EGL platform: auto, device (a GPU driver), surfaceless (Mesa)")->capture_default_str()->group(group)
        ->check(CLI::IsMember({"auto", "device", "surfaceless"}));
    app.add_option("--parts", s.parts, "What to render: ghosts, starburst or both (ghosts,starburst)")->capture_default_str()->group(group);
    add_part_gain_options(app, s.controls.ghost_gain, s.starburst_gain, group);
    add_flare_control_options(app, s.controls, group);
    app.add_option("--starburst-scale", s.starburst_scale, "Starburst length relative to its physical length (the spikes' width stays that of wavelength x f-number)")->capture_default_str()->group(group)->check(CLI::PositiveNumber)->check(finite_number());
    app.add_option("--bands", s.bands, "Spectral quality: 0 = RGB (650/550/450 nm), or 7..81 bands over 380..780 nm through the CIE 1931 functions")
        ->capture_default_str()->group(group)->check(CLI::Range(0, flare::kMaxBands));
    app.add_flag("--band-filter", s.band_filter, "With --bands: blur each ghost between neighbouring bands so few bands look continuous (slower)")->group(group);
    app.add_option("--min-light", s.min_light, "Skip lights dimmer than this fraction of the brightest (fading in up to twice that)")
        ->capture_default_str()->group(group)->check(CLI::Range(0.0, 1.0))->check(finite_number());
    app.add_option("--layer", s.layer, "Write the flare as extra channels LAYER.R/G/B, leaving R, G, B as they were")->group(group);
    app.add_option("--visibility", s.visibility,
                   "Scene culling: leave out ghosts that together change no 32-pixel cell's 8-bit sRGB view by more than V codes")
        ->capture_default_str()->group(group)->check(CLI::NonNegativeNumber)->check(finite_number());
    app.add_flag("--no-scene-cull", s.no_scene_cull, "Draw every ghost, however faint against the plate")->group(group);
    app.add_option("--grid", s.grid, "Base ray grid cells per side of each ghost (the adaptive grid scales it)")->capture_default_str()->group(group)->check(CLI::Range(4, 1024));
    app.add_flag("--ringing", s.ringing, "Shade ghosts by the iris with its diffraction ringing (high quality)")->group(group);
    app.add_option("--flare-look", s.flare_look, "Flare look file: per-ghost colour, gain, offset and imperfect symmetry (TOML)")->group(group);
    add_pupil_options(app, s.pupil);
    add_acceleration_options(app, s.accel, "Ghost renderer accelerations");
}

void add_coating_options(CLI::App& app, std::string& coating, double& spread, const std::string& group) {
    app.add_option("--coating", coating,
                   "Anti-reflection coatings of the air-glass surfaces: uncoated (before the 1940s), single (MgF2, "
                   "1950s-70s), multi (broadband multi-layer, since the 1970s) or lens (the lens file's)")
        ->capture_default_str()->group(group)->check(CLI::IsMember({"uncoated", "single", "multi", "lens", "none"}));
    app.add_option("--coating-spread", spread, "Relative thickness spread of the coating layers (seeded per surface; 0 = exact)")
        ->capture_default_str()->group(group)->check(CLI::Range(0.0, 0.49));
}

void apply_coatings(optics::System& system, const std::string& coating, double spread) {
    optics::choose_coatings(system, optics::parse_coating_choice(coating), spread);
}

FlareParts parse_parts(std::string_view text) {
    FlareParts parts{false, false};
    std::size_t begin = 0;
    while (begin <= text.size()) {
        const std::size_t end = std::min(text.find(',', begin), text.size());
        const std::string_view part = text.substr(begin, end - begin);
        if (part == "ghosts") {
            parts.ghosts = true;
        } else if (part == "starburst") {
            parts.starburst = true;
        } else {
            throw std::invalid_argument(fmt::format("--parts: unknown part \"{}\" (ghosts, starburst)", part));
        }
        begin = end + 1;
    }
    return parts;
}

optics::Mat3 xyz_to_rgb_of(const std::array<double, 9>& m) {
    const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                       m[2] * (m[3] * m[7] - m[4] * m[6]);
    if (!(std::abs(det) > 1e-12)) throw std::invalid_argument("the working space's RGB -> XYZ matrix is singular");
    const double k = 1.0 / det;
    return {{{(m[4] * m[8] - m[5] * m[7]) * k, (m[2] * m[7] - m[1] * m[8]) * k, (m[1] * m[5] - m[2] * m[4]) * k},
             {(m[5] * m[6] - m[3] * m[8]) * k, (m[0] * m[8] - m[2] * m[6]) * k, (m[2] * m[3] - m[0] * m[5]) * k},
             {(m[3] * m[7] - m[4] * m[6]) * k, (m[1] * m[6] - m[0] * m[7]) * k, (m[0] * m[4] - m[1] * m[3]) * k}}};
}

double min_light_fade(double relative, double min_light) {
    if (!(min_light > 0.0)) return 1.0;
    const double t = std::clamp((relative - min_light) / min_light, 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

}  // namespace

// The largest strength a light is given: with the ghosts' own peak values and many lights summed it
// stays far inside float range, so a huge --gain or flux saturates the frame instead of making it NaN.
constexpr double kMaxLightScale = 1e30;

// The `count` brightest lights (luminance times weight), in their order; the rest are left out.
void keep_brightest(std::vector<detect::Light>& lights, std::size_t count) {
    if (lights.size() <= count) return;
    auto strength = [](const detect::Light& l) {
        return (detect::kRec709Luma[0] * l.flux[0] + detect::kRec709Luma[1] * l.flux[1] + detect::kRec709Luma[2] * l.flux[2]) * l.weight;
    };
    if (count == 0) {
        lights.clear();
        return;
    }
    std::vector<double> strengths;
    for (const auto& l : lights) strengths.push_back(strength(l));
    std::nth_element(strengths.begin(), strengths.begin() + static_cast<std::ptrdiff_t>(count - 1), strengths.end(), std::greater<>());
    const double cut = strengths[count - 1];
    // Every light above the cut, and as many at it as fill the count (the first ones).
    std::size_t ties = count - static_cast<std::size_t>(std::count_if(strengths.begin(), strengths.end(), [&](double v) { return v > cut; }));
    std::erase_if(lights, [&](const detect::Light& l) {
        const double v = strength(l);
        if (v > cut) return false;
        if (v == cut && ties > 0) {
            --ties;
            return false;
        }
        return true;
    });
}

// The files the flare options name, refused when they are not regular files (a FIFO or /dev/zero would
// hang the reader); --layer names that an EXR channel cannot hold; iris blade counts no iris has.
void check_input_files(const FlareSettings& s) {
    if (std::filesystem::exists(s.lens)) require_regular_file(s.lens, "--lens");
    require_regular_file(s.tracks, "--tracks");
    require_regular_file(s.flare_look, "--flare-look");
    if (s.layer.size() > 253) throw std::invalid_argument(fmt::format("--layer: {} characters; EXR channel names hold 255 (the layer and \".R\")", s.layer.size()));
    if (s.blades && (*s.blades == 1 || *s.blades == 2))
        throw std::invalid_argument(fmt::format("--blades {}: 0 (round) or 3 to 64", *s.blades));
}

namespace {

// Bytes a frame holds while its flare is made: its pixels (none while release_rgb_pixels() has them in
// `rgb`) and R, G, B as float; the flare image over the display window unless the flare goes into the
// frame directly; the GL targets (RGBA float at full size and at 1/2..1/16, read back in bands) for
// ghosts, and a single-light image for extended lights; at most the data window's growth to the display
// window with its R, G, B; a layer's copy.
double flare_frame_bytes(const Frame& frame, bool into_frame, bool ghosts, bool extended, bool layer) {
    const ImageSpec& spec = frame.spec;
    const double display = bytes_of(spec.full_width, spec.full_height, 1.0);
    const double data = static_cast<double>(spec.pixel_count());
    const double pixel = static_cast<double>(spec.pixel_bytes()), rgb = 3.0 * sizeof(float);
    double bytes = static_cast<double>(frame.pixels.size()) + data * rgb;
    if (!into_frame) bytes += display * rgb + display * (pixel + rgb);  // the flare image; growth at most
    if (ghosts) bytes += gpu::render_target_bytes(spec.full_width, spec.full_height);
    if (extended) bytes += display * rgb;
    if (layer) bytes += display * (rgb + pixel + rgb);
    return bytes;
}

// The flare image over the display window added to the frame: the data window grows to hold the flare
// where it lands; into R, G, B, or as channels LAYER.R/G/B when `layer` is not empty.
void composite(Frame& frame, const std::vector<float>& flare_rgb, const FlareGeometry& geo, const std::string& layer_name) {
    const bool layer = !layer_name.empty();
    int bx0 = geo.width, by0 = geo.height, bx1 = 0, by1 = 0;
    for (int y = 0; y < geo.height; ++y) {
        const float* row = flare_rgb.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(geo.width) * 3;
        auto lit = [&](int x) { return row[x * 3] != 0.0f || row[x * 3 + 1] != 0.0f || row[x * 3 + 2] != 0.0f; };
        int first = 0;
        while (first < geo.width && !lit(first)) ++first;
        if (first == geo.width) continue;
        int last = geo.width - 1;
        while (!lit(last)) --last;
        bx0 = std::min(bx0, first);
        bx1 = std::max(bx1, last + 1);
        by0 = std::min(by0, y);
        by1 = y + 1;
    }
    if (bx1 > bx0)
        grow_data_window(frame, frame.spec.full_x + bx0, frame.spec.full_y + by0, frame.spec.full_x + bx1,
                         frame.spec.full_y + by1);
    const int dx0 = frame.spec.x - frame.spec.full_x;
    const int dy0 = frame.spec.y - frame.spec.full_y;
    std::vector<float> layer_rgb;
    if (layer) layer_rgb.assign(frame.pixel_count() * 3, 0.0f);
    float* target = layer ? layer_rgb.data() : frame.rgb.data();
    // Where the data window and the display window overlap, row by row.
    const int x0 = std::max(0, -dx0), x1 = std::min(frame.spec.width, geo.width - dx0);
    for (int y = 0; y < frame.spec.height && x1 > x0; ++y) {
        const int fy = y + dy0;
        if (fy < 0 || fy >= geo.height) continue;
        float* px = target + (static_cast<std::size_t>(y) * static_cast<std::size_t>(frame.spec.width) + static_cast<std::size_t>(x0)) * 3;
        const float* f = flare_rgb.data() + (static_cast<std::size_t>(fy) * static_cast<std::size_t>(geo.width) +
                                             static_cast<std::size_t>(x0 + dx0)) * 3;
        const std::size_t n = static_cast<std::size_t>(x1 - x0) * 3;
        for (std::size_t i = 0; i < n; ++i) px[i] = added_within_float(px[i], f[i]);
    }
    if (layer) add_rgb_layer(frame, layer_name, layer_rgb);
}

// How far (pixels) a light's footprint scaled by m spreads a ghost beyond where the ghost lands: its whole
// diagonal (the centroid may lie anywhere in it), and a reduced image's interpolation.
double footprint_reach_px(const detect::Shape& shape, double m) {
    return std::abs(m) * shape.cell * std::hypot(static_cast<double>(shape.width), static_cast<double>(shape.height)) + 4.0;
}

}  // namespace

struct FlareStage::State {
    FlareSettings settings;
    optics::System system;
    double efl_mm = 0.0;
    std::array<double, 2> sensor{};
    std::optional<detect::TrackFile> tracks;
    detect::Detector detector;
    detect::Tracker tracker;
    std::shared_ptr<GpuSession> gpu_session;  // its context is made ahead and taken at the first frame with a light
    std::unique_ptr<gpu::FlareRenderer> renderer;
    std::optional<measured::MeasuredLens> measured_lens;  // a measured preset instead of a prescription
    std::unique_ptr<gpu::MeasuredRenderer> measured_renderer;
    FlareParts parts;
    double f_number = 0.0;
    optics::StarburstOptions starburst_options;  // the pupil's dirt and image, read at start
    gpu::GpuFlareOptions render_options;         // grid, ringing, accelerations, --flare-look styles
    PrimariesSource primaries_source;
    std::optional<optics::Mat3> xyz_to_rgb;       // the working space's, fixed at the first light
    std::vector<flare::SpectralPass> passes;        // with those primaries
    std::optional<optics::Starburst> starburst;  // computed (or read from the cache) at the first light
    flare::DirectPowerTable direct;                     // made at the first light, over the frame's corners
    std::string direct_key;                      // what the table depends on (its cache file's name)
    std::filesystem::path direct_file;
    std::string lens_text;                       // the lens as TOML: part of the table's key
    std::vector<optics::Ghost> ghosts;           // the lens's ghosts, their imaging and axial power: for
    std::vector<optics::GhostImaging> imaging;   // extended lights, made at the first one
    std::vector<double> axial_power;
    std::vector<std::pair<std::string, double>> times;  // of the last frame
    std::vector<std::pair<std::string, double>> figures;  // of the last frame
    std::vector<std::pair<std::string, double>> detected;  // the detector's figures of the last frame
    DetectionInput detection_input;  // the plate as the detector sees it (--matte, --add-light)
    LightSummary summary;
    std::vector<float> flare_rgb;  // the frame's flare over the display window; kept to reuse its memory

    State(FlareSettings s, std::shared_ptr<GpuSession> g, PrimariesSource primaries)
        : settings(std::move(s)),
          detector([&] {
              detect::DetectorOptions o;
              o.threshold = detect::Threshold::parse(settings.threshold);
              o.max_lights = settings.max_lights;
              return o;
          }()),
          detection_input(settings.controls) {
        gpu_session = g ? std::move(g) : std::make_shared<GpuSession>();
        summary.threshold_text = settings.threshold;
        summary.tracks = settings.tracks;
        primaries_source = std::move(primaries);
        check_input_files(settings);
        if (measured::is_measured_file(settings.lens)) {
            measured_lens = measured::read_measured(settings.lens);
            efl_mm = measured_lens->focal_length_mm;
        } else {
            load_physical_lens();
        }
        parts = parse_parts(settings.parts);
        parts.starburst = parts.starburst && !measured_lens;  // a measured lens models its ghosts only
        parts.ghosts = parts.ghosts && settings.controls.ghost_gain > 0.0;  // a gain of 0 renders nothing
        parts.starburst = parts.starburst && settings.starburst_gain > 0.0;
        if (!settings.tracks.empty() && detection_input.changes_the_plate())
            throw std::invalid_argument("--matte, --matte-channel and --add-light act on detection; with --tracks, edit the track file");
        sensor = parse_sensor(settings.sensor);
        if (!settings.tracks.empty()) tracks = detect::read_track_file(settings.tracks);
        starburst_options = filter::starburst_options(settings.pupil);
        render_options.grid = settings.grid;
        render_options.ringing = settings.ringing;
        render_options.accel = settings.accel.acceleration();
        render_options.memory = settings.memory;
        // A lens of many surfaces has ghosts by the square of them: refused here, before any table is built.
        if (!measured_lens) gpu::check_ghost_tables(system, settings.bands == 0 ? 3 : static_cast<std::size_t>(settings.bands), settings.memory);
        if (!settings.flare_look.empty() && !measured_lens)
            render_options.styles =
                optics::ghost_styles(optics::read_flare_look(settings.flare_look), optics::enumerate_ghosts(system));
        if (settings.bands != 0) flare::spectral_passes(settings.bands);  // checks the band count
        if (settings.band_filter && settings.bands == 0) throw std::invalid_argument("--band-filter needs --bands N");
        if (gpu_session->platform.empty() || gpu_session->platform == "auto") gpu_session->platform = settings.gpu;
        if (parts.ghosts && settings.gain > 0.0) gpu_session->prepare();
    }

    // The prescription, realized at --zoom and --fstop with its coatings and blades.
    void load_physical_lens() {
        const optics::Lens lens = optics::load_lens(settings.lens);
        const double zoom = settings.zoom.empty() ? 0.0 : optics::parse_zoom(lens, settings.zoom);
        system = optics::realize(lens, zoom, settings.fstop);
        apply_coatings(system, settings.coating, settings.coating_spread);
        lens_text = fmt::format("{}\nzoom {:.17g} fstop {:.17g} blades {} coating {} spread {:.17g}", optics::write_lens_toml(lens), zoom,
                                settings.fstop.value_or(0.0), settings.blades.value_or(-1), settings.coating, settings.coating_spread);
        if (settings.blades) system.aperture.blades = *settings.blades;
        const optics::Paraxial first_order = optics::paraxial(system);
        efl_mm = first_order.efl_mm;
        f_number = first_order.f_number;
    }

    // A measured lens's ghosts for every light (no starburst): each light's recorded energy over the
    // capture's light energy scales the fitted ghosts (the ratio paper equation 2 keeps, in the frame's own
    // units), times the light's gains; composited like the physical flare.
    void add_measured_flare(Frame& frame, const std::vector<detect::Light>& lights, const FlareGeometry& geo) {
        const auto t = Clock::now();
        if (!measured_renderer) measured_renderer = std::make_unique<gpu::MeasuredRenderer>(gpu_session->get());
        std::vector<float> flare(static_cast<std::size_t>(geo.width) * static_cast<std::size_t>(geo.height) * 3, 0.0f);
        measured::MeasuredView view{0.0, 0.0, geo.sensor_width_mm, geo.sensor_height_mm, geo.width, geo.height};
        for (const detect::Light& light : lights) {
            const auto [ax, ay] = geo.angles_at(light.x, light.y);
            view.angle_x_deg = ax, view.angle_y_deg = ay;
            std::array<double, 3> scale{};
            for (std::size_t c = 0; c < 3; ++c)
                scale[c] = std::min(std::max(0.0, light.flux[c]) * geo.pixel_area_mm2() / measured_lens->capture.light_energy * boost(light, false) *
                                        settings.controls.ghost_gain, kMaxLightScale);
            measured_renderer->render_add(*measured_lens, view, scale, flare.data());
        }
        times.emplace_back("ghosts", ms_since(t));
        composite(frame, flare, geo, settings.layer);
    }

    // The working space's primaries and the passes in them; asked once, at the first light.
    void resolve_primaries() {
        if (xyz_to_rgb) return;
        const auto rgb_to_xyz = primaries_source ? primaries_source() : std::nullopt;
        xyz_to_rgb = rgb_to_xyz ? xyz_to_rgb_of(*rgb_to_xyz) : optics::kXyzToRec709;
        gpu::FlareView view;
        view.bands = settings.bands;
        view.xyz_to_rgb = *xyz_to_rgb;
        passes = view.passes();
    }

    FlareGeometry geometry(const Frame& frame) const {
        FlareGeometry g;
        g.width = frame.spec.full_width;
        g.height = frame.spec.full_height;
        g.sensor_width_mm = sensor[0];
        const auto aspect = static_cast<double>(frame.spec.pixel_aspect);
        g.sensor_height_mm = sensor[1] > 0.0 ? sensor[1] : sensor[0] * g.height / (g.width * aspect);
        g.focal_mm = settings.fov_deg ? 0.5 * g.sensor_width_mm / std::tan(0.5 * *settings.fov_deg / kDegrees) : efl_mm;
        return g;
    }

    std::vector<detect::Light> lights(const Frame& frame) {
        if (tracks) {
            std::vector<detect::Light> found = tracks->lights_at(frame.number);
            if (tracks->width > 0 && tracks->width != frame.spec.full_width)
                throw std::runtime_error(fmt::format("track file {} is for {}x{} frames, this one is {}x{}", settings.tracks,
                                                     tracks->width, tracks->height, frame.spec.full_width, frame.spec.full_height));
            keep_brightest(found, static_cast<std::size_t>(settings.max_lights));
            return found;
        }
        const detect::Detection found = detector.detect(detection_input.view(frame));
        const detect::FrameStats& st = found.stats;
        detected = {{"sources", static_cast<double>(found.sources.size())}, {"brightest", st.max_luminance}, {"threshold", st.threshold}};
        if (summary.lights_per_frame.empty() || st.max_luminance > summary.brightest_luminance) {
            summary.brightest_luminance = st.max_luminance;
            summary.threshold_there = st.threshold;
        }
        return tracker.update(found);
    }

    // The strength of a light's whole flare beyond physics: the artistic gains that apply to it, multiplied
    // in double (each is finite and >= 0; their product may still overflow, and is then the largest double).
    double boost(const detect::Light& light, bool extended) const {
        const double b = (light.clipped ? settings.source_gain : 1.0) * settings.gain * light.weight * light.gain *
                         (extended ? settings.controls.extended_gain : 1.0);
        return std::isfinite(b) ? b : std::numeric_limits<double>::max();
    }
};

FlareStage::FlareStage(FlareSettings settings, std::shared_ptr<GpuSession> gpu, PrimariesSource working_rgb_to_xyz)
    : state_(std::make_unique<State>(std::move(settings), std::move(gpu), std::move(working_rgb_to_xyz))) {}
FlareStage::~FlareStage() = default;

std::vector<std::pair<std::string, double>> FlareStage::part_times() const { return state_->times; }
std::vector<std::pair<std::string, double>> FlareStage::frame_figures() const { return state_->figures; }
const LightSummary& FlareStage::summary() const { return state_->summary; }

void FlareStage::process(Frame& frame) {
    State& s = *state_;
    s.times.clear();
    s.figures.clear();
    s.detected.clear();
    if (!frame.has_rgb()) {
        std::string names;
        for (const auto& n : frame.spec.channelnames) names += (names.empty() ? "" : ", ") + n;
        throw std::runtime_error(fmt::format("the flare needs R, G, B channels (or LAYER.R, .G, .B); this frame has {}", names.empty() ? "none" : names));
    }
    for (int c : frame.rgb_channels)
        if (frame.spec.channel_type(c) == PixelType::uint32)
            throw std::runtime_error(fmt::format("channel {} is uint32 (integers such as ids, not light): the flare needs half or float R, G, B",
                                                 frame.spec.channel_name(c)));
    auto t = Clock::now();
    std::vector<detect::Light> lights = s.lights(frame);
    s.times.emplace_back("detect", ms_since(t));
    const FlareParts& parts = s.parts;
    if (s.settings.flare_only) std::fill(frame.rgb.begin(), frame.rgb.end(), 0.0f);

    // Lights too dim against the brightest to show are left out, fading as they approach the limit.
    auto luminous = [](const detect::Light& l) {
        return detect::kRec709Luma[0] * l.flux[0] + detect::kRec709Luma[1] * l.flux[1] + detect::kRec709Luma[2] * l.flux[2];
    };
    double brightest = 0.0;
    for (const auto& l : lights) brightest = std::max(brightest, luminous(l) * l.weight * l.gain);
    std::erase_if(lights, [&](detect::Light& l) {
        l.weight *= brightest > 0.0 ? min_light_fade(luminous(l) * l.weight * l.gain / brightest, s.settings.min_light) : 0.0;
        return !(l.weight > 0.0);
    });
    s.summary.lights_per_frame.push_back(static_cast<int>(lights.size()));
    s.figures.emplace_back("lights", static_cast<double>(lights.size()));
    s.figures.insert(s.figures.end(), s.detected.begin(), s.detected.end());

    const bool layer = !s.settings.layer.empty();
    if (lights.empty() || s.settings.gain == 0.0 || (!parts.ghosts && !parts.starburst)) {  // nothing to draw (the context made ahead waits)
        if (layer) add_rgb_layer(frame, s.settings.layer, std::vector<float>(frame.pixel_count() * 3, 0.0f));
        return;
    }

    const FlareGeometry geo = s.geometry(frame);
    if (s.measured_lens) return s.add_measured_flare(frame, lights, geo);
    s.resolve_primaries();
    if (!s.renderer && parts.ghosts) s.renderer = std::make_unique<gpu::FlareRenderer>(s.gpu_session->get());
    // Scene culling needs the plate the flare is added to: not with --flare-only or --layer (composited later).
    const bool scene_cull = parts.ghosts && !s.settings.no_scene_cull && !s.settings.flare_only && !layer;
    s.render_options.visibility = scene_cull ? plate_visibility(frame, s.settings.visibility) : nullptr;
    const gpu::GpuFlareOptions& render_options = s.render_options;
    int ghosts_drawn = 0, ghosts_culled = 0;
    auto count_ghosts = [&] {
        ghosts_drawn += s.renderer->last_stats().ghosts_drawn;
        ghosts_culled += s.renderer->last_stats().ghosts_culled;
    };

    // The flare over the display window, composited into the frame once every light is in; when the data
    // window is the display window (and R, G, B are the target), added into the frame's R, G, B directly.
    const std::size_t display_px = static_cast<std::size_t>(geo.width) * static_cast<std::size_t>(geo.height);
    const bool into_frame = frame.spec.data_is_display() && !layer;
    const bool any_extended = std::any_of(lights.begin(), lights.end(), [](const detect::Light& l) {
        return l.shape && !l.shape->weights.empty();
    });
    s.settings.memory.check(flare_frame_bytes(frame, into_frame, parts.ghosts, any_extended, layer),
                            fmt::format("the flare over the {}x{} display window", geo.width, geo.height));
    if (into_frame) s.flare_rgb = {};
    std::vector<float>& flare_rgb = into_frame ? frame.rgb : s.flare_rgb;
    if (!into_frame) flare_rgb.assign(display_px * 3, 0.0f);
    double direct_ms = 0.0, starburst_ms = 0.0, ghosts_ms = 0.0, extended_ms = 0.0;
    gpu::FlareView view;  // the frame as the lens sees it; each light sets the angles
    view.sensor_width_mm = geo.sensor_width_mm;
    view.sensor_height_mm = geo.sensor_height_mm;
    view.width = geo.width;
    view.height = geo.height;
    view.bands = s.settings.bands;
    view.xyz_to_rgb = *s.xyz_to_rgb;
    std::vector<gpu::ScaledLight> point_lights;  // their ghosts drawn together: one clear and read-back
    std::vector<float> group_rgb;  // an extended light's group of ghosts, before its footprint
    for (const detect::Light& light : lights) {
        t = Clock::now();
        const auto [ax, ay] = geo.angles_at(light.x, light.y);
        const bool extended = light.shape && !light.shape->weights.empty();
        if (s.direct.empty()) {
            const auto [cx, cy] = geo.angles_at(0.0, 0.0);
            const double corner = std::atan(std::hypot(std::tan(cx / kDegrees), std::tan(cy / kDegrees))) * kDegrees;
            s.direct = flare::DirectPowerTable(s.system, std::min(89.0, 1.02 * corner), 12, 96, s.passes);
            s.direct_key = fmt::format("lensfx-direct-2\n{}\nfield {:.17g}\n{}", s.lens_text, s.direct.max_field_deg(),
                                       flare::passes_key(s.passes));
            if (const std::string dir = flare::cache_dir_of(s.settings.accel.cache_dir); !dir.empty()) {
                s.direct_file = flare::cache_file(dir, "direct", flare::key_hash(s.direct_key));
                s.direct.load(s.direct_file, s.direct_key);
            }
        }
        const int traced_before = s.direct.traced();
        const std::array<double, 3> direct = s.direct.at(ax, ay);
        if (s.direct.traced() != traced_before && !s.direct_file.empty()) s.direct.save(s.direct_file, s.direct_key);
        const double boost = s.boost(light, extended);
        std::array<float, 3> scale{};  // of the ghosts
        bool any = false;
        for (std::size_t c = 0; c < 3; ++c) {
            // Irradiance of the light at the lens: the energy its image recorded over what unit irradiance gives.
            if (direct[c] <= 0.0) continue;
            const double irradiance = std::max(0.0, light.flux[c]) * geo.pixel_area_mm2() / direct[c];
            scale[c] = to_float_within(std::min(irradiance * boost * s.settings.controls.ghost_gain, kMaxLightScale));
            any = any || irradiance * boost > 0.0;
        }
        direct_ms += ms_since(t);
        if (!any) continue;  // outside what the lens images: nothing reaches the sensor

        if (parts.starburst) {
            t = Clock::now();
            if (!s.starburst) {
                optics::StarburstOptions starburst_options = s.starburst_options;
                starburst_options.xyz_to_rgb = *s.xyz_to_rgb;
                s.starburst = flare::cached_starburst(s.system.aperture, starburst_options, flare::cache_dir_of(s.settings.accel.cache_dir));
            }
            // The light's diffraction pattern carries its recorded energy, centred on its image; its core is
            // already in the recorded pixels, so only the spikes and rings are added.
            std::array<double, 3> energy{};
            for (std::size_t c = 0; c < 3; ++c)
                energy[c] = std::min(std::max(0.0, light.flux[c]) * geo.pixel_area_mm2() * s.settings.starburst_gain * boost, kMaxLightScale);
            // Never leave out more than the light's own pixel, or a small light would show a hole.
            const double texel_px = s.starburst->texel_per_fnumber_mm * s.f_number / (geo.sensor_width_mm / geo.width);
            const double core_texels = std::min(optics::starburst_core_radius_texels(*s.starburst), 0.75 / texel_px);
            // An extended light's diffraction is every point's pattern over its footprint (the direct image),
            // less what its recorded pixels hold (footprint.h).
            const double f_number = s.f_number;
            const double pixel_w_mm = geo.sensor_width_mm / geo.width, pixel_h_mm = geo.sensor_height_mm / geo.height;
            if (extended) {
                // An extended light's pattern is spread over its footprint from the texture alone, which
                // --starburst-scale enlarges as a whole (the point lights' spikes are lengthened instead).
                add_extended_starburst(*s.starburst, f_number * s.settings.starburst_scale, light.x, light.y, energy, pixel_w_mm, pixel_h_mm,
                                       core_texels, *light.shape, flare_rgb.data(), geo.width, geo.height);
            } else {
                optics::draw_starburst(*s.starburst, s.system.aperture, f_number, s.settings.starburst_scale, light.x,
                                       light.y, energy, pixel_w_mm, pixel_h_mm, flare_rgb.data(), geo.width, geo.height,
                                       core_texels);
            }
            starburst_ms += ms_since(t);
        }
        if (!parts.ghosts) continue;

        view.angle_x_deg = ax;
        view.angle_y_deg = ay;
        std::vector<FootprintGroup> groups(1);  // a point light: every ghost, no footprint
        if (extended) {
            t = Clock::now();
            if (s.imaging.empty()) {
                s.ghosts = optics::enumerate_ghosts(s.system);
                s.imaging = optics::ghost_imaging(s.system, s.ghosts);
                const optics::TraceSystem traced(s.system, optics::kLambdaD_nm);
                for (const optics::Ghost& g : s.ghosts) s.axial_power.push_back(optics::ghost_axial_factor(traced, g));
            }
            groups = footprint_groups(s.ghosts, s.imaging, s.axial_power, *light.shape, geo.sensor_width_mm / geo.width);
            extended_ms += ms_since(t);
        }
        const bool as_point = groups.size() == 1 && groups[0].magnification == 0.0;
        if (as_point) groups[0].ghosts.clear();  // every ghost: a point light's selection, and its caches
        if (as_point && !s.settings.band_filter) {
            point_lights.push_back({ax, ay, {static_cast<double>(scale[0]), static_cast<double>(scale[1]), static_cast<double>(scale[2])}});  // drawn with the frame's others
            continue;
        }
        const gpu::ScaledLight scaled{ax, ay, {static_cast<double>(scale[0]), static_cast<double>(scale[1]), static_cast<double>(scale[2])}};
        for (const FootprintGroup& group : groups) {
            t = Clock::now();
            if (s.settings.band_filter) {
                view.only_ghosts = group.ghosts;
                gpu::FlareImage flare = gpu::render_band_filtered(
                    s.system, view, [&](const gpu::FlareView& one) { return s.renderer->render(s.system, one, render_options); });
                view.only_ghosts.clear();
                if (flare.width != geo.width || flare.height != geo.height)
                    throw std::runtime_error(fmt::format("the ghost image is {}x{}, the frame {}x{}", flare.width,
                                                         flare.height, geo.width, geo.height));
                group_rgb = std::move(flare.rgb);
                for (std::size_t i = 0; i < display_px; ++i)
                    for (std::size_t c = 0; c < 3; ++c) group_rgb[i * 3 + c] = scaled_within_float(group_rgb[i * 3 + c], scale[c]);
            } else {
                // The group's ghosts out of the whole lens's (one bounds table and estimate for all groups),
                // at the light's strength, so scene culling weighs them in the frame's units.
                gpu::GpuFlareOptions group_options = render_options;
                group_options.draw_only = group.ghosts;
                group_options.spread_px = group.magnification != 0.0 ? footprint_reach_px(*light.shape, group.magnification) : 0.0;
                group_rgb.assign(display_px * 3, 0.0f);
                s.renderer->render_add(s.system, view, std::span(&scaled, 1), group_options, group_rgb);
            }
            count_ghosts();
            ghosts_ms += ms_since(t);
            if (group.magnification != 0.0) {
                t = Clock::now();
                convolve_footprint(group_rgb, geo.width, geo.height, *light.shape, group.magnification);
                extended_ms += ms_since(t);
            }
            for (std::size_t i = 0; i < display_px * 3; ++i) flare_rgb[i] = added_within_float(flare_rgb[i], group_rgb[i]);
        }
    }
    if (!point_lights.empty()) {
        t = Clock::now();
        s.renderer->render_add(s.system, view, point_lights, render_options, flare_rgb);
        count_ghosts();
        ghosts_ms += ms_since(t);
    }
    // Above 4K the GL targets (over 300 MB) are not kept for the next frame: making them again costs
    // little against rendering at that size, and the frame is stored and written without them.
    constexpr std::size_t kKeepTargetsPixels = std::size_t{4096} * 4096;
    if (s.renderer && display_px > kKeepTargetsPixels) s.renderer->release_targets();
    s.figures.emplace_back("ghosts drawn", static_cast<double>(ghosts_drawn));
    s.figures.emplace_back("ghosts culled", static_cast<double>(ghosts_culled));
    s.summary.ghosts_drawn += ghosts_drawn;
    s.summary.ghosts_culled += ghosts_culled;
    s.times.emplace_back("direct", direct_ms);
    s.times.emplace_back("starburst", starburst_ms);
    s.times.emplace_back("ghosts", ghosts_ms);
    s.times.emplace_back("extended", extended_ms);

    t = Clock::now();
    if (!into_frame) composite(frame, flare_rgb, geo, s.settings.layer);
    s.times.emplace_back("composite", ms_since(t));
}

}  // namespace lensfx::filter
