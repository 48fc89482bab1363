// Importers for pbrt-v4 `.dat` and lentil `.fx` lens tables (formats: ../shared/reference/lenses/README.md).
#include <optics/importers.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <optional>
#include <algorithm>

#include <fmt/core.h>

#include <optics/lens_file.h>
#include <optics/system.h>
#include "regular_file.h"

namespace lensfx::optics {
namespace {

[[noreturn]] void fail(std::string_view origin, int line, const std::string& what) {
    throw LensFileError(fmt::format("{}:{}: {}", origin, line, what));
}

std::optional<double> to_number(std::string_view s) {
    double v = 0.0;
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc{} || end != s.data() + s.size()) return std::nullopt;
    return v;
}

double number(std::string_view token, std::string_view origin, int line, std::string_view field) {
    const auto v = to_number(token);
    if (!v) fail(origin, line, fmt::format("{}: '{}' is not a number", field, token));
    if (!std::isfinite(*v)) fail(origin, line, fmt::format("{}: {} is not a finite number", field, token));
    return *v;
}

std::vector<std::string> split(std::string_view line, std::string_view separators = " \t") {
    std::vector<std::string> out;
    std::size_t i = 0;
    while (true) {
        i = line.find_first_not_of(separators, i);
        if (i == std::string_view::npos) break;
        const std::size_t j = line.find_first_of(separators, i);
        out.emplace_back(line.substr(i, j == std::string_view::npos ? std::string_view::npos : j - i));
        if (j == std::string_view::npos) break;
        i = j;
    }
    return out;
}

std::vector<std::string> lines_of(std::string_view text) {
    std::vector<std::string> out;
    std::size_t pos = 0;
    while (pos < text.size()) {
        const std::size_t eol = std::min(text.find('\n', pos), text.size());
        std::string line(text.substr(pos, eol - pos));
        if (!line.empty() && line.back() == '\r') line.pop_back();
        out.push_back(std::move(line));
        pos = eol + 1;
    }
    return out;
}

std::string trim(std::string_view s) {
    const auto b = s.find_first_not_of(" \t\"");
    if (b == std::string_view::npos) return {};
    const auto e = s.find_last_not_of(" \t\"");
    return std::string(s.substr(b, e - b + 1));
}

std::string stem_of(std::string_view origin) { return std::filesystem::path(std::string(origin)).stem().string(); }

Coating mgf2() {
    Coating c;
    c.kind = Coating::Kind::QuarterWave;
    return c;
}

// The format's default coating: a single MgF2 quarter wave at 550 nm on every air-glass interface.
void coat_air_glass(Lens& lens) {
    Glass before = Glass::air();
    for (auto& s : lens.surfaces) {
        const Glass& after = s.is_stop ? before : s.medium;
        if (!s.is_stop && before.is_air() != after.is_air()) s.coating = mgf2();
        before = after;
    }
}

Glass constant_glass(double n) {
    if (n == 1.0) return Glass::air();
    Glass g;
    g.name = fmt::format("n={}", n);
    g.nd = n;
    return g;
}

}  // namespace

Lens parse_pbrt_dat(std::string_view text, std::string_view origin) {
    Lens lens;
    lens.name = stem_of(origin);
    std::string header;
    int line_no = 0;
    for (const auto& line : lines_of(text)) {
        ++line_no;
        const auto first = line.find_first_not_of(" \t");
        if (first == std::string::npos) continue;
        if (line[first] == '#') {
            const std::string h = trim(std::string_view(line).substr(first + 1));
            if (!h.empty() && h.find("radius") == std::string::npos) header += (header.empty() ? "" : "; ") + h;
            continue;
        }
        const auto cols = split(line);
        if (cols.size() != 4)
            fail(origin, line_no, fmt::format("expected 4 columns (radius thickness eta aperture-diameter), found {}", cols.size()));
        Surface s;
        s.source_line = line_no;
        s.radius_mm = number(cols[0], origin, line_no, "radius");
        s.thickness_mm = {number(cols[1], origin, line_no, "thickness")};
        const double eta = number(cols[2], origin, line_no, "eta");
        const double diameter = number(cols[3], origin, line_no, "aperture");
        if (diameter <= 0.0) fail(origin, line_no, fmt::format("aperture: diameter {} must be positive", diameter));
        if (eta < 0.0 || (eta > 0.0 && eta < 1.0)) fail(origin, line_no, fmt::format("eta: {} is not a refractive index", eta));
        s.semi_diameter_mm = 0.5 * diameter;
        s.is_stop = s.radius_mm == 0.0;
        if (!s.is_stop) s.medium = constant_glass(eta == 0.0 ? 1.0 : eta);
        lens.surfaces.push_back(std::move(s));
    }
    lens.source = header;
    lens.notes = "imported from a pbrt-v4 .dat file: constant refractive indices (the format has no dispersion); "
                 "last thickness set to the paraxial back focal distance at 587.56 nm";
    coat_air_glass(lens);
    if (!lens.surfaces.empty()) lens.surfaces.back().thickness_mm = {0.0};
    validate_lens(lens, origin);
    double bfl = 0.0;
    try {
        const System sys = realize(lens);
        bfl = sys.sensor_z_mm - sys.interfaces.back().z_mm;
    } catch (const std::invalid_argument& e) {
        throw LensFileError(fmt::format("{}: {}", origin, e.what()));
    }
    if (!(bfl > 0.0))
        fail(origin, lens.surfaces.back().source_line,
             fmt::format("the paraxial focus lies {:.4g} mm before the last surface: no real image to put the sensor at", bfl));
    lens.surfaces.back().thickness_mm = {bfl};
    validate_lens(lens, origin);  // the back focal distance too: a nearly afocal lens focuses past any sensor (10 m)
    return lens;
}

namespace {

// What a lentil file states outside its table rows.
struct LentilPreamble {
    double scale = 1.0;  // #!scale: every length is multiplied by it
    std::string header;  // the first comment line
};

// Reads a line that is no table row (a #!scale or #EFL directive, a comment, a blank line) into the
// preamble or the stated focal lengths; false for a table row.
bool read_lentil_non_row(const std::string& line, std::string_view origin, int line_no, LentilPreamble& pre,
                         std::vector<double>& stated_focal_mm) {
    if (line.starts_with("#!scale")) {
        pre.scale = number(trim(std::string_view(line).substr(7)), origin, line_no, "#!scale");
        if (pre.scale <= 0.0) fail(origin, line_no, "#!scale: must be positive");
        return true;
    }
    if (line.starts_with("#EFL")) {
        for (const auto& w : split(std::string_view(line).substr(4))) {
            const auto v = to_number(w);
            if (!v) break;
            stated_focal_mm.push_back(*v);
        }
        return true;
    }
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos) return true;
    if (line[first] == '#' || line.compare(first, 2, "//") == 0) {
        if (pre.header.empty()) pre.header = trim(std::string_view(line).substr(first + (line[first] == '#' ? 1 : 2)));
        return true;
    }
    return false;
}

// The row's material (iris, air, or a glass from index and Abbe number) into s; returns the column of the
// semi-aperture that follows it.
std::size_t read_lentil_material(const std::vector<std::string>& cols, std::string_view origin, int line_no, Surface& s) {
    const std::string& material = cols[2];
    std::string lower = material;
    for (auto& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    if (lower.starts_with("cx_"))
        fail(origin, line_no, fmt::format("material: '{}' is a cylindrical (anamorphic) surface, which lensfx does not support", material));
    if (lower == "iris") {
        s.is_stop = true;
        return 3;
    }
    if (lower == "air") return 3;
    if (cols.size() < 6) fail(origin, line_no, "expected index and Abbe number after the material");
    const double nd = number(cols[3], origin, line_no, "index");
    const double vd = number(cols[4], origin, line_no, "vno");
    if (nd < 1.0) fail(origin, line_no, fmt::format("index: {} is not a refractive index", nd));
    try {
        s.medium = vd == 0.0 ? constant_glass(nd) : glass_from_abbe(nd, vd, lower == "abbe" ? "" : material);
    } catch (const std::invalid_argument& e) {
        fail(origin, line_no, fmt::format("vno: {}", e.what()));
    }
    return 5;
}

// A `#!aspheric=k,A4,A6,A8,A10` tag on the row: conic and coefficients, scaled; it keeps a large radius
// that would otherwise read as a plane.
void read_aspheric_tag(const std::string& line, std::string_view origin, int line_no, double scale, double radius,
                       Surface& s) {
    const auto tag = line.find("#!aspheric=");
    if (tag == std::string::npos) return;
    const auto values = split(trim(std::string_view(line).substr(tag + 11)), ",");
    if (values.empty() || values.size() > 5) fail(origin, line_no, "#!aspheric: expected k,A4,A6,A8,A10");
    s.conic = number(values[0], origin, line_no, "#!aspheric k");
    for (std::size_t i = 1; i < values.size(); ++i) {
        // z(h) scales as h: a_2k h^2k -> a_2k s^(1-2k) (s h)^2k.
        const double a = number(values[i], origin, line_no, "#!aspheric");
        s.aspheric.push_back(a * std::pow(scale, 1.0 - 2.0 * static_cast<double>(i + 1)));
    }
    if (radius != 0.0 && s.radius_mm == 0.0) s.radius_mm = radius * scale;
}

// One table row as a surface; none where lentil ends the table (a zero radius, thickness or semi-aperture).
std::optional<Surface> parse_lentil_row(const std::string& line, std::string_view origin, int line_no, double scale) {
    const auto cols = split(line);
    if (cols.size() < 3) fail(origin, line_no, "expected radius thickness material ... semi-aperture");
    const double radius = number(cols[0], origin, line_no, "radius");
    if (radius == 0.0) return std::nullopt;

    Surface s;
    s.source_line = line_no;
    for (const auto& part : split(cols[1], "/")) s.thickness_mm.push_back(number(part, origin, line_no, "thickness") * scale);
    if (s.thickness_mm.empty() || s.thickness_mm[0] == 0.0) return std::nullopt;
    const std::size_t sa_column = read_lentil_material(cols, origin, line_no, s);
    if (cols.size() <= sa_column) fail(origin, line_no, "sa: missing (clear semi-aperture)");
    const double sa = number(cols[sa_column], origin, line_no, "sa");
    if (sa == 0.0) return std::nullopt;
    s.semi_diameter_mm = sa * scale;
    s.radius_mm = (s.is_stop || std::abs(radius) >= 1e4) ? 0.0 : radius * scale;
    read_aspheric_tag(line, origin, line_no, scale, radius, s);
    return s;
}

}  // namespace

Lens parse_lentil_fx(std::string_view text, std::string_view origin) {
    Lens lens;
    lens.name = stem_of(origin);
    LentilPreamble pre;
    int line_no = 0;
    for (const auto& line : lines_of(text)) {
        ++line_no;
        if (read_lentil_non_row(line, origin, line_no, pre, lens.stated_focal_mm)) continue;
        std::optional<Surface> surface = parse_lentil_row(line, origin, line_no, pre.scale);
        if (!surface) break;
        lens.surfaces.push_back(std::move(*surface));
    }
    for (auto& f : lens.stated_focal_mm) f *= pre.scale;
    lens.source = pre.header;
    lens.notes = fmt::format("imported from a lentil .fx file{}; media from nd/Vd (glass_from_abbe); "
                             "radii of 1e4 mm or more read as planes",
                             pre.scale != 1.0 ? fmt::format(", #!scale {} applied", pre.scale) : std::string());
    lens.sensor_as_written = false;
    coat_air_glass(lens);
    validate_lens(lens, origin);
    return lens;
}

Lens read_pbrt_dat(const std::filesystem::path& path) { return parse_pbrt_dat(read_text(path), path.string()); }
Lens read_lentil_fx(const std::filesystem::path& path) { return parse_lentil_fx(read_text(path), path.string()); }

}  // namespace lensfx::optics
