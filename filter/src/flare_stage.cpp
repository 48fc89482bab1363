// The flare stage: lights -> directions and strengths -> GPU ghost images -> added to the frame.
#include <filter/flare_stage.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <fmt/core.h>

#include <detect/detector.h>
#include <detect/threshold.h>
#include <detect/track_file.h>
#include <detect/tracker.h>
#include <gpu/context.h>
#include <gpu/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/starburst.h>
#include <optics/system.h>
#include <optics/tracer.h>

namespace lensfx::filter {

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
    app.add_option("--fstop", s.fstop, "Stop the iris down to this f-number")->group(group)->check(CLI::PositiveNumber);
    app.add_option("--blades", s.blades, "Iris blade count (0 = round), overriding the lens's")->group(group)->check(CLI::Range(0, 64));
    app.add_option("--threshold", s.threshold, "Light-source threshold: luminance (20) or stops above the median (+6ev)")->capture_default_str()->group(group);
    app.add_option("--max-lights", s.max_lights, "The brightest lights rendered per frame")->capture_default_str()->group(group)->check(CLI::Range(0, 4096));
    app.add_option("--sensor", s.sensor, "Sensor width in mm, or WxH (the height follows the frame's aspect)")->capture_default_str()->group(group);
    app.add_option("--fov", s.fov_deg, "Horizontal field of view in degrees (instead of the lens's focal length)")->group(group)->check(CLI::Range(0.1, 179.0));
    app.add_option("--gain", s.gain, "Scale of the whole flare (1 = physical)")->capture_default_str()->group(group)->check(CLI::NonNegativeNumber);
    app.add_option("--source-gain", s.source_gain, "Strength multiplier for clipped sources")->capture_default_str()->group(group)->check(CLI::NonNegativeNumber);
    app.add_flag("--flare-only", s.flare_only, "Write the flare alone, on black")->group(group);
    app.add_option("--tracks", s.tracks, "Render the lights of this track file (lensfx track) instead of detecting")->group(group);
    app.add_option("--gpu", s.gpu, "EGL platform: auto, device (a GPU driver), surfaceless (Mesa)")->capture_default_str()->group(group)
        ->check(CLI::IsMember({"auto", "device", "surfaceless"}));
    app.add_option("--parts", s.parts, "What to render: ghosts, starburst or both (ghosts,starburst)")->capture_default_str()->group(group);
    app.add_option("--starburst-gain", s.starburst_gain, "Starburst energy relative to the light's own recorded energy")->capture_default_str()->group(group)->check(CLI::NonNegativeNumber);
    app.add_option("--starburst-scale", s.starburst_scale, "Starburst size relative to its physical size (wavelength x f-number)")->capture_default_str()->group(group)->check(CLI::PositiveNumber);
    app.add_option("--grid", s.grid, "Base ray grid cells per side of each ghost (the adaptive grid scales it)")->capture_default_str()->group(group)->check(CLI::Range(4, 1024));
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

std::array<double, 2> FlareGeometry::angles_at(double x, double y) const {
    const double xs = (x / width - 0.5) * sensor_width_mm;
    const double ys = (0.5 - y / height) * sensor_height_mm;
    return {std::atan(xs / focal_mm) * kDegrees, std::atan(ys / focal_mm) * kDegrees};
}

double FlareGeometry::pixel_area_mm2() const {
    return (sensor_width_mm / width) * (sensor_height_mm / height);
}

std::array<double, 3> direct_power(const optics::System& system, double ax_deg, double ay_deg, int rays) {
    std::array<double, 3> power{};
    gpu::FlareView view;
    view.angle_x_deg = ax_deg;
    view.angle_y_deg = ay_deg;
    const std::vector<optics::Step> path = optics::direct_path(system);
    for (std::size_t c = 0; c < 3; ++c) {
        const optics::TraceSystem traced(system, gpu::kRgbWavelengths_nm[c]);
        const gpu::PupilRect square = gpu::entrance_square(traced, view);
        const double dx = (square.x1 - square.x0) / rays;
        const double dy = (square.y1 - square.y0) / rays;
        double sum = 0.0;
        for (int iy = 0; iy < rays; ++iy) {
            for (int ix = 0; ix < rays; ++ix) {
                const optics::Ray ray = optics::collimated_ray(ax_deg, ay_deg, square.x0 + dx * (ix + 0.5),
                                                               square.y0 + dy * (iy + 0.5), 0.0);
                const optics::TraceResult r = optics::trace(traced, ray, path);
                if (gpu::ray_passes(r, system.aperture)) sum += r.transmission * std::abs(ray.direction.z);
            }
        }
        power[c] = sum * dx * dy;
    }
    return power;
}

struct FlareStage::State {
    FlareSettings settings;
    optics::System system;
    double efl_mm = 0.0;
    std::array<double, 2> sensor{};
    std::optional<detect::TrackFile> tracks;
    detect::Detector detector;
    detect::Tracker tracker;
    std::unique_ptr<gpu::Context> context;  // created at the first frame that has a light
    std::unique_ptr<gpu::FlareRenderer> renderer;
    FlareParts parts;
    double f_number = 0.0;
    std::optional<optics::Starburst> starburst;  // computed at the first light

    explicit State(FlareSettings s)
        : settings(std::move(s)),
          detector([&] {
              detect::DetectorOptions o;
              o.threshold = detect::Threshold::parse(settings.threshold);
              o.max_lights = settings.max_lights;
              return o;
          }()) {
        const optics::Lens lens = optics::load_lens(settings.lens);
        const double zoom = settings.zoom.empty() ? 0.0 : optics::parse_zoom(lens, settings.zoom);
        system = optics::realize(lens, zoom, settings.fstop);
        if (settings.blades) system.aperture.blades = *settings.blades;
        const optics::Paraxial first_order = optics::paraxial(system);
        efl_mm = first_order.efl_mm;
        f_number = first_order.f_number;
        parts = parse_parts(settings.parts);
        sensor = parse_sensor(settings.sensor);
        if (!settings.tracks.empty()) tracks = detect::read_track_file(settings.tracks);
    }

    FlareGeometry geometry(const Frame& frame) const {
        FlareGeometry g;
        g.width = frame.spec.full_width;
        g.height = frame.spec.full_height;
        g.sensor_width_mm = sensor[0];
        const double aspect = frame.spec.get_float_attribute("PixelAspectRatio", 1.0f);
        g.sensor_height_mm = sensor[1] > 0.0 ? sensor[1] : sensor[0] * g.height / (g.width * aspect);
        g.focal_mm = settings.fov_deg ? 0.5 * g.sensor_width_mm / std::tan(0.5 * *settings.fov_deg / kDegrees) : efl_mm;
        return g;
    }

    std::vector<detect::Light> lights(const Frame& frame) {
        if (tracks) {
            std::vector<detect::Light> found = tracks->lights_at(static_cast<int>(frame.number));
            if (tracks->width > 0 && tracks->width != frame.spec.full_width)
                throw std::runtime_error(fmt::format("track file {} is for {}x{} frames, this one is {}x{}", settings.tracks,
                                                     tracks->width, tracks->height, frame.spec.full_width, frame.spec.full_height));
            return found;
        }
        return tracker.update(detector.detect(rgb_view(frame)));
    }
};

FlareStage::FlareStage(FlareSettings settings) : state_(std::make_unique<State>(std::move(settings))) {}
FlareStage::~FlareStage() = default;

void FlareStage::process(Frame& frame) {
    State& s = *state_;
    const std::vector<detect::Light> lights = s.lights(frame);
    FlareParts& parts = s.parts;
    if (s.settings.flare_only) std::fill(frame.rgb.begin(), frame.rgb.end(), 0.0f);
    if (lights.empty() || s.settings.gain == 0.0) return;  // no light: the GPU is never touched

    const FlareGeometry geo = s.geometry(frame);
    if (!s.context && parts.ghosts) {
        s.context = std::make_unique<gpu::Context>(gpu::parse_platform(s.settings.gpu));
        s.renderer = std::make_unique<gpu::FlareRenderer>(*s.context);
    }
    gpu::GpuFlareOptions render_options;
    render_options.grid = s.settings.grid;

    const int dx0 = frame.spec.x - frame.spec.full_x;
    const int dy0 = frame.spec.y - frame.spec.full_y;
    for (const detect::Light& light : lights) {
        const auto [ax, ay] = geo.angles_at(light.x, light.y);
        const std::array<double, 3> direct = direct_power(s.system, ax, ay);
        const double boost = (light.clipped ? s.settings.source_gain : 1.0) * s.settings.gain * light.weight;
        std::array<float, 3> scale{};
        bool any = false;
        for (std::size_t c = 0; c < 3; ++c) {
            // Irradiance of the light at the lens: the energy its image recorded over what unit irradiance gives.
            if (direct[c] <= 0.0) continue;
            const double irradiance = std::max(0.0, light.flux[c]) * geo.pixel_area_mm2() / direct[c];
            scale[c] = static_cast<float>(irradiance * boost);
            any = any || scale[c] > 0.0f;
        }
        if (!any) continue;  // outside what the lens images: nothing reaches the sensor

        if (parts.starburst && s.settings.starburst_gain > 0.0) {
            if (!s.starburst) s.starburst = optics::make_starburst(s.system.aperture);
            // The light's diffraction pattern carries its recorded energy, centred on its image; its core is
            // already in the recorded pixels, so only the spikes and rings are added.
            std::array<double, 3> energy{};
            for (std::size_t c = 0; c < 3; ++c)
                energy[c] = std::max(0.0, light.flux[c]) * geo.pixel_area_mm2() * s.settings.starburst_gain * boost;
            // An artistic --starburst-scale enlarges the core too; never leave out more than the light's
            // own pixel, or a small light would show a hole.
            const double texel_px = s.starburst->texel_per_fnumber_mm * s.f_number * s.settings.starburst_scale /
                                    (geo.sensor_width_mm / geo.width);
            const double core_texels = std::min(optics::starburst_core_radius_texels(*s.starburst), 0.75 / texel_px);
            optics::splat_starburst(*s.starburst, s.f_number * s.settings.starburst_scale, light.x - dx0,
                                    light.y - dy0, energy, geo.sensor_width_mm / geo.width,
                                    geo.sensor_height_mm / geo.height, frame.rgb.data(), frame.spec.width,
                                    frame.spec.height, core_texels);
        }
        if (!parts.ghosts) continue;

        gpu::FlareView view;
        view.angle_x_deg = ax;
        view.angle_y_deg = ay;
        view.sensor_width_mm = geo.sensor_width_mm;
        view.sensor_height_mm = geo.sensor_height_mm;
        view.width = geo.width;
        view.height = geo.height;
        const gpu::FlareImage flare = s.renderer->render(s.system, view, render_options);

        for (int y = 0; y < frame.spec.height; ++y) {
            const int fy = y + dy0;
            if (fy < 0 || fy >= flare.height) continue;
            for (int x = 0; x < frame.spec.width; ++x) {
                const int fx = x + dx0;
                if (fx < 0 || fx >= flare.width) continue;
                float* px = &frame.rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(frame.spec.width) +
                                        static_cast<std::size_t>(x)) * 3];
                for (int c = 0; c < 3; ++c) px[c] += scale[static_cast<std::size_t>(c)] * flare.at(fx, fy, c);
            }
        }
    }
}

}  // namespace lensfx::filter
