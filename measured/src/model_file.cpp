// Reading and writing measured lens presets (TOML).
#include <measured/model_file.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/core.h>
#include <toml++/toml.h>

#include <optics/lens_file.h>

#include "regular_file.h"
#include "toml_fields.h"

namespace lensfx::measured {

namespace {

using optics::LensFileError;
using optics::toml_fields::Fields;

constexpr double kMaxCoefficient = 1e6;

std::string file_text(const std::filesystem::path& path) {
    optics::require_regular_file(path);
    std::ifstream in(path, std::ios::binary);
    if (!in) throw LensFileError(fmt::format("{}: cannot open", path.string()));
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

std::array<double, 3> coefficients(Fields& f, std::string_view key) {
    const std::vector<double> v = f.numbers(key, true);
    if (v.empty()) f.error(key, "missing (1 to 3 polynomial coefficients over the angle in degrees)");
    if (v.size() > 3) f.error(key, fmt::format("{} coefficients; a degree-2 polynomial has at most 3", v.size()));
    std::array<double, 3> c{};
    for (std::size_t i = 0; i < v.size(); ++i) c[i] = v[i];
    return c;
}

MeasuredGhost read_ghost(const toml::table& t, std::string_view origin, std::size_t index) {
    Fields f(t, origin, fmt::format("ghost {}: ", index + 1));
    MeasuredGhost g;
    const std::vector<double> angles = f.numbers("angles", false);
    if (angles.size() != 2) f.error("angles", "expected [first, last] in degrees");
    g.angle_min_deg = angles[0];
    g.angle_max_deg = angles[1];
    for (int i = 0; i < kParamCount; ++i) g.poly[static_cast<std::size_t>(i)] = coefficients(f, param_names()[static_cast<std::size_t>(i)]);
    f.reject_unknown();
    return g;
}

void check(bool ok, std::string_view origin, const std::string& what) {
    if (!ok) throw LensFileError(fmt::format("{}: {}", origin, what));
}

// A TOML basic string.
std::string quoted(const std::string& text) {
    std::string out = "\"";
    for (char ch : text) {
        if (ch == '"' || ch == '\\') out += '\\', out += ch;
        else if (static_cast<unsigned char>(ch) < 0x20) out += fmt::format("\\u{:04x}", static_cast<int>(ch));
        else out += ch;
    }
    return out + "\"";
}

std::string numbers_text(const std::array<double, 3>& c) { return fmt::format("[{:.9g}, {:.9g}, {:.9g}]", c[0], c[1], c[2]); }

}  // namespace

bool is_measured_file(std::string_view name_or_path) {
    const std::filesystem::path path(name_or_path);
    std::error_code ec;
    if (path.extension() != ".toml" || !std::filesystem::is_regular_file(path, ec)) return false;
    std::ifstream in(path);
    std::string line;
    for (int i = 0; i < 200 && std::getline(in, line); ++i) {
        const auto start = line.find_first_not_of(" \t");
        if (start == std::string::npos || line[start] == '#') continue;
        if (line.compare(start, 4, "kind") == 0 && line.find("\"measured\"") != std::string::npos) return true;
        if (line[start] == '[') return false;  // the top-level keys have ended
    }
    return false;
}

MeasuredLens parse_measured_toml(std::string_view text, std::string_view origin) {
    const toml::table doc = optics::toml_fields::parse_toml(text, origin);
    Fields top(doc, origin, "");
    const auto kind = top.opt_string("kind");
    if (kind != "measured") top.error("kind", "expected \"measured\"");
    MeasuredLens lens;
    lens.name = top.opt_string("name").value_or("");
    lens.source = top.opt_string("source").value_or("");
    lens.focal_length_mm = top.required_number("focal_length", "mm, the focal length the sweep was shot at");
    const std::vector<double> sensor = top.numbers("sensor", false);
    if (sensor.size() != 2) top.error("sensor", "expected [width, height] in mm");
    lens.sensor_mm = {sensor[0], sensor[1]};
    if (const toml::node* c = top.get("capture")) {
        if (!c->is_table()) top.error("capture", "expected a table");
        Fields cap(*c->as_table(), origin, "capture: ");
        lens.capture.f_number = cap.opt_number("f_number").value_or(0.0);
        lens.capture.iso = cap.opt_number("iso").value_or(100.0);
        lens.capture.exposure_s = cap.opt_number("exposure").value_or(1.0);
        lens.capture.light_energy = cap.opt_number("light_energy").value_or(1.0);
        cap.reject_unknown();
    }
    if (const toml::node* g = top.get("ghost")) {
        const toml::array* list = g->as_array();
        if (!list) top.error("ghost", "expected [[ghost]] tables");
        for (std::size_t i = 0; i < list->size(); ++i) {
            const toml::table* t = (*list)[i].as_table();
            if (!t) top.error("ghost", fmt::format("entry {} is not a table", i + 1));
            lens.ghosts.push_back(read_ghost(*t, origin, i));
        }
    }
    top.reject_unknown();
    validate_measured(lens, origin);
    return lens;
}

MeasuredLens read_measured(const std::filesystem::path& path) { return parse_measured_toml(file_text(path), path.string()); }

void validate_measured(const MeasuredLens& lens, std::string_view origin) {
    check(std::isfinite(lens.focal_length_mm) && lens.focal_length_mm > 0.0 && lens.focal_length_mm < 1e5, origin,
          fmt::format("focal_length: {} is not a focal length in mm (0 to 1e5)", lens.focal_length_mm));
    for (double s : lens.sensor_mm) check(std::isfinite(s) && s > 0.0 && s < 1e4, origin, fmt::format("sensor: {} mm is not a sensor size", s));
    const Capture& c = lens.capture;
    check(std::isfinite(c.f_number) && c.f_number >= 0.0 && c.f_number < 1e3, origin, fmt::format("capture: f_number: {} (0 or a positive f-number)", c.f_number));
    check(std::isfinite(c.iso) && c.iso > 0.0 && c.iso < 1e8, origin, fmt::format("capture: iso: {} must be positive", c.iso));
    check(std::isfinite(c.exposure_s) && c.exposure_s > 0.0 && c.exposure_s < 1e6, origin, fmt::format("capture: exposure: {} s must be positive", c.exposure_s));
    check(std::isfinite(c.light_energy) && c.light_energy > 0.0 && c.light_energy < 1e30, origin,
          fmt::format("capture: light_energy: {} must be positive", c.light_energy));
    check(lens.ghosts.size() <= 1024, origin, fmt::format("{} ghosts; at most 1024", lens.ghosts.size()));
    for (std::size_t i = 0; i < lens.ghosts.size(); ++i) {
        const MeasuredGhost& g = lens.ghosts[i];
        check(std::isfinite(g.angle_min_deg) && std::isfinite(g.angle_max_deg) && g.angle_min_deg >= 0.0 && g.angle_max_deg <= 89.0 &&
                  g.angle_min_deg <= g.angle_max_deg,
              origin, fmt::format("ghost {}: angles: [{}, {}] must be an increasing range within 0..89 degrees", i + 1, g.angle_min_deg, g.angle_max_deg));
        for (int p = 0; p < kParamCount; ++p)
            for (double v : g.poly[static_cast<std::size_t>(p)])
                check(std::isfinite(v) && std::abs(v) < kMaxCoefficient, origin,
                      fmt::format("ghost {}: {}: coefficient {} is not finite or over 1e6", i + 1, param_names()[static_cast<std::size_t>(p)], v));
    }
}

std::string write_measured_toml(const MeasuredLens& lens) {
    std::string out = "# A measured lens: ghosts fitted to photographs (lensfx lens fit; docs/measured-lenses.md).\n";
    out += "# Each ghost parameter is c0 + c1 a + c2 a^2 over the light's field angle a in degrees; lengths in mm on the sensor.\n";
    out += "kind = \"measured\"\n";
    out += fmt::format("name = {}\n", quoted(lens.name));
    out += fmt::format("source = {}\n", quoted(lens.source));
    out += fmt::format("focal_length = {:.9g}\n", lens.focal_length_mm);
    out += fmt::format("sensor = [{:.9g}, {:.9g}]\n", lens.sensor_mm[0], lens.sensor_mm[1]);
    out += fmt::format("\n[capture]  # paper equation 2; light_energy: the light's own image (sum x pixel area, mm^2)\n");
    out += fmt::format("f_number = {:.9g}\niso = {:.9g}\nexposure = {:.9g}\nlight_energy = {:.9g}\n", lens.capture.f_number, lens.capture.iso,
                       lens.capture.exposure_s, lens.capture.light_energy);
    for (const MeasuredGhost& g : lens.ghosts) {
        out += fmt::format("\n[[ghost]]\nangles = [{:.9g}, {:.9g}]\n", g.angle_min_deg, g.angle_max_deg);
        for (int p = 0; p < kParamCount; ++p)
            out += fmt::format("{} = {}\n", param_names()[static_cast<std::size_t>(p)], numbers_text(g.poly[static_cast<std::size_t>(p)]));
    }
    return out;
}

}  // namespace lensfx::measured
