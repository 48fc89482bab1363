// The flare stage: lights -> directions and strengths -> GPU ghost images -> added to the frame.
#include <filter/flare_stage.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <limits>
#include <numbers>
#include <optional>
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
#include <flare/flare.h>
#include <flare/convolve.h>
#include <flare/footprint.h>
#include <flare/starburst_cache.h>
#include <gpu/address_space.h>
#include <gpu/band_filter.h>
#include <gpu/flare_renderer.h>
#include <gpu/measured_renderer.h>
#include <measured/model_file.h>
#include <optics/coating.h>
#include <optics/flare_look.h>
#include <optics/ghosts.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/starburst.h>
#include <optics/stopwatch.h>
#include <optics/system.h>
#include <optics/tracer.h>

#include <flare/float_range.h>
#include <flare/image_ops.h>
#include <filter/output_files.h>
#include <filter/visibility.h>

#include <filter/colour/matrix.h>

namespace lensfx::filter {

using flare::ConstRgbView;
using flare::FootprintGroup;
using flare::Region;
using flare::RgbView;
using flare::add;
using flare::nonzero_region;
using flare::scaled_within_float;
using flare::to_float_within;
using flare::add_extended_starburst;
using flare::convolve_footprint;
using flare::footprint_groups;

namespace {

constexpr double kDegrees = 180.0 / std::numbers::pi;

}  // namespace

double min_light_fade(double relative, double min_light) {
    if (!(min_light > 0.0)) return 1.0;
    const double t = std::clamp((relative - min_light) / min_light, 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

optics::Mat3 working_xyz_to_rgb(const FlareStage::PrimariesSource& working_rgb_to_xyz) {
    const auto rgb_to_xyz = working_rgb_to_xyz ? working_rgb_to_xyz() : std::nullopt;
    return rgb_to_xyz ? colour::inverse(*rgb_to_xyz) : optics::kXyzToRec709;
}

namespace {

using Clock = std::chrono::steady_clock;

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
// hang the reader); --layer names that an EXR channel cannot hold (--blades: realize_lens).
void check_input_files(const FlareSettings& s) {
    if (std::filesystem::exists(s.lens)) require_regular_file(s.lens, "--lens");
    require_regular_file(s.tracks, "--tracks");
    require_regular_file(s.flare_look, "--flare-look");
    if (s.layer.size() > 253) throw std::invalid_argument(fmt::format("--layer: {} characters; EXR channel names hold 255 (the layer and \".R\")", s.layer.size()));
}

// The settings, once check_input_files has passed them (before any file they name is read).
FlareSettings with_files_checked(FlareSettings s) {
    check_input_files(s);
    return s;
}

namespace {

// A light's per-channel ghost scale in the renderer's precision.
std::array<double, 3> as_double(const std::array<float, 3>& v) {
    return {static_cast<double>(v[0]), static_cast<double>(v[1]), static_cast<double>(v[2])};
}

// Bytes a frame holds while its flare is made: its pixels (none while release_rgb_pixels() has them in
// `rgb`) and R, G, B as float; the flare image over the display window unless the flare goes into the
// frame directly; the GL targets (RGBA float at full size and at 1/2..1/32, read back in bands) for
// ghosts, and for extended lights a group's image, a reduced group's image being spread while the next is drawn
// (at most a quarter of an image) and the sums of the reduced ones (LevelSums: under a third of an image); at
// most the data window's growth to the display window with its R, G, B; a layer's copy.
double flare_frame_bytes(const Frame& frame, bool into_frame, bool ghosts, bool extended, bool layer) {
    const ImageSpec& spec = frame.spec;
    const double display = bytes_of(spec.full_width, spec.full_height, 1.0);
    const double data = static_cast<double>(spec.pixel_count());
    const double pixel = static_cast<double>(spec.pixel_bytes()), rgb = 3.0 * sizeof(float);
    double bytes = static_cast<double>(frame.pixels.size()) + data * rgb;
    if (!into_frame) bytes += display * rgb + display * (pixel + rgb);  // the flare image; growth at most
    if (ghosts) bytes += gpu::render_target_bytes(spec.full_width, spec.full_height);
    if (extended) bytes += display * rgb * (1.0 + 0.25 + 1.0 / 3.0);
    if (layer) bytes += display * (rgb + pixel + rgb);
    return bytes;
}

// Step 4, composite: the flare image over the display window added to the frame (ImageBufAlgo-like ops,
// image_ops.h): the data window grows to hold where the flare is not zero; into R, G, B, or as channels
// LAYER.R/G/B when `layer_name` is not empty.
void composite(Frame& frame, const std::vector<float>& flare_rgb, const FlareGeometry& geo, const std::string& layer_name) {
    const ConstRgbView flare{flare_rgb.data(), frame.spec.full_x, frame.spec.full_y, geo.width, geo.height};
    if (const Region lit = nonzero_region(flare); !lit.empty()) grow_data_window(frame, lit.x0, lit.y0, lit.x1, lit.y1);
    const bool layer = !layer_name.empty();
    std::vector<float> layer_rgb;
    if (layer) layer_rgb.assign(frame.pixel_count() * 3, 0.0f);
    const RgbView target{layer ? layer_rgb.data() : frame.rgb.data(), frame.spec.x, frame.spec.y, frame.spec.width, frame.spec.height};
    add(target, flare, flare.region());
    if (layer) add_rgb_layer(frame, layer_name, layer_rgb);
}

// How far (pixels) a light's footprint scaled by m spreads a ghost beyond where the ghost lands: its whole
// diagonal (the centroid may lie anywhere in it), and a reduced image's interpolation.
double footprint_reach_px(const detect::Shape& shape, double m) {
    return std::abs(m) * shape.cell * std::hypot(static_cast<double>(shape.width), static_cast<double>(shape.height)) + 4.0;
}

// An extended light's magnified groups, each convolved with its footprint at its level (1/2 .. 1/16 of the
// frame), summed per level and then enlarged into the frame once per level (flare::add_enlarged); together
// under a third of the frame's image. A reduced group is convolved and summed on a worker thread (spread)
// while the GPU draws the light's next group: its image is one of two, drawn into in turn.
struct LevelSums {
    std::array<std::vector<float>, 5> sum;  // by log2 of the level
    std::array<bool, 5> used{};             // false: no group at that level for this light
    std::array<int, 5> width{}, height{};
    std::vector<float> scratch;  // one group's image, before its footprint (a full-size group's, or a reduced one's)
    std::vector<float> other;    // the second reduced group's image, drawn while the group in `scratch` is spread
    std::future<double> spreading;  // the last group given to spread(): its ms of convolving and summing

    // Ready for a light of a frame of `pixels`: no level used, the memory of the frame's earlier lights kept
    // (their pages already touched), and room for a group's image at full size, so a larger level never moves it.
    void start_light(std::size_t pixels) {
        stop_spreading();  // left by a light whose drawing failed: its result is not wanted
        used = {};
        // spread() swaps the two images: the larger (an earlier light's full-size group, its pages touched) is
        // made `scratch` again rather than a second full-size image being made (24 MB at 1080p).
        if (other.capacity() > scratch.capacity()) std::swap(scratch, other);
        scratch.reserve(pixels * 3);
    }
    // A zeroed image of w x h for the next group: not the one a group is being spread from.
    std::vector<float>& image_for_next(int w, int h) {
        std::vector<float>& image = spreading.valid() ? other : scratch;
        image.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3, 0.0f);
        return image;
    }
    // `image` (w x h, a reduced group's, drawn at `level`) handed to a worker thread: convolved with the light's
    // footprint scaled by m and added into the level's sum, after the group given before it (so the sums add
    // their groups in order). Ms of the groups finished meanwhile go to `ms`.
    void spread(std::vector<float>& image, int w, int h, int level, const detect::Shape& footprint, double m,
                flare::ConvolveScratch& convolve, double& ms) {
        ms += finish_spreading();
        if (&image == &other) std::swap(scratch, other);  // the image being spread is always `scratch`
        std::vector<float>& into = at(level, w, h);
        spreading = std::async(std::launch::async, [this, &into, w, h, footprint, m, &convolve] {
            const auto t = Clock::now();
            convolve_footprint(scratch, w, h, footprint, m, convolve);
            const RgbView view_of{into.data(), 0, 0, w, h};
            add(view_of, ConstRgbView{scratch.data(), 0, 0, w, h}, view_of.region());
            return ms_since(t);
        });
    }
    // Waits for the group being spread (if any); its ms.
    double finish_spreading() { return spreading.valid() ? spreading.get() : 0.0; }
    // Waits for the group being spread (if any), its result and any error not wanted.
    void stop_spreading() {
        if (spreading.valid()) spreading.wait();
        spreading = {};
    }

    // The sum at `level` (2 .. 16; an image of width x height), zero when first asked for.
    std::vector<float>& at(int level, int w, int h) {
        const auto k = static_cast<std::size_t>(std::countr_zero(static_cast<unsigned>(level)));
        if (!used[k]) sum[k].assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3, 0.0f);
        used[k] = true;
        width[k] = w;
        height[k] = h;
        return sum[k];
    }
    // Every level's sum added into the frame's rgb (w x h), enlarged bilinearly (add_enlarged's mapping), in
    // one pass over the frame.
    void add_enlarged_into(std::vector<float>& rgb, int w, int h) const {
        std::vector<ConstRgbView> levels;
        std::vector<flare::Region> regions;
        for (std::size_t k = 1; k < sum.size(); ++k) {
            if (!used[k]) continue;
            levels.push_back(ConstRgbView{sum[k].data(), 0, 0, width[k], height[k]});
            regions.push_back(flare::Region{0, 0, width[k] << k, height[k] << k});
        }
        flare::add_resized_each(RgbView{rgb.data(), 0, 0, w, h}, levels, regions);
    }
};

// A light with a footprint (a window, a lamp shade): its ghosts and starburst are spread over it.
bool is_extended(const detect::Light& light) { return light.shape && !light.shape->weights.empty(); }

// Step 2, fade: lights too dim against the brightest to show are left out, fading as they approach the limit
// (min_light_fade of their luminous flux times weight and gain).
void fade_dim_lights(std::vector<detect::Light>& lights, double min_light) {
    auto luminous = [](const detect::Light& l) {
        return detect::kRec709Luma[0] * l.flux[0] + detect::kRec709Luma[1] * l.flux[1] + detect::kRec709Luma[2] * l.flux[2];
    };
    double brightest = 0.0;
    for (const auto& l : lights) brightest = std::max(brightest, luminous(l) * l.weight * l.gain);
    std::erase_if(lights, [&](detect::Light& l) {
        l.weight *= brightest > 0.0 ? min_light_fade(luminous(l) * l.weight * l.gain / brightest, min_light) : 0.0;
        return !(l.weight > 0.0);
    });
}

// R, G, B of half or float: what a flare is added to; throws naming what the frame has instead.
void check_flare_channels(const Frame& frame) {
    if (!frame.has_rgb()) {
        std::string names;
        for (const auto& n : frame.spec.channelnames) names += (names.empty() ? "" : ", ") + n;
        const std::string first = frame.spec.channelnames.empty() ? std::string("Y") : frame.spec.channelnames.front();
        throw std::runtime_error(fmt::format("the flare needs R, G, B channels (or LAYER.R, .G, .B, or Y alone); this frame has {0} (to flare one "
                                             "channel, copy it to R, G, B: oiiotool IN --ch R={1},G={1},B={1} -o OUT)",
                                             names.empty() ? "none" : names, first));
    }
    for (int c : frame.rgb_channels)
        if (frame.spec.channel_type(c) == PixelType::uint32)
            throw std::runtime_error(fmt::format("channel {} is uint32 (integers such as ids, not light): the flare needs half or float R, G, B",
                                                 frame.spec.channel_name(c)));
}

// A lens's ghosts, their first-order imaging and their power along the axis: how an extended light's ghosts
// are grouped by footprint (footprint_groups).
struct GhostImagingTable {
    std::vector<optics::Ghost> ghosts;
    std::vector<optics::GhostImaging> imaging;
    std::vector<double> axial_power;

    static GhostImagingTable of(const optics::System& system) {
        GhostImagingTable t;
        t.ghosts = optics::enumerate_ghosts(system);
        t.imaging = optics::ghost_imaging(system, t.ghosts);
        const optics::TraceSystem traced(system, optics::kLambdaD_nm);
        for (const optics::Ghost& g : t.ghosts) t.axial_power.push_back(optics::ghost_axial_factor(traced, g));
        return t;
    }

    // The table from the disk cache (<dir>/imaging-<hash>.bin, keyed by the lens's text and system hash), or
    // made and saved there (best effort): its traces cost canon-70-200 (528 ghosts) some 0.11 CPU s a run.
    static GhostImagingTable cached(const optics::System& system, const std::string& lens_text, const std::string& dir) {
        const std::string key = fmt::format("lensfx-ghost-imaging-1\n{}\nsystem {:016x}", lens_text, flare::system_hash(system));
        const std::string path = dir.empty() ? std::string() : flare::cache_file(dir, "imaging", flare::key_hash(key));
        GhostImagingTable t;
        t.ghosts = optics::enumerate_ghosts(system);
        if (!path.empty() && t.load(path, key)) return t;
        t = of(system);
        if (!path.empty()) flare::try_write_cache_file(path, [&](std::ostream& out) { t.save(out, key); });
        return t;
    }

private:
    // Per ghost: its two interfaces (checked against the lens's ghosts on reading), magnification, blur, power.
    struct Row {
        std::int32_t first, second;
        double magnification, blur_mm, axial_power;
    };

    void save(std::ostream& out, const std::string& key) const {
        flare::write_key(out, key);
        const auto n = static_cast<std::uint64_t>(ghosts.size());
        out.write(reinterpret_cast<const char*>(&n), sizeof n);
        for (std::size_t g = 0; g < ghosts.size(); ++g) {
            const Row row{ghosts[g].first, ghosts[g].second, imaging[g].magnification, imaging[g].blur_mm, axial_power[g]};
            out.write(reinterpret_cast<const char*>(&row), sizeof row);
        }
    }

    // The imaging and power of `ghosts` from a cache file; false (nothing kept) for a foreign, stale,
    // truncated or damaged one.
    bool load(const std::string& path, const std::string& key) {
        flare::CacheFile in = flare::open_cache_file(path);
        std::uint64_t n = 0;
        if (!flare::read_key(in, key) || !in.read(reinterpret_cast<char*>(&n), sizeof n) || n != ghosts.size()) return false;
        std::vector<optics::GhostImaging> im(ghosts.size());
        std::vector<double> power(ghosts.size());
        for (std::size_t g = 0; g < ghosts.size(); ++g) {
            Row row{};
            if (!in.read(reinterpret_cast<char*>(&row), sizeof row) || row.first != ghosts[g].first || row.second != ghosts[g].second ||
                !std::isfinite(row.magnification) || !std::isfinite(row.blur_mm) || !std::isfinite(row.axial_power))
                return false;
            im[g] = {row.magnification, row.blur_mm};
            power[g] = row.axial_power;
        }
        if (in.peek() != std::char_traits<char>::eof()) return false;
        imaging = std::move(im);
        axial_power = std::move(power);
        return true;
    }
};

// What the model step adds up over a frame's lights: the parts' times and the ghosts drawn and culled.
struct FrameTally {
    double direct_ms = 0.0, starburst_ms = 0.0, ghosts_ms = 0.0, extended_ms = 0.0;
    int ghosts_drawn = 0, ghosts_culled = 0;
    int ghosts_merged = 0;         // faint ghosts drawn once for several passes (gpu::merge_faint_passes)
    int lights_outside_field = 0;  // lights the lens does not image (no flare)
};

// The lens the stage renders: a prescription realized at --zoom and --fstop (with its coatings and blades),
// or a measured preset; and the sensor it images onto.
struct LensModel {
    optics::System system;
    std::optional<measured::MeasuredLens> measured;  // a measured preset instead of a prescription
    double efl_mm = 0.0;
    double f_number = 0.0;
    std::string text;                  // the prescription as TOML: part of the cache keys
    std::array<double, 2> sensor{};    // mm; height 0: from the frame's aspect
};

// Where a frame's lights come from: the track file, or the detector (on the plate as --matte and --add-light
// change it) followed by the tracker.
struct LightFinder {
    std::optional<detect::TrackFile> tracks;
    detect::Detector detector;
    detect::Tracker tracker;
    DetectionInput input;  // the plate as the detector sees it (--matte, --add-light)

    explicit LightFinder(const FlareSettings& settings)
        : detector([&] {
              detect::DetectorOptions o;
              o.threshold = detect::Threshold::parse(settings.threshold);
              o.max_lights = settings.max_lights;
              return o;
          }()),
          input(settings.controls, settings.memory) {
        if (!settings.tracks.empty() && input.changes_the_plate())
            throw std::invalid_argument("--matte, --matte-channel and --add-light act on detection; with --tracks, edit the track file");
        if (!settings.tracks.empty()) tracks = detect::read_track_file(settings.tracks);
    }
};

// The direct path's power over the frame's field (flare::DirectPowerTable): made at the first light, over the
// frame's corners, and kept on disk under --cache-dir; every light's ghost scale divides by it.
class DirectPowerCache {
public:
    // The power at (ax, ay) degrees; `corner_deg` (the field the frame reaches) sizes the table at its first use.
    std::array<double, 3> at(const LensModel& lens, const std::vector<flare::SpectralPass>& passes, double corner_deg,
                             const std::string& cache_dir_option, double ax, double ay) {
        if (table_.empty()) make(lens, passes, corner_deg, cache_dir_option);
        const int traced_before = table_.traced();
        const std::array<double, 3> power = table_.at(ax, ay);
        if (table_.traced() != traced_before && !file_.empty()) table_.save(file_, key_);
        return power;
    }

private:
    void make(const LensModel& lens, const std::vector<flare::SpectralPass>& passes, double corner_deg, const std::string& cache_dir_option) {
        table_ = flare::DirectPowerTable(lens.system, std::min(89.0, 1.02 * corner_deg), 12, 96, passes);
        // (3: a lens stopped far down is sampled again round its beam, flare::direct_power)
        key_ = fmt::format("lensfx-direct-3\n{}\nfield {:.17g}\n{}", lens.text, table_.max_field_deg(), flare::passes_key(passes));
        if (const std::string dir = flare::cache_dir_of(cache_dir_option); !dir.empty()) {
            file_ = flare::cache_file(dir, "direct", flare::key_hash(key_));
            table_.load(file_, key_);
        }
    }

    flare::DirectPowerTable table_;
    std::string key_;             // what the table depends on (its cache file's name)
    std::filesystem::path file_;  // empty: no cache folder
};

// The lens's diffraction pattern (the starburst texture): computed, or read from the cache, at the first light
// that draws one.
class StarburstSource {
public:
    explicit StarburstSource(optics::StarburstOptions options) : options_(std::move(options)) {}

    const optics::Starburst& texture(const optics::Aperture& aperture, const optics::Mat3& xyz_to_rgb, const std::string& cache_dir_option) {
        if (!texture_) {
            optics::StarburstOptions options = options_;
            options.xyz_to_rgb = xyz_to_rgb;
            texture_ = flare::cached_starburst(aperture, options, flare::cache_dir_of(cache_dir_option));
        }
        return *texture_;
    }

private:
    optics::StarburstOptions options_;  // the pupil's dirt and image, read at start
    std::optional<optics::Starburst> texture_;
};

// What one frame reports: part times, figures, and the detector's own figures.
struct FrameReport {
    std::vector<std::pair<std::string, double>> times;
    std::vector<std::pair<std::string, double>> figures;
    std::vector<std::pair<std::string, double>> detected;

    void clear() {
        times.clear();
        figures.clear();
        detected.clear();
    }
};

}  // namespace

struct FlareStage::State {
    FlareSettings settings;
    LensModel lens;
    LightFinder finder;
    LightSummary summary;
    std::shared_ptr<GpuSession> gpu_session;  // its context is made ahead and taken at the first ghost render
    std::unique_ptr<gpu::FlareRenderer> renderer;  // made at the first ghost render (ghost_renderer)
    // The renderer made and warmed up on the context's worker (GpuSession::prepare), taken at the first ghost render.
    std::shared_ptr<std::unique_ptr<gpu::FlareRenderer>> renderer_ahead = std::make_shared<std::unique_ptr<gpu::FlareRenderer>>();
    std::unique_ptr<gpu::MeasuredRenderer> measured_renderer;
    FlareParts parts;
    gpu::GpuFlareOptions render_options;  // grid, ringing, accelerations, --flare-look styles
    PrimariesSource primaries_source;
    std::optional<optics::Mat3> xyz_to_rgb;  // the working space's, fixed at the first light
    std::vector<flare::SpectralPass> passes;  // with those primaries
    StarburstSource starburst;
    DirectPowerCache direct;
    std::optional<GhostImagingTable> ghost_imaging;  // for extended lights, made at the first one
    FrameReport report;  // of the last frame
    std::vector<float> flare_rgb;  // the frame's flare over the display window; kept to reuse its memory
    flare::ConvolveScratch convolve_scratch;  // the footprint FFTs' arrays, kept for the next group and frame
    // The extended lights' groups, shared by a frame's lights; let go at the frame's end. After convolve_scratch:
    // destroyed first, it waits for a group still being spread (which uses convolve_scratch).
    LevelSums level_sums;

    // A renderer the context's worker may still be making, or made and no render took, is let go with the context
    // current here.
    ~State() {
        if (!gpu_session) return;
        if (gpu_session->preparing()) {
            try {
                gpu_session->get();
            } catch (const std::exception&) {  // lost: see forget_lost_renderer
            }
        }
        forget_lost_renderer();
    }
    State(const State&) = delete;
    State& operator=(const State&) = delete;

    State(FlareSettings s, std::shared_ptr<GpuSession> g, PrimariesSource primaries)
        : settings(with_files_checked(std::move(s))),
          finder(settings),
          starburst(filter::starburst_options(settings.pupil)) {
        gpu_session = g ? std::move(g) : std::make_shared<GpuSession>();
        summary.threshold_text = settings.threshold;
        summary.tracks = settings.tracks;
        primaries_source = std::move(primaries);
        if (measured::is_measured_file(settings.lens)) {
            lens.measured = measured::read_measured(settings.lens);
            lens.efl_mm = lens.measured->focal_length_mm;
        } else {
            load_physical_lens();
        }
        parts = parse_parts(settings.parts);
        parts.starburst = parts.starburst && !lens.measured;  // a measured lens models its ghosts only
        parts.ghosts = parts.ghosts && settings.controls.ghost_gain > 0.0;  // a gain of 0 renders nothing
        parts.starburst = parts.starburst && settings.starburst_gain > 0.0;
        lens.sensor = parse_sensor(settings.sensor);
        render_options.grid = settings.grid;
        render_options.ringing = settings.ringing;
        render_options.accel = settings.accel.acceleration();
        render_options.memory = settings.memory;
        // A lens of many surfaces has ghosts by the square of them: refused here, before any table is built.
        if (!lens.measured) gpu::check_ghost_tables(lens.system, settings.bands == 0 ? 3 : static_cast<std::size_t>(settings.bands), settings.memory);
        if (!settings.flare_look.empty() && !lens.measured)
            render_options.styles =
                optics::ghost_styles(optics::read_flare_look(settings.flare_look), optics::enumerate_ghosts(lens.system));
        if (settings.bands != 0) flare::spectral_passes(settings.bands);  // checks the band count
        if (settings.band_filter && settings.bands == 0) throw std::invalid_argument("--band-filter needs --bands N");
        if (gpu_session->platform.empty() || gpu_session->platform == "auto") gpu_session->platform = settings.gpu;
        if (parts.ghosts && settings.gain > 0.0) gpu_session->prepare(lens.measured ? nullptr : renderer_made_ahead());
        flare::keep_fft_wisdom_in(flare::cache_dir_of(settings.accel.cache_dir));  // the footprints' FFT plans
    }

    // A renderer made on the context's worker and warmed up there (FlareRenderer::prepare: shaders compiled,
    // the passes' ghost sequences built) while the first frame is read, its lights found and their starbursts
    // drawn: canon-70-200's first pass on a 1080p frame took 117 ms instead of 229 (each step finished before the
    // next), the whole run 15 ms less back to back and 50 ms less 3 s after the last. A failure leaves it unmade:
    // the first render then makes its own and reports the fault where it meets it. The view's size and sensor
    // height matter only to the warm-up's tiny draws.
    std::function<void(gpu::Context&)> renderer_made_ahead() const {
        flare::FlareView view;
        view.sensor_width_mm = lens.sensor[0];
        view.sensor_height_mm = lens.sensor[1] > 0.0 ? lens.sensor[1] : lens.sensor[0];
        view.bands = settings.bands;
        // The slot is held weakly: were the stage gone (its construction failed after this), the renderer is let go
        // here, where the context is current.
        return [slot = std::weak_ptr(renderer_ahead), system = lens.system, view, options = render_options](gpu::Context& context) {
            try {
                auto made = std::make_unique<gpu::FlareRenderer>(context);
                made->prepare(system, view, options);
                if (const auto taker = slot.lock()) *taker = std::move(made);
            } catch (const std::exception&) {
            }
        };
    }

    // The prescription, realized at --zoom and --fstop with its coatings and blades.
    void load_physical_lens() {
        RealizedLens realized = realize_lens(settings);
        lens.system = std::move(realized.system);
        lens.text = std::move(realized.text);
        const optics::Paraxial first_order = optics::paraxial(lens.system);
        lens.efl_mm = first_order.efl_mm;
        lens.f_number = first_order.f_number;
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
                scale[c] = std::min(std::max(0.0, light.flux[c]) * geo.pixel_area_mm2() / lens.measured->capture.light_energy * boost(light, false) *
                                        settings.controls.ghost_gain, kMaxLightScale);
            measured_renderer->render_add(*lens.measured, view, scale, flare.data());
        }
        report.times.emplace_back("ghosts", ms_since(t));
        composite(frame, flare, geo, settings.layer);
    }

    // The working space's primaries and the passes in them; asked once, at the first light.
    void resolve_primaries() {
        if (xyz_to_rgb) return;
        xyz_to_rgb = working_xyz_to_rgb(primaries_source);
        flare::FlareView view;
        view.bands = settings.bands;
        view.xyz_to_rgb = *xyz_to_rgb;
        passes = view.passes();
    }

    FlareGeometry geometry(const Frame& frame) const {
        FlareGeometry g;
        g.width = frame.spec.full_width;
        g.height = frame.spec.full_height;
        g.sensor_width_mm = lens.sensor[0];
        const auto aspect = static_cast<double>(frame.spec.pixel_aspect);
        g.sensor_height_mm = lens.sensor[1] > 0.0 ? lens.sensor[1] : lens.sensor[0] * g.height / (g.width * aspect);
        g.focal_mm = settings.fov_deg ? 0.5 * g.sensor_width_mm / std::tan(0.5 * *settings.fov_deg / kDegrees) : lens.efl_mm;
        return g;
    }

    std::vector<detect::Light> lights(const Frame& frame) {
        if (finder.tracks) {
            std::vector<detect::Light> found = finder.tracks->lights_at(frame.number);
            if (finder.tracks->width > 0 && finder.tracks->width != frame.spec.full_width)
                throw std::runtime_error(fmt::format("track file {} is for {}x{} frames, this one is {}x{}", settings.tracks,
                                                     finder.tracks->width, finder.tracks->height, frame.spec.full_width, frame.spec.full_height));
            keep_brightest(found, static_cast<std::size_t>(settings.max_lights));
            return found;
        }
        const detect::Detection found = finder.detector.detect(finder.input.view(frame));
        const detect::FrameStats& st = found.stats;
        report.detected = {{"sources", static_cast<double>(found.sources.size())}, {"brightest", st.max_luminance}, {"threshold", st.threshold}};
        if (summary.lights_per_frame.empty() || st.max_luminance > summary.brightest_luminance) {
            summary.brightest_luminance = st.max_luminance;
            summary.threshold_there = st.threshold;
        }
        note_added_below(st.threshold);
        return finder.tracker.update(found);
    }

    // Notes (once each) the --add-light discs whose value is below this frame's threshold: the detector cannot
    // find them, so they add no light.
    void note_added_below(double threshold) {
        for (const std::string& text : settings.controls.add_lights) {
            if (!(parse_added_light(text).value < threshold)) continue;
            if (std::find(summary.added_below_threshold.begin(), summary.added_below_threshold.end(), text) == summary.added_below_threshold.end())
                summary.added_below_threshold.push_back(text);
        }
    }

    // The strength of a light's whole flare beyond physics: the artistic gains that apply to it, multiplied
    // in double (each is finite and >= 0; their product may still overflow, and is then the largest double).
    double boost(const detect::Light& light, bool extended) const {
        const double b = (light.clipped ? settings.source_gain : 1.0) * settings.gain * light.weight * light.gain *
                         (extended ? settings.controls.extended_gain : 1.0);
        return std::isfinite(b) ? b : std::numeric_limits<double>::max();
    }

    // Step 1, lights: this frame's (detected and tracked, or from the track file), less those too dim against
    // the brightest to show; counted in the run's summary and the frame's figures.
    std::vector<detect::Light> frame_lights(const Frame& frame) {
        const auto t = Clock::now();
        std::vector<detect::Light> found = lights(frame);
        report.times.emplace_back("detect", ms_since(t));
        fade_dim_lights(found, settings.min_light);
        summary.lights_per_frame.push_back(static_cast<int>(found.size()));
        report.figures.emplace_back("lights", static_cast<double>(found.size()));
        report.figures.insert(report.figures.end(), report.detected.begin(), report.detected.end());
        return found;
    }

    bool draws_nothing(const std::vector<detect::Light>& found) const {
        return found.empty() || settings.gain == 0.0 || (!parts.ghosts && !parts.starburst);
    }

    // The flare image of this frame, cleared: the frame's own R, G, B when `into_frame`, else a buffer over the
    // display window; with the working space resolved and the plate's visibility for culling.
    std::vector<float>& start_flare(Frame& frame, const FlareGeometry& geo, const std::vector<detect::Light>& found, bool into_frame) {
        resolve_primaries();
        // Scene culling needs the plate the flare is added to: not with --flare-only or --layer (composited later).
        const bool layer = !settings.layer.empty();
        const bool scene_cull = parts.ghosts && !settings.no_scene_cull && !settings.flare_only && !layer;
        render_options.visibility = scene_cull ? plate_visibility(frame, settings.visibility) : nullptr;
        const bool any_extended = std::any_of(found.begin(), found.end(), [](const detect::Light& l) { return is_extended(l); });
        settings.memory.check(flare_frame_bytes(frame, into_frame, parts.ghosts, any_extended, layer),
                              fmt::format("the flare over the {}x{} display window", geo.width, geo.height));
        if (into_frame) {
            flare_rgb = {};
            return frame.rgb;
        }
        flare_rgb.assign(static_cast<std::size_t>(geo.width) * static_cast<std::size_t>(geo.height) * 3, 0.0f);
        return flare_rgb;
    }

    // The ghost renderer, made at the first render: the light's direct power, starburst and footprint groups
    // are computed first, while the context made ahead (GpuSession::prepare) may still be starting up.
    gpu::FlareRenderer& ghost_renderer() {
        if (renderer) return *renderer;
        gpu::Context& context = gpu_session->get();  // after the worker is done with the renderer it made
        forget_lost_renderer();
        renderer = *renderer_ahead ? std::move(*renderer_ahead) : std::make_unique<gpu::FlareRenderer>(context);
        return *renderer;
    }

    // A renderer made ahead in a context that was lost (GpuSession::lost_ahead; a later get() makes another) is
    // let go without deleting its GL objects: their names belong to the lost context, and in another would be
    // someone else's.
    void forget_lost_renderer() {
        if (gpu_session->lost_ahead() && *renderer_ahead) static_cast<void>(renderer_ahead->release());
    }

    // Step 3, the model: every light's starburst and ghosts added into `rgb` (the display window) at the light's
    // strength; the point lights' ghosts drawn together at the end (one clear and read-back).
    FrameTally add_model(const std::vector<detect::Light>& found, const FlareGeometry& geo, std::vector<float>& rgb) {
        FrameTally tally;
        flare::FlareView view = flare_view(geo);  // each light sets the angles
        std::vector<gpu::ScaledLight> point_lights;
        const std::vector<std::vector<const UnheldLight*>> unheld = unheld_of(found);
        for (std::size_t i = 0; i < found.size(); ++i) {
            const detect::Light& light = found[i];
            auto t = Clock::now();
            const auto [ax, ay] = geo.angles_at(light.x, light.y);
            const std::optional<std::array<float, 3>> scale = ghost_scale(light, geo, ax, ay);
            tally.direct_ms += ms_since(t);
            if (!scale) {  // outside what the lens images (or gains of 0): nothing reaches the sensor
                tally.lights_outside_field += outside_field(geo, ax, ay);
                continue;
            }
            if (parts.starburst) {
                t = Clock::now();
                add_starburst(light, geo, rgb);
                add_unheld_cores(light, unheld[i], geo, rgb);
                tally.starburst_ms += ms_since(t);
            }
            if (!parts.ghosts) continue;
            view.angle_x_deg = ax;
            view.angle_y_deg = ay;
            const gpu::ScaledLight scaled{ax, ay, as_double(*scale)};
            if (!add_light_ghosts(light, *scale, view, rgb, tally)) point_lights.push_back(scaled);
        }
        if (!point_lights.empty()) {
            const auto t = Clock::now();
            ghost_renderer().render_add(lens.system, view, point_lights, render_options, rgb);
            count_ghosts(tally);
            tally.ghosts_ms += ms_since(t);
        }
        return tally;
    }

    // The frame as the lens sees it: sensor, pixels, bands and the working space's primaries.
    flare::FlareView flare_view(const FlareGeometry& geo) const {
        flare::FlareView view;
        view.sensor_width_mm = geo.sensor_width_mm;
        view.sensor_height_mm = geo.sensor_height_mm;
        view.width = geo.width;
        view.height = geo.height;
        view.bands = settings.bands;
        view.xyz_to_rgb = *xyz_to_rgb;
        return view;
    }

    // Whether no light from (ax, ay) degrees reaches the sensor through the direct path: beyond the lens's field.
    bool outside_field(const FlareGeometry& geo, double ax, double ay) {
        const std::array<double, 3> power = direct_power_at(geo, ax, ay);
        return std::all_of(power.begin(), power.end(), [](double p) { return !(p > 0.0); });
    }

    // direct_power at (ax, ay), from the table over the frame's field up to its corners.
    std::array<double, 3> direct_power_at(const FlareGeometry& geo, double ax, double ay) {
        const auto [cx, cy] = geo.angles_at(0.0, 0.0);
        const double corner = std::atan(std::hypot(std::tan(cx / kDegrees), std::tan(cy / kDegrees))) * kDegrees;
        return direct.at(lens, passes, corner, settings.accel.cache_dir, ax, ay);
    }

    // The factor per channel a light's ghosts are added with: its irradiance at the lens (the energy its image
    // recorded over what unit irradiance gives through the direct path) times its gains; nullopt when nothing
    // of it reaches the sensor.
    std::optional<std::array<float, 3>> ghost_scale(const detect::Light& light, const FlareGeometry& geo, double ax, double ay) {
        const std::array<double, 3> power = direct_power_at(geo, ax, ay);
        const double gains = boost(light, is_extended(light));
        std::array<float, 3> scale{};
        bool any = false;
        for (std::size_t c = 0; c < 3; ++c) {
            if (power[c] <= 0.0) continue;
            const double irradiance = std::max(0.0, light.flux[c]) * geo.pixel_area_mm2() / power[c];
            scale[c] = to_float_within(std::min(irradiance * gains * settings.controls.ghost_gain, kMaxLightScale));
            any = any || irradiance * gains > 0.0;
        }
        return any ? std::optional(scale) : std::nullopt;
    }

    // The added lights each found light stands for (the nearest one whose disc it reaches, if any).
    std::vector<std::vector<const UnheldLight*>> unheld_of(const std::vector<detect::Light>& found) const {
        std::vector<std::vector<const UnheldLight*>> of(found.size());
        for (const UnheldLight& u : finder.input.unheld()) {
            std::optional<std::size_t> nearest;
            double nearest_px = std::numeric_limits<double>::infinity();
            for (std::size_t i = 0; i < found.size(); ++i) {
                const double px = std::hypot(found[i].x - u.light.x, found[i].y - u.light.y);
                const double reach = u.light.radius + std::max(found[i].extent.major, found[i].extent.minor) + 2.0;
                if (px <= reach && px < nearest_px) nearest = i, nearest_px = px;
            }
            if (nearest) of[*nearest].push_back(&u);
        }
        return of;
    }

    // The starburst texture (computed or read from the cache at the first light).
    const optics::Starburst& starburst_texture() {
        return starburst.texture(lens.system.aperture, *xyz_to_rgb, settings.accel.cache_dir);
    }

    // The radius (texels) of the pattern's core a light's recorded pixels hold; never more than its own pixel,
    // or a small light would show a hole.
    double core_texels(const FlareGeometry& geo) {
        const optics::Starburst& sb = starburst_texture();
        const double texel_px = sb.texel_per_fnumber_mm * lens.f_number / (geo.sensor_width_mm / geo.width);
        return std::min(optics::starburst_core_radius_texels(sb), 0.75 / texel_px);
    }

    static optics::SensorImage sensor_image(const FlareGeometry& geo, std::vector<float>& rgb) {
        return {rgb.data(), geo.width, geo.height, geo.sensor_width_mm / geo.width, geo.sensor_height_mm / geo.height};
    }

    // The core of each added light the plate does not hold (UnheldLight), at its own place over its own disc,
    // at physical strength times the light's fade: with what add_starburst draws, the whole pattern, so an
    // added sun shows its disc. A light the plate holds adds nothing here (its pixels are its core).
    void add_unheld_cores(const detect::Light& light, const std::vector<const UnheldLight*>& cores, const FlareGeometry& geo,
                          std::vector<float>& rgb) {
        for (const UnheldLight* u : cores) {
            std::array<double, 3> energy{};
            for (std::size_t c = 0; c < 3; ++c) energy[c] = std::min(u->flux[c] * geo.pixel_area_mm2() * light.weight, kMaxLightScale);
            const optics::SourceEllipse disc{u->light.radius, u->light.radius, 0.0};
            optics::draw_starburst_core(starburst_texture(), lens.system.aperture, settings.starburst_scale,
                                        {u->light.x, u->light.y, lens.f_number, core_texels(geo), disc}, energy, sensor_image(geo, rgb));
        }
    }

    // The light's diffraction pattern, carrying its recorded energy, centred on its image; its core is already in
    // the recorded pixels, so only the spikes and rings are added. An extended light's is every point's pattern
    // over its footprint (the direct image), less what its recorded pixels hold (footprint.h).
    void add_starburst(const detect::Light& light, const FlareGeometry& geo, std::vector<float>& rgb) {
        const double gains = boost(light, is_extended(light));
        std::array<double, 3> energy{};
        for (std::size_t c = 0; c < 3; ++c)
            energy[c] = std::min(std::max(0.0, light.flux[c]) * geo.pixel_area_mm2() * settings.starburst_gain * gains, kMaxLightScale);
        const optics::SensorImage image = sensor_image(geo, rgb);
        const double core = core_texels(geo);
        if (is_extended(light)) {
            add_extended_starburst(starburst_texture(), lens.system.aperture, settings.starburst_scale, {light.x, light.y, lens.f_number, core}, energy,
                                   *light.shape, image, convolve_scratch);
        } else {
            // Spread over the light's own extent: a sun 8 px across has spikes 8 px wide.
            const optics::SourceEllipse source{light.extent.major, light.extent.minor, light.extent.angle_deg};
            optics::draw_starburst(starburst_texture(), lens.system.aperture, settings.starburst_scale, {light.x, light.y, lens.f_number, core, source},
                                   energy, image);
        }
    }

    // The groups of a light's ghosts by footprint magnification (footprint.h): one group of every ghost, no
    // footprint, for a point light or an extended light whose ghosts all image as from a point.
    std::vector<FootprintGroup> ghost_groups(const detect::Light& light, double pixel_mm) {
        if (!is_extended(light)) return std::vector<FootprintGroup>(1);
        if (!ghost_imaging) ghost_imaging = GhostImagingTable::cached(lens.system, lens.text, flare::cache_dir_of(settings.accel.cache_dir));
        const GhostImagingTable& t = *ghost_imaging;
        std::vector<FootprintGroup> groups = footprint_groups(t.ghosts, t.imaging, t.axial_power, *light.shape, pixel_mm);
        if (groups.size() == 1 && groups[0].magnification == 0.0) groups[0].ghosts.clear();  // every ghost: a point light's caches
        return groups;
    }

    // A light's ghosts added into `rgb` group by group (each convolved with its footprint), or with
    // --band-filter one render per band; false for a point light, left to be drawn with the frame's others.
    bool add_light_ghosts(const detect::Light& light, const std::array<float, 3>& scale, flare::FlareView& view, std::vector<float>& rgb,
                          FrameTally& tally) {
        auto t = Clock::now();
        const std::vector<FootprintGroup> groups = ghost_groups(light, view.sensor_width_mm / view.width);
        if (is_extended(light)) tally.extended_ms += ms_since(t);
        const bool as_point = groups.size() == 1 && groups[0].magnification == 0.0;
        if (as_point && !settings.band_filter) return false;
        if (settings.band_filter) {
            for (const FootprintGroup& group : groups) add_band_filtered_group(light, scale, group, view, rgb, tally);
            return true;
        }
        const gpu::ScaledLight scaled{view.angle_x_deg, view.angle_y_deg, as_double(scale)};
        LevelSums& sums = level_sums;
        sums.start_light(static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height));
        // In their order (the plate's culling budget is spent render by render); a reduced group is spread on a
        // worker thread while the GPU draws the next.
        for (const FootprintGroup& group : groups) add_group_ghosts(light, scaled, group, view, rgb, sums, tally);
        t = Clock::now();
        const double spread_ms = sums.finish_spreading();
        sums.add_enlarged_into(rgb, view.width, view.height);
        tally.extended_ms += spread_ms + ms_since(t);
        return true;
    }

    // A footprint group's ghosts drawn at the level its footprint's blur allows (gpu::spread_level: a group
    // spread over a disc of radius r is drawn and convolved at 1/(r/4) of the frame, up to 1/16), convolved
    // there and summed with the light's other groups of that level (on a worker thread, LevelSums::spread);
    // a group drawn as from a point, into rgb.
    void add_group_ghosts(const detect::Light& light, const gpu::ScaledLight& scaled, const FootprintGroup& group,
                          const flare::FlareView& view, std::vector<float>& rgb, LevelSums& sums, FrameTally& tally) {
        auto t = Clock::now();
        // The group's ghosts out of the whole lens's (one bounds table and estimate for all groups), at the
        // light's strength, so scene culling weighs them in the frame's units.
        gpu::GpuFlareOptions group_options = render_options;
        group_options.draw_only = group.ghosts;
        if (group.magnification == 0.0) {
            ghost_renderer().render_add(lens.system, view, std::span(&scaled, 1), group_options, rgb);
            count_ghosts(tally);
            tally.ghosts_ms += ms_since(t);
            return;
        }
        group_options.spread = {footprint_reach_px(*light.shape, group.magnification),
                                flare::footprint_peak_share(*light.shape, group.magnification)};
        const int level = gpu::spread_level(group_options.spread);
        const int w = flare::reduced_side(view.width, level), h = flare::reduced_side(view.height, level);
        if (level == 1) tally.extended_ms += sums.finish_spreading();  // a full-size group's image is `scratch`
        std::vector<float>& image = sums.image_for_next(w, h);
        ghost_renderer().render_add(lens.system, view, std::span(&scaled, 1), group_options, image, level);
        count_ghosts(tally);
        tally.ghosts_ms += ms_since(t);
        // A group that drew nothing (every ghost culled or dark) adds nothing: no footprint, no sum.
        if (renderer->last_stats().ghosts_drawn == 0) return;
        const detect::Shape footprint = flare::reduced_footprint(*light.shape, level);
        if (level > 1) return sums.spread(image, w, h, level, footprint, group.magnification, convolve_scratch, tally.extended_ms);
        // At full size, straight into the frame.
        t = Clock::now();
        convolve_footprint(image, w, h, footprint, group.magnification, convolve_scratch);
        const RgbView view_of{rgb.data(), 0, 0, w, h};
        add(view_of, ConstRgbView{image.data(), 0, 0, w, h}, view_of.region());
        tally.extended_ms += ms_since(t);
    }

    // --band-filter: a group's ghosts rendered one band at a time (gpu::render_band_filtered), scaled, convolved
    // with the footprint at full size and added into rgb.
    void add_band_filtered_group(const detect::Light& light, const std::array<float, 3>& scale, const FootprintGroup& group,
                                 flare::FlareView& view, std::vector<float>& rgb, FrameTally& tally) {
        auto t = Clock::now();
        // The whole lens's ghost list for every render (one bounds table per band), the group's drawn.
        flare::FlareImage flare = gpu::render_band_filtered(lens.system, view, gpu::render_one_on(ghost_renderer(), lens.system, render_options),
                                                            group.ghosts);
        if (flare.width != view.width || flare.height != view.height)
            throw std::runtime_error(fmt::format("the ghost image is {}x{}, the frame {}x{}", flare.width, flare.height,
                                                 view.width, view.height));
        const std::size_t pixels = flare.rgb.size() / 3;
        for (std::size_t i = 0; i < pixels; ++i)
            for (std::size_t c = 0; c < 3; ++c) flare.rgb[i * 3 + c] = scaled_within_float(flare.rgb[i * 3 + c], scale[c]);
        count_ghosts(tally);
        tally.ghosts_ms += ms_since(t);
        if (group.magnification != 0.0) {
            t = Clock::now();
            convolve_footprint(flare.rgb, view.width, view.height, *light.shape, group.magnification, convolve_scratch);
            tally.extended_ms += ms_since(t);
        }
        const RgbView display{rgb.data(), 0, 0, view.width, view.height};
        add(display, ConstRgbView{flare.rgb.data(), 0, 0, view.width, view.height}, display.region());
    }

    void count_ghosts(FrameTally& tally) const {
        tally.ghosts_drawn += renderer->last_stats().ghosts_drawn;
        tally.ghosts_culled += renderer->last_stats().ghosts_culled;
        tally.ghosts_merged += renderer->last_stats().ghosts_merged;
    }

    // The model's figures and part times for the frame and the run; above 4K the GL targets (over 300 MB) are
    // not kept for the next frame: making them again costs little against rendering at that size, and the
    // frame is stored and written without them.
    void finish_model(const FrameTally& tally, const FlareGeometry& geo) {
        level_sums.stop_spreading();  // none is left unless a light failed; its images are about to go
        level_sums = {};  // nothing of it is held between frames (held_bytes)
        constexpr std::size_t kKeepTargetsPixels = std::size_t{4096} * 4096;
        if (renderer && static_cast<std::size_t>(geo.width) * static_cast<std::size_t>(geo.height) > kKeepTargetsPixels)
            renderer->release_targets();
        report.figures.emplace_back("ghosts drawn", static_cast<double>(tally.ghosts_drawn));
        report.figures.emplace_back("ghosts culled", static_cast<double>(tally.ghosts_culled));
        report.figures.emplace_back("ghosts merged", static_cast<double>(tally.ghosts_merged));
        summary.ghosts_drawn += tally.ghosts_drawn;
        summary.ghosts_culled += tally.ghosts_culled;
        summary.lights_outside_field += tally.lights_outside_field;
        report.times.emplace_back("direct", tally.direct_ms);
        report.times.emplace_back("starburst", tally.starburst_ms);
        report.times.emplace_back("ghosts", tally.ghosts_ms);
        report.times.emplace_back("extended", tally.extended_ms);
    }
};

FlareStage::FlareStage(FlareSettings settings, std::shared_ptr<GpuSession> gpu, PrimariesSource working_rgb_to_xyz)
 {
    gpu::require_address_space();  // before the GL context is made ahead and before FFTW: both abort below it
    state_ = std::make_unique<State>(std::move(settings), std::move(gpu), std::move(working_rgb_to_xyz));
}
FlareStage::~FlareStage() = default;

std::vector<std::pair<std::string, double>> FlareStage::part_times() const { return state_->report.times; }
std::vector<std::pair<std::string, double>> FlareStage::frame_figures() const { return state_->report.figures; }
const LightSummary& FlareStage::summary() const { return state_->summary; }

std::size_t FlareStage::held_bytes(const ImageSpec& spec) const {
    const std::size_t convolve = state_->convolve_scratch.held_bytes();
    if (!state_->parts.ghosts || state_->lens.measured) return convolve;
    const double bytes = gpu::render_target_bytes(spec.full_width, spec.full_height);
    return static_cast<std::size_t>(std::min(bytes, 0x1p60)) + convolve;  // a hostile window is refused by the stage itself
}

// lights -> fade -> model -> composite.
void FlareStage::process(Frame& frame) {
    State& s = *state_;
    s.report.clear();
    check_flare_channels(frame);
    const std::vector<detect::Light> lights = s.frame_lights(frame);
    if (s.settings.flare_only) std::fill(frame.rgb.begin(), frame.rgb.end(), 0.0f);
    const bool layer = !s.settings.layer.empty();
    if (s.draws_nothing(lights)) {  // the context made ahead waits
        if (layer) add_rgb_layer(frame, s.settings.layer, std::vector<float>(frame.pixel_count() * 3, 0.0f));
        return;
    }
    const FlareGeometry geo = s.geometry(frame);
    if (s.lens.measured) return s.add_measured_flare(frame, lights, geo);
    // The flare over the display window, composited into the frame once every light is in; when the data
    // window is the display window (and R, G, B are the target), added into the frame's R, G, B directly.
    const bool into_frame = frame.spec.data_is_display() && !layer;
    std::vector<float>& flare_rgb = s.start_flare(frame, geo, lights, into_frame);
    s.finish_model(s.add_model(lights, geo, flare_rgb), geo);
    const auto t = Clock::now();
    if (!into_frame) composite(frame, flare_rgb, geo, s.settings.layer);
    s.report.times.emplace_back("composite", ms_since(t));
}

}  // namespace lensfx::filter
