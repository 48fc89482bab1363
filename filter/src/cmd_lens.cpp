// `lensfx lens info|trace|list|convert`: paraxial data, one exact meridional ray, the preset list, and
// conversion of any supported lens file to the project's format.
#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <optics/ghosts.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/presets.h>
#include <optics/system.h>
#include <optics/tracer.h>
#include <optics/text_pairs.h>

#include <filter/flare_settings.h>
#include <filter/option_checks.h>
#include <filter/output_files.h>

#include "commands.h"

namespace lensfx::filter {
namespace {

using nlohmann::json;

struct LensOptions {
    std::string lens;
    std::string zoom = "0";
    double wavelength_nm = optics::kLambdaD_nm;
    std::optional<double> f_number;
    std::string sensor = "36x24";
    bool json = false;
};

// "36x24" -> {36, 24} (mm): the flare's --sensor (parse_sensor, its bounds), both sides given.
std::pair<double, double> lens_sensor(const std::string& text) {
    const auto [w, h] = parse_sensor(text);
    if (h > 0.0) return {w, h};
    throw std::invalid_argument(fmt::format("--sensor '{}': expected WxH in mm, e.g. 36x24", text));
}

void add_lens_options(CLI::App* cmd, LensOptions& o) {
    cmd->add_option("lens", o.lens, "Preset name or lens file (.toml, pbrt .dat, lentil .fx)")->required();
    cmd->add_option("--zoom", o.zoom, "Zoom: 0 (short) to 1 (long), or a focal length label like 135mm");
    cmd->add_option("--wavelength", o.wavelength_nm, "Wavelength in nm")->check(CLI::Range(300.0, 1100.0));
    cmd->add_option("--fstop", o.f_number, "Set the stop for this paraxial f-number (default: the stop wide open)")
        ->check(CLI::PositiveNumber)->check(CLI::Range(0.0, kMaxFNumber));
    cmd->add_option("--sensor", o.sensor, "Sensor WxH in mm, for the field of view (default 36x24)")
        ->check(parsed_by([](const std::string& text) { lens_sensor(text); }, "--sensor", "WxH"));
    cmd->add_flag("--json", o.json, "Print JSON");
}

optics::System realize(const optics::Lens& lens, const LensOptions& o) {
    return optics::realize(lens, optics::parse_zoom(lens, o.zoom), o.f_number);
}

// JSON has no infinity: a pupil at infinity (telecentric) is written as null.
json finite_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

std::string range_text(double a, double b, const char* format) {
    if (std::abs(a - b) < 1e-9 * std::max(1.0, std::abs(a))) return fmt::format(fmt::runtime(format), a);
    return fmt::format(fmt::runtime(format), a) + "-" + fmt::format(fmt::runtime(format), b);
}

void lens_info(const LensOptions& o) {
    const optics::Lens lens = optics::load_lens(o.lens);
    const optics::System sys = realize(lens, o);
    const optics::Paraxial p = optics::paraxial(sys, o.wavelength_nm);
    const std::size_t ghosts = optics::ghost_count(sys);
    if (o.json) {
        const json j = {{"efl_mm", p.efl_mm},
                        {"bfl_mm", p.bfl_mm},
                        {"ffl_mm", p.ffl_mm},
                        {"f_number", p.f_number},
                        {"entrance_pupil_mm", finite_or_null(p.entrance_pupil_mm)},
                        {"entrance_pupil_diameter_mm", p.entrance_pupil_diameter_mm},
                        {"exit_pupil_mm", finite_or_null(p.exit_pupil_mm)},
                        {"exit_pupil_diameter_mm", finite_or_null(p.exit_pupil_diameter_mm)},
                        {"surfaces", sys.interfaces.size()},
                        {"ghosts", ghosts}};
        fmt::print("{}\n", j.dump(2));
        return;
    }
    const auto [sensor_w, sensor_h] = lens_sensor(o.sensor);
    const optics::FieldOfView fov = optics::field_of_view(p, sensor_w, sensor_h);
    fmt::print("lens:            {}\n", lens.name);
    if (!lens.source.empty()) fmt::print("source:          {}\n", lens.source);
    if (lens.zoom_positions() > 1) fmt::print("zoom:            {} of {} columns\n", o.zoom, lens.zoom_positions());
    fmt::print("wavelength:      {:g} nm\n", p.wavelength_nm);
    fmt::print("focal length:    {:.4f} mm\n", p.efl_mm);
    fmt::print("back focal:      {:.4f} mm (last vertex -> focus)\n", p.bfl_mm);
    fmt::print("front focal:     {:.4f} mm (first vertex -> front focus)\n", p.ffl_mm);
    fmt::print("f-number:        f/{:.4f}{}\n", p.f_number, o.f_number ? "" : " (stop wide open)");
    fmt::print("entrance pupil:  {:.4f} mm from the first vertex, diameter {:.4f} mm\n", p.entrance_pupil_mm,
               p.entrance_pupil_diameter_mm);
    fmt::print("exit pupil:      {:.4f} mm from the last vertex, diameter {:.4f} mm\n", p.exit_pupil_mm,
               p.exit_pupil_diameter_mm);
    fmt::print("field of view:   {:.2f} x {:.2f} deg, {:.2f} diagonal ({:g} x {:g} mm sensor, paraxial rectilinear)\n",
               fov.horizontal_deg, fov.vertical_deg, fov.diagonal_deg, sensor_w, sensor_h);
    fmt::print("length:          {:.3f} mm first vertex -> sensor\n", sys.sensor_z_mm);
    fmt::print("surfaces:        {} (stop = surface {})\n", sys.interfaces.size(), sys.stop + 1);
    fmt::print("ghosts:          {} (two-reflection paths)\n", ghosts);
}

void lens_trace(const LensOptions& o, double height_mm, double angle_deg) {
    const optics::Lens lens = optics::load_lens(o.lens);
    const optics::System sys = realize(lens, o);
    const optics::MeridionalTrace t = optics::trace_meridional(sys, height_mm, angle_deg, o.wavelength_nm);
    const bool ok = t.result.ok();
    if (o.json) {
        json rows = json::array();
        for (const auto& s : t.surfaces)
            rows.push_back({{"surface", s.surface}, {"x", s.local.x}, {"y", s.local.y}, {"z", s.local.z},
                            {"dx", s.direction.x}, {"dy", s.direction.y}, {"dz", s.direction.z}, {"path_mm", s.path_mm}});
        json j = {{"surfaces", rows}, {"status", optics::to_string(t.result.status)}};
        if (ok) j["sensor"] = {{"x", t.result.position.x}, {"y", t.result.position.y}, {"path_mm", t.sensor_path_mm}};
        fmt::print("{}\n", j.dump(2));
    } else {
        fmt::print("{}: ray at height {} mm, angle {} deg, {} nm\n", lens.name, height_mm, angle_deg, o.wavelength_nm);
        fmt::print("{:>4} {:>12} {:>12} {:>12} {:>11} {:>11} {:>11} {:>11}\n", "surf", "x", "y", "z(sag)", "dx", "dy", "dz",
                   "path mm");
        for (const auto& s : t.surfaces)
            fmt::print("{:>4} {:>12.6f} {:>12.6f} {:>12.6f} {:>11.8f} {:>11.8f} {:>11.8f} {:>11.6f}\n", s.surface,
                       s.local.x, s.local.y, s.local.z, s.direction.x, s.direction.y, s.direction.z, s.path_mm);
        if (ok) fmt::print("sensor: x {:.6f} y {:.6f} mm (path {:.6f} mm)\n", t.result.position.x, t.result.position.y, t.sensor_path_mm);
    }
    if (!ok)
        throw std::runtime_error(fmt::format("{}: the ray stops at surface {}: {}", lens.name,
                                             t.result.failed_interface + 1, optics::to_string(t.result.status)));
}

void lens_list() {
    fmt::print("{:<26} {:>15} {:>9} {:>8} {:>7}  {}\n", "preset", "focal mm", "f/#", "surfaces", "ghosts", "source");
    for (const auto& name : optics::preset_names()) {
        const optics::Lens lens = optics::load_preset(name);
        const optics::System wide = optics::realize(lens, 0.0), tele = optics::realize(lens, 1.0);
        const optics::Paraxial p0 = optics::paraxial(wide), p1 = optics::paraxial(tele);
        const std::string fnum = lens.stated_f_number > 0 ? fmt::format("{:g}", lens.stated_f_number)
                                                          : range_text(p0.f_number, p1.f_number, "{:.2f}");
        fmt::print("{:<26} {:>15} {:>9} {:>8} {:>7}  {}\n", name, range_text(p0.efl_mm, p1.efl_mm, "{:.1f}"), fnum,
                   wide.interfaces.size(), optics::ghost_count(wide), lens.source.substr(0, 60));
    }
}

}  // namespace

void register_lens_commands(CLI::App& app) {
    auto* lens = app.add_subcommand("lens", "Lens prescriptions: paraxial data, ray traces, presets, conversion");
    lens->require_subcommand(1);

    auto info = std::make_shared<LensOptions>();
    auto* cmd_info = lens->add_subcommand("info", "Focal lengths, focal distances, pupils, f-number, field of view");
    add_lens_options(cmd_info, *info);
    cmd_info->callback([info] { lens_info(*info); });

    auto trace = std::make_shared<LensOptions>();
    auto height = std::make_shared<double>(0.0);
    auto angle = std::make_shared<double>(0.0);
    auto* cmd_trace = lens->add_subcommand("trace", "One exact meridional ray from infinity, surface by surface");
    add_lens_options(cmd_trace, *trace);
    cmd_trace->add_option("--height", *height, "Ray height at the first vertex plane, mm")->required();
    cmd_trace->add_option("--angle", *angle, "Field angle in degrees (positive: light above the axis)")->required();
    cmd_trace->callback([trace, height, angle] { lens_trace(*trace, *height, *angle); });

    lens->add_subcommand("list", "The lens presets")->callback(lens_list);

    register_lens_fit_command(*lens);

    auto in = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    auto* cmd_convert = lens->add_subcommand("convert", "Write a lens (preset or file) in the project's TOML format");
    cmd_convert->add_option("input", *in, "Preset name or lens file (.toml, pbrt .dat, lentil .fx)")->required();
    cmd_convert->add_option("-o,--output", *out, "Output .toml file, or - for stdout")->required();
    cmd_convert->callback([in, out] {
        refuse_overwrite(*out, "-o", *in);
        refuse_special_output(*out, "-o");
        const optics::Lens l = optics::load_lens(*in);
        if (*out == "-") write_stdout(optics::write_lens_toml(l));
        else write_file(*out, optics::write_lens_toml(l));
    });
}

}  // namespace lensfx::filter
