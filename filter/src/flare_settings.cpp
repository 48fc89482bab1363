// The flare settings: the lens both flare commands realize the same way, the options that fill the settings,
// --sensor and --parts.
#include <filter/flare_settings.h>

#include <cmath>
#include <stdexcept>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <detect/threshold.h>
#include <filter/option_checks.h>
#include <flare/flare.h>
#include <optics/coating.h>
#include <optics/lens_file.h>
#include <optics/text_pairs.h>

namespace lensfx::filter {

RealizedLens realize_lens(const LensChoice& c) {
    if (c.blades && (*c.blades < 0 || *c.blades == 1 || *c.blades == 2 || *c.blades > 64))
        throw std::invalid_argument(fmt::format("--blades {}: 0 (round) or 3 to 64", *c.blades));
    optics::Lens lens = optics::load_lens(c.lens);
    const double zoom = c.zoom.empty() ? 0.0 : optics::parse_zoom(lens, c.zoom);
    RealizedLens out;
    out.text = fmt::format("{}\nzoom {:.17g} fstop {:.17g} blades {} coating {} spread {:.17g}", optics::write_lens_toml(lens), zoom,
                           c.fstop.value_or(0.0), c.blades.value_or(-1), c.coating, c.coating_spread);
    if (c.blades) lens.aperture.blades = *c.blades;  // realize copies the iris as it is
    out.system = optics::realize(lens, zoom, c.fstop);
    apply_coatings(out.system, c.coating, c.coating_spread);
    return out;
}

void add_lens_options(CLI::App& app, LensChoice& c, const std::string& group) {
    app.add_option("--zoom", c.zoom, "Zoom position: 0..1, or a focal-length label such as 135mm")->group(group)->check(zoom_check());
    app.add_option("--fstop", c.fstop, "Stop the iris down to this f-number")->group(group)->check(CLI::PositiveNumber)->check(finite_number())
        ->check(CLI::Range(0.0, kMaxFNumber));
    app.add_option("--blades", c.blades, "Iris blade count (0 = round), overriding the lens's")->group(group)->check(CLI::Range(0, 64));
    add_coating_options(app, c.coating, c.coating_spread, group);
}

std::array<double, 2> parse_sensor(const std::string& text) {
    const bool height_given = text.find('x') != std::string::npos;
    const auto wh = parse_pair_of<double>(height_given ? text : text + "x0", 'x');
    if (!wh) throw std::invalid_argument(fmt::format("--sensor must be WIDTH or WIDTHxHEIGHT in mm, not \"{}\"", text));
    const auto [w, h] = *wh;
    // (a height given as 0 would stand for none: the image's aspect)
    if (!(w > 0.0) || !std::isfinite(w) || !(h > 0.0 || (!height_given && h == 0.0)) || !std::isfinite(h))
        throw std::invalid_argument(fmt::format("--sensor {}: sizes must be positive", text));
    const auto within = [](double side) { return side >= kMinSensorMm && side <= kMaxSensorMm; };
    if (!within(w) || (h != 0.0 && !within(h)))
        throw std::invalid_argument(fmt::format("--sensor {}: each side {:g} to {:g} mm (a phone's sensor to the largest plate film, with room; "
                                                "sizes beyond overflow the starburst's pixel arithmetic)", text, kMinSensorMm, kMaxSensorMm));
    return {w, h};
}

CLI::Validator sensor_check() {
    return parsed_by([](const std::string& text) { parse_sensor(text); }, "--sensor", "MM[xMM]");
}

CLI::Validator threshold_check() {
    return parsed_by([](const std::string& text) { detect::Threshold::parse(text); }, "--threshold", "THRESHOLD");
}

CLI::Validator bands_check() {
    return CLI::Validator(
        [](std::string& text) -> std::string {
            int bands = 0;
            if (!CLI::detail::lexical_cast(text, bands) || bands == 0 || (bands >= flare::kMinBands && bands <= flare::kMaxBands)) return {};
            return fmt::format("give 0 (RGB, three wavelengths) or {}..{} spectral bands, not {}", flare::kMinBands, flare::kMaxBands, text);
        },
        "0|7..81");
}

CLI::Validator zoom_check() {
    return CLI::Validator(
        [](std::string& text) -> std::string {
            if (text.empty()) return "needs a value: 0..1, or a focal length like 135mm";
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (end != text.c_str() + text.size()) return {};  // a label (135mm): checked against the lens
            if (!(v >= 0.0 && v <= 1.0)) return "the zoom parameter runs from 0 to 1 (or give a focal length like 135mm), not " + text;
            return {};
        },
        "ZOOM");
}

void add_flare_options(CLI::App& app, FlareSettings& s) {
    const std::string group = "Flare";
    app.add_option("--lens", s.lens, "Lens preset (lensfx lens list) or lens file (.toml, pbrt .dat, lentil .fx)")->group(group);
    add_lens_options(app, s, group);
    app.add_option("--threshold", s.threshold, "Light-source threshold: luminance (20) or stops above the median (+6ev)")->capture_default_str()->group(group)
        ->check(threshold_check());
    app.add_option("--max-lights", s.max_lights, "The brightest lights rendered per frame")->capture_default_str()->group(group)->check(CLI::Range(0, 4096));
    app.add_option("--sensor", s.sensor, "Sensor width in mm, or WxH (the height follows the frame's aspect)")->capture_default_str()->group(group)
        ->check(sensor_check());
    app.add_option("--fov", s.fov_deg, "Horizontal field of view in degrees (instead of the lens's focal length)")->group(group)->check(CLI::Range(0.1, 179.0))->check(finite_number());
    app.add_option("--gain", s.gain, "Scale of the whole flare (1 = physical)")->capture_default_str()->group(group)->check(CLI::NonNegativeNumber)->check(finite_number());
    app.add_option("--source-gain", s.source_gain, "Strength multiplier for clipped sources")->capture_default_str()->group(group)->check(CLI::NonNegativeNumber)->check(finite_number());
    app.add_flag("--flare-only", s.flare_only, "Write the flare alone, on black")->group(group);
    app.add_option("--tracks", s.tracks, "Render the lights of this track file (lensfx track) instead of detecting")->group(group);
    app.add_option("--gpu", s.gpu, "EGL platform: auto, device (a GPU driver), surfaceless (Mesa)")->capture_default_str()->group(group)
        ->check(CLI::IsMember({"auto", "device", "surfaceless"}));
    app.add_option("--parts", s.parts, "What to render: ghosts, starburst or both (ghosts,starburst)")
        ->capture_default_str()
        ->group(group)
        ->check(parsed_by([](const std::string& t) { parse_parts(t); }, "--parts", "PARTS"));
    add_part_gain_options(app, s.controls.ghost_gain, s.starburst_gain, group);
    add_flare_control_options(app, s.controls, group);
    app.add_option("--starburst-scale", s.starburst_scale, "Starburst length relative to its physical length (the spikes' width stays that of wavelength x f-number)")->capture_default_str()->group(group)->check(CLI::PositiveNumber)->check(finite_number());
    app.add_option("--bands", s.bands, "Spectral quality: 0 = RGB (650/550/450 nm), or 7..81 bands over 380..780 nm through the CIE 1931 functions")
        ->capture_default_str()->group(group)->check(bands_check());
    app.add_flag("--band-filter", s.band_filter, "With --bands: blur each ghost between neighbouring bands so few bands look continuous (slower)")->group(group);
    app.add_option("--min-light", s.min_light, "Skip lights dimmer than this fraction of the brightest (fading in up to twice that)")
        ->capture_default_str()->group(group)->check(CLI::Range(0.0, 1.0))->check(finite_number());
    app.add_option("--layer", s.layer, "Write the flare as extra channels LAYER.R/G/B, leaving R, G, B as they were")->group(group)
        ->check(CLI::Validator([](const std::string& v) { return v.empty() ? std::string("the layer needs a name (its channels are NAME.R, .G, .B)") : std::string(); },
                               "NAME"));
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
        ->capture_default_str()->group(group)->check(finite_number())->check(CLI::Range(0.0, 0.49));
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

}  // namespace lensfx::filter
