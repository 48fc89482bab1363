// `lensfx lens fit` (a measured lens from a photographed sweep, Walch et al. 2018), `lensfx predict` (the
// flare estimators over a range of light angles, for any lens) and the measured lenses' render in
// `lensfx flare`.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <filter/frame.h>
#include <filter/image_io.h>
#include <filter/output_files.h>
#include <filter/sequence.h>
#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <gpu/measured_renderer.h>
#include <measured/fit.h>
#include <measured/model_file.h>
#include <measured/predict.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/system.h>
#include <optics/text_pairs.h>

#include <filter/flare_stage.h>

#include "commands.h"
#include <filter/option_checks.h>

namespace lensfx::filter {

namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// The sensor of a sweep or a prediction, read as the flare's --sensor (parse_sensor): "36" (height from the
// image's aspect) or "36x24", each within kMinSensorMm..kMaxSensorMm.
std::array<double, 2> sensor_of(const std::string& text, int width, int height) {
    try {
        auto [w, h] = parse_sensor(text);
        if (text.find('x') == std::string::npos) h = w * height / width;
        if (w >= kMinSensorMm && h >= kMinSensorMm && w <= kMaxSensorMm && h <= kMaxSensorMm) return {w, h};
    } catch (const std::invalid_argument&) {
    }
    throw CLI::ValidationError("--sensor", fmt::format("'{}': expected WIDTH or WIDTHxHEIGHT in mm, e.g. 36x24 ({:g} to {:g} each)", text,
                                                       kMinSensorMm, kMaxSensorMm));
}

// "100x60" -> {100, 60}.
std::array<int, 2> size_of(const std::string& text) {
    const auto wh = parse_pair_of<int>(text, 'x');
    if (wh && (*wh)[0] >= 16 && (*wh)[1] >= 16 && (*wh)[0] <= 8192 && (*wh)[1] <= 8192) return *wh;
    throw CLI::ValidationError("--size", fmt::format("'{}': expected WxH in pixels, 16 to 8192 each", text));
}

// The focal length from --focal-length or --fov (horizontal, over the sensor's width).
double focal_of(std::optional<double> focal_mm, std::optional<double> fov_deg, double sensor_width_mm) {
    if (focal_mm) return *focal_mm;
    if (fov_deg) return 0.5 * sensor_width_mm / std::tan(0.5 * *fov_deg * kDegree);
    throw CLI::ValidationError("--focal-length", "give --focal-length MM or --fov DEGREES (the pixel-to-angle mapping)");
}

// A frame's R, G, B as floats, or an error naming the file.
measured::SweepFrame read_sweep_frame(const std::string& path, double angle_deg) {
    Frame frame = read_image(path);
    if (!frame.has_rgb()) throw std::runtime_error(fmt::format("{}: no R, G, B channels", path));
    if (!frame.spec.data_is_display()) throw std::runtime_error(fmt::format("{}: the data window must be the display window", path));
    load_rgb(frame);
    measured::SweepFrame f;
    f.width = frame.spec.width, f.height = frame.spec.height, f.angle_deg = angle_deg;
    f.rgb = std::move(frame.rgb);
    for (float v : f.rgb)
        if (!std::isfinite(v)) throw std::runtime_error(fmt::format("{}: a pixel is not finite", path));
    return f;
}

struct FitArgs {
    std::string sweep, angles, output, report, frames, name;
    std::string sensor = "36";
    std::optional<double> focal_mm, fov_deg;
    double f_number = 0.0, iso = 100.0, shutter_s = 1.0;
    bool progress = false;  // --progress: the fit's steps on stderr even when it is not a terminal
    measured::FitOptions options;
};

void run_fit(FitArgs& a) {
    refuse_overwrite(a.output, "-o", a.sweep);
    refuse_special_output(a.output, "-o");
    if (!a.report.empty()) {  // the report, written after the preset, overwrites neither it nor a frame
        refuse_overwrite(a.report, "--report", a.sweep, a.output);
        require_writable_file(a.report, "--report");  // refuse_special_output's checks, then a byte written beside it
    }
    const std::vector<double> angles = parse_angles(a.angles, "--angles");
    const FrameList list = frames_to_read(a.sweep, a.frames, true);
    if (list.size() != angles.size())
        throw CLI::ValidationError("--angles", fmt::format("{} gives {} angles, the sweep {} has {} frames", a.angles, angles.size(), a.sweep, list.size()));
    const FramePattern pattern = parse_pattern(a.sweep);
    std::vector<measured::SweepFrame> frames;
    for (std::uint64_t i = 0; i < list.size(); ++i) frames.push_back(read_sweep_frame(pattern.path(list[i]), angles[i]));
    const auto [sw, sh] = sensor_of(a.sensor, frames[0].width, frames[0].height);
    measured::FitOptions& o = a.options;
    o.sensor_width_mm = sw, o.sensor_height_mm = sh;
    o.focal_length_mm = focal_of(a.focal_mm, a.fov_deg, sw);
    o.capture = {a.f_number, a.iso, a.shutter_s, 1.0};
    if (a.progress || ::isatty(STDERR_FILENO))  // a failure in a pipe or a log stays one line
        o.progress = [](const std::string& line) { fmt::print(stderr, "lensfx lens fit: {}\n", line); };
    const auto start = std::chrono::steady_clock::now();
    measured::FitResult fit = measured::fit_sweep(frames, o);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    fit.lens.name = a.name.empty() ? fmt::format("measured from {}", a.sweep) : a.name;
    fit.lens.source = fmt::format("lensfx lens fit {} --angles {} (focal length {:g} mm, sensor {:g}x{:g} mm)", a.sweep, a.angles, o.focal_length_mm, sw, sh);
    if (fit.lens.ghosts.empty()) throw std::runtime_error(fmt::format("{}: no ghost was found on the light-centre axis of {} frames", a.sweep, frames.size()));
    write_file(a.output, measured::write_measured_toml(fit.lens));
    fmt::print(stderr, "lensfx lens fit: {} ghosts from {} frames in {:.1f} s -> {}\n", fit.lens.ghosts.size(), frames.size(), seconds, a.output);
    if (!a.report.empty()) {
        nlohmann::json frames_json = nlohmann::json::array();
        for (const measured::FrameFit& f : fit.frames)
            frames_json.push_back({{"angle_deg", f.angle_deg}, {"ghosts", f.ghosts}, {"background", f.background}, {"noise", f.noise},
                                   {"residual", f.residual}, {"model_residual", f.model_residual}});
        const nlohmann::json report = {{"sweep", a.sweep}, {"model", a.output}, {"ghosts", fit.lens.ghosts.size()}, {"seconds", seconds}, {"frames", frames_json}};
        write_file(a.report, report.dump(2) + "\n");
    }
}

// One light's ghosts through a lens file or preset, physical or measured, on the GPU.
class AnyLensRenderer {
public:
    explicit AnyLensRenderer(const std::string& lens, const std::string& gpu_platform) : context_(gpu::parse_platform(gpu_platform)) {
        if (measured::is_measured_file(lens)) {
            measured_ = measured::read_measured(lens);
            measured_renderer_ = std::make_unique<gpu::MeasuredRenderer>(context_);
            focal_mm_ = measured_->focal_length_mm;
        } else {
            system_ = optics::realize(optics::load_lens(lens), 0.0);
            apply_coatings(*system_, "lens", 0.03);
            renderer_ = std::make_unique<gpu::FlareRenderer>(context_);
            focal_mm_ = optics::paraxial(*system_).efl_mm;
        }
    }
    double focal_mm() const { return focal_mm_; }
    std::vector<float> render(const flare::FlareView& view) {
        if (measured_) {
            std::vector<float> rgb(static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height) * 3, 0.0f);
            measured_renderer_->render_add(*measured_, measured_view(view), {1.0, 1.0, 1.0}, rgb.data());
            return rgb;
        }
        return renderer_->render(*system_, view, gpu::GpuFlareOptions{}).rgb;
    }

private:
    gpu::Context context_;
    std::optional<measured::MeasuredLens> measured_;
    std::unique_ptr<gpu::MeasuredRenderer> measured_renderer_;
    std::optional<optics::System> system_;
    std::unique_ptr<gpu::FlareRenderer> renderer_;
    double focal_mm_ = 0.0;
};

struct PredictArgs {
    std::string lens, angles, map, size = "240x160", sensor = "36", gpu = "auto";
    double scene_level = 1e-3;
    bool json = false;
};

// Log-scaled flare strength as a colour: black, purple, orange, pale yellow.
std::array<float, 3> heat(double t) {
    t = std::clamp(t, 0.0, 1.0);
    const double r = std::clamp(1.6 * t, 0.0, 1.0), g = std::clamp(1.6 * t - 0.55, 0.0, 1.0), b = std::clamp(0.7 * std::sin(t * std::numbers::pi) + std::max(0.0, 2.0 * t - 1.4), 0.0, 1.0);
    return {static_cast<float>(r), static_cast<float>(g), static_cast<float>(b)};
}

// The total flare over (ax, ay) in [-end, end]^2 from the sweep's totals over the field angle (a radially
// symmetric lens), log-scaled, as an image for light planning.
void write_map(const std::string& path, const std::vector<double>& angles, const std::vector<double>& totals) {
    constexpr int kSize = 256;
    const double end = angles.back();
    double lo = 1e300, hi = 0.0;
    for (double t : totals)
        if (t > 0.0) lo = std::min(lo, t), hi = std::max(hi, t);
    std::vector<float> rgb(kSize * kSize * 3, 0.0f);
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            const double ax = ((x + 0.5) / kSize * 2.0 - 1.0) * end, ay = (1.0 - (y + 0.5) / kSize * 2.0) * end;
            const double field = measured::field_and_roll(ax, ay)[0];
            if (field < angles.front() || field > angles.back()) continue;
            if (angles.size() < 2) {
                std::copy_n(heat(totals[0] > 0.0 ? 1.0 : 0.0).begin(), 3, rgb.begin() + (y * kSize + x) * 3);
                continue;
            }
            const auto it = std::upper_bound(angles.begin(), angles.end(), field);
            const std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - angles.begin(), 1)), angles.size() - 1);
            const double w = angles[i] > angles[i - 1] ? (field - angles[i - 1]) / (angles[i] - angles[i - 1]) : 0.0;
            const double total = totals[i - 1] + std::clamp(w, 0.0, 1.0) * (totals[i] - totals[i - 1]);
            const double t = total > 0.0 && hi > lo ? std::log(total / lo) / std::log(hi / lo) : (total > 0.0 ? 1.0 : 0.0);
            const auto c = heat(t);
            std::copy(c.begin(), c.end(), rgb.begin() + (y * kSize + x) * 3);
        }
    write_image(image_frame(kSize, kSize, 3, PixelType::float32, rgb.data()), path);
}

void run_predict(const PredictArgs& a) {
    const std::vector<double> angles = parse_angles(a.angles, "--angles");
    if (!a.map.empty()) refuse_overwrite(a.map, "--map", a.lens);
    refuse_special_output(a.map, "--map");
    const auto [w, h] = size_of(a.size);
    const auto [sw, sh] = sensor_of(a.sensor, w, h);
    AnyLensRenderer renderer(a.lens, a.gpu);
    flare::FlareView view;
    view.width = w, view.height = h, view.sensor_width_mm = sw, view.sensor_height_mm = sh;
    std::vector<measured::FlareEstimate> estimates;
    const std::vector<float> scene{static_cast<float>(a.scene_level)};
    for (double angle : angles) {
        view.angle_x_deg = angle;
        measured::FlareEstimate e = measured::estimate(renderer.render(view), w, h, scene, (sw / w) * (sh / h));
        e.angle_deg = angle;
        estimates.push_back(e);
    }
    std::vector<double> totals;
    for (const auto& e : estimates) totals.push_back(e.total);
    const std::vector<double> rating = measured::rated(totals);
    if (a.json) {
        nlohmann::json list = nlohmann::json::array();
        for (const auto& e : estimates) list.push_back({{"angle_deg", e.angle_deg}, {"peak", e.peak}, {"total", e.total}, {"glare", e.glare}, {"contrast", e.contrast}});
        fmt::print("{}\n", list.dump(2));
    } else {
        fmt::print("# {}: flare of a light of irradiance 1 on a flat grey scene of {:g}; rating: total against the range (0 least, 1 most)\n", a.lens, a.scene_level);
        fmt::print("{:>9} {:>12} {:>12} {:>12} {:>10} {:>7}\n", "angle_deg", "peak", "total", "glare", "contrast", "rating");
        for (std::size_t i = 0; i < estimates.size(); ++i) {
            const auto& e = estimates[i];
            fmt::print("{:>9.3f} {:>12.4e} {:>12.4e} {:>12.4e} {:>10.4f} {:>7.3f}\n", e.angle_deg, e.peak, e.total, e.glare, e.contrast, rating[i]);
        }
    }
    if (!a.map.empty()) write_map(a.map, angles, totals);
}

}  // namespace

std::vector<double> parse_angles(const std::string& text, const char* option) {
    double v[3] = {};
    std::size_t at = 0;
    for (int i = 0; i < 3; ++i) {
        const auto end = i < 2 ? text.find(':', at) : text.size();
        try {
            if (end == std::string::npos) throw std::invalid_argument(text);
            std::size_t used = 0;
            v[i] = std::stod(text.substr(at, end - at), &used);
            if (used != end - at || !std::isfinite(v[i])) throw std::invalid_argument(text);
        } catch (const std::exception&) {
            throw CLI::ValidationError(option, fmt::format("'{}': expected START:END:STEP in degrees, e.g. 0:20:0.5", text));
        }
        at = end + 1;
    }
    if (!(v[2] > 0.0) || v[1] < v[0] || v[0] < 0.0 || v[1] > 89.0 || (v[1] - v[0]) / v[2] > 10000)
        throw CLI::ValidationError(option, fmt::format("'{}': angles 0..89, END >= START, STEP > 0, at most 10000 steps", text));
    std::vector<double> angles;
    const auto n = static_cast<int>(std::floor((v[1] - v[0]) / v[2] + 1e-9));
    for (int i = 0; i <= n; ++i) angles.push_back(v[0] + i * v[2]);
    return angles;
}

measured::MeasuredView measured_view(const flare::FlareView& view) {
    measured::MeasuredView m;
    m.angle_x_deg = view.angle_x_deg, m.angle_y_deg = view.angle_y_deg;
    m.sensor_width_mm = view.sensor_width_mm, m.sensor_height_mm = view.sensor_height_mm;
    m.width = view.width, m.height = view.height;
    return m;
}

flare::FlareImage render_measured_flare(const std::string& path, const flare::FlareView& view, const measured::Capture& target, bool reference,
                                      const std::string& gpu_platform) {
    const measured::MeasuredLens lens = measured::read_measured(path);
    const double scale = measured::brightness_scale(lens.capture, target);
    flare::FlareImage image;
    image.width = view.width, image.height = view.height;
    image.rgb.assign(static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height) * 3, 0.0f);
    if (reference) {
        measured::render_add(lens, measured_view(view), {scale, scale, scale}, image.rgb.data());
    } else {
        const gpu::Context context(gpu::parse_platform(gpu_platform));
        gpu::MeasuredRenderer renderer(context);
        renderer.render_add(lens, measured_view(view), {scale, scale, scale}, image.rgb.data());
    }
    return image;
}

void register_lens_fit_command(CLI::App& lens) {
    auto a = std::make_shared<FitArgs>();
    auto* cmd = lens.add_subcommand("fit", "Fit a measured lens to a sweep of photographs of a point light (Walch et al. 2018)");
    cmd->add_option("sweep", a->sweep, "The sweep: a frame pattern (sweep.####.exr), frame i at START + i x STEP degrees")->required();
    cmd->add_option("--angles", a->angles, "START:END:STEP in degrees: the light's angle right of the view axis in each frame")->required();
    cmd->add_option("-o,--output", a->output, "The measured lens preset to write (.toml)")->required();
    cmd->add_option("--frames", a->frames, "Which frames of the pattern (default: those on disk)");
    cmd->add_option("--sensor", a->sensor, "Sensor width in mm, or WxH (the height from the frames' aspect)")->capture_default_str();
    cmd->add_option("--focal-length", a->focal_mm, "Focal length in mm (pixel -> angle)")->check(CLI::Range(0.1, 1e5));
    cmd->add_option("--fov", a->fov_deg, "Horizontal field of view in degrees, instead of --focal-length")->check(CLI::Range(0.1, 179.0))->excludes("--focal-length");
    cmd->add_option("--fstop", a->f_number, "The capture's f-number (paper equation 2; 0: not known)")->check(CLI::Range(0.0, 1000.0));
    cmd->add_option("--iso", a->iso, "The capture's ISO")->capture_default_str()->check(CLI::Range(1.0, 1e7));
    cmd->add_option("--shutter", a->shutter_s, "The capture's exposure time in seconds")->capture_default_str()->check(CLI::Range(1e-6, 1e5));
    cmd->add_option("--name", a->name, "The preset's name");
    cmd->add_option("--report", a->report, "JSON report: the fit's residual per frame");
    cmd->add_flag("--progress", a->progress, "Show the fit's steps even when stderr is not a terminal");
    cmd->add_option("--key-iterations", a->options.key_iterations, "Gradient-descent passes at each ghost's key frame")->capture_default_str()->check(CLI::Range(1, 100000));
    cmd->add_option("--track-iterations", a->options.track_iterations, "Passes at each tracked frame")->capture_default_str()->check(CLI::Range(1, 100000));
    cmd->add_option("--edge-weight", a->options.edge_weight, "Weight of the smoothed Laplacian edge cost against the MSE")->capture_default_str()->check(CLI::Range(0.0, 100.0));
    cmd->add_option("--min-snr", a->options.min_snr, "A ghost's level on the axis over the noise, to be found")->capture_default_str()->check(CLI::Range(0.5, 1e6));
    cmd->add_option("--max-ghosts", a->options.max_ghosts, "Ghosts found per frame at most")->capture_default_str()->check(CLI::Range(1, 256));
    cmd->add_option("--threads", a->options.threads, "Worker threads (0: one per core)")->capture_default_str()->check(CLI::Range(0, 1024));
    cmd->callback([a] { run_fit(*a); });
}

void register_predict_command(CLI::App& app) {
    auto a = std::make_shared<PredictArgs>();
    auto* cmd = app.add_subcommand("predict", "Flare estimators over a range of light angles (peak, total, glare, contrast), for any lens");
    cmd->add_option("--lens", a->lens, "Preset name, lens file or measured lens (.toml)")->required();
    cmd->add_option("--angles", a->angles, "START:END:STEP in degrees off the view axis")->required();
    cmd->add_flag("--json", a->json, "Print a JSON list of {angle_deg, peak, total, glare, contrast}");
    cmd->add_option("--map", a->map, "Write the flare strength over (ax, ay) as an image (PNG), for light planning");
    cmd->add_option("--size", a->size, "Image WxH in pixels for the estimators")->capture_default_str();
    cmd->add_option("--sensor", a->sensor, "Sensor width in mm, or WxH")->capture_default_str();
    cmd->add_option("--scene-level", a->scene_level, "The flat grey scene's level (sensor irradiance; the light's is 1)")->capture_default_str()->check(CLI::Range(1e-12, 1e12));
    cmd->add_option("--gpu", a->gpu, "EGL platform: auto, device or surfaceless")->check(CLI::IsMember({"auto", "device", "surfaceless"}))->capture_default_str();
    cmd->callback([a] { run_predict(*a); });
}

}  // namespace lensfx::filter
