// The project's lens file format (TOML, one inline table per surface row; docs/lens-format.md): parser,
// validation with file:line:field messages, writer, format detection and load_lens().
#include <optics/lens_file.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <cstdlib>
#include <set>
#include <sstream>

#include <fmt/core.h>
#include <toml++/toml.h>

#include <optics/coating.h>
#include <optics/importers.h>
#include <optics/presets.h>

#include "regular_file.h"
#include "toml_fields.h"

namespace lensfx::optics {

void require_regular_file(const std::filesystem::path& path) {
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (!ec && std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
        throw LensFileError(fmt::format("{}: not a regular file (a directory, device or named pipe)", path.string()));
}

std::string read_text(const std::filesystem::path& path) {
    require_regular_file(path);
    errno = 0;
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) {  // the system's reason where it gave one (a file of /proc opens but has no end to seek to)
        const int error = errno;
        throw LensFileError(fmt::format("{}: cannot open the lens file{}", path.string(), error != 0 ? std::string(": ") + std::strerror(error) : ""));
    }
    std::string text(static_cast<std::size_t>(in.tellg()), '\0');
    in.seekg(0);
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    if (!in) throw LensFileError(fmt::format("{}: cannot read the lens file", path.string()));
    return text;
}

namespace {

// The media a lens file may give, whatever its format: refractive index at 587.56 nm and Abbe number.
constexpr double kMaxIndex = 3.0;
constexpr double kMaxAbbe = 150.0;
constexpr const char* kCoatingNames = "\"none\", \"mgf2\", \"v-coat\", \"broadband-3\", \"broadband-4\"";

Coating mgf2() {
    Coating c;
    c.kind = Coating::Kind::QuarterWave;
    return c;
}

bool same_glass(const Glass& a, const Glass& b) {
    return a.formula == b.formula && a.coefficients == b.coefficients && a.nd == b.nd && a.vd == b.vd;
}

bool same_coating(const Coating& a, const Coating& b) {
    if (a.kind != b.kind) return false;
    if (a.kind == Coating::Kind::None) return true;
    if (a.layer_errors != b.layer_errors) return false;
    if (a.kind == Coating::Kind::QuarterWave)
        return a.design_wavelength_nm == b.design_wavelength_nm && a.layer_index == b.layer_index &&
               a.thickness_offset == b.thickness_offset;
    if (a.kind == Coating::Kind::Design) return a.design == b.design && a.design_wavelength_nm == b.design_wavelength_nm;
    if (a.layers.size() != b.layers.size()) return false;
    for (std::size_t i = 0; i < a.layers.size(); ++i)
        if (!same_glass(a.layers[i].material, b.layers[i].material) || a.layers[i].thickness_nm != b.layers[i].thickness_nm)
            return false;
    return true;
}

// A medium from glass / nd / vd / sellmeier / polynomial / label fields; nullopt when none is given.
std::optional<Glass> read_medium(Fields& f) {
    const auto name = f.opt_string("glass");
    const auto nd = f.opt_number("nd");
    const auto vd = f.opt_number("vd");
    const auto sellmeier = f.numbers("sellmeier", false);
    const auto polynomial = f.numbers("polynomial", false);
    const auto label = f.opt_string("label");
    const int kinds = (name ? 1 : 0) + ((nd || vd) ? 1 : 0) + (sellmeier.empty() ? 0 : 1) + (polynomial.empty() ? 0 : 1);
    if (kinds > 1) f.error(name ? "glass" : "nd", "give one of glass, nd/vd, sellmeier or polynomial");
    if (label && kinds == 0) f.error("label", "a label names a medium given by nd/vd, sellmeier or polynomial");
    if (name) {
        if (label) f.error("label", "a catalog glass is named by glass = \"...\" alone");
        if (*name == "air" || *name == "AIR") return Glass::air();
        auto g = catalog_glass(*name);
        if (!g) f.error("glass", fmt::format("unknown glass '{}' (not in the catalog; give nd and vd instead)", *name));
        g->name = *name;
        return g;
    }
    if (nd) {
        if (*nd < 1.0 || *nd > kMaxIndex) f.error("nd", fmt::format("{} is not a refractive index of glass (1 to {})", *nd, kMaxIndex));
        if (vd) {
            if (*vd <= 0.0 || *vd > kMaxAbbe) f.error("vd", fmt::format("Abbe number {} outside (0, {}]", *vd, kMaxAbbe));
            try {
                return glass_from_abbe(*nd, *vd, label.value_or(""));
            } catch (const std::invalid_argument& e) {
                f.error("vd", e.what());
            }
        }
        Glass g;
        g.name = label.value_or(fmt::format("n={}", *nd));
        g.nd = *nd;
        return g;
    }
    if (vd) f.error("vd", "an Abbe number needs nd");
    auto coefficients_glass = [&](Glass::Formula formula, std::vector<double> c, std::string_view key) {
        if (formula == Glass::Formula::Sellmeier && c.size() < 2)
            f.error(key, "expected [A,] B1, C1, B2, C2, ... (C in um^2)");
        if (formula == Glass::Formula::Polynomial && c.size() % 2 != 1)
            f.error(key, "expected c0, then pairs of coefficient and exponent");
        Glass g;
        g.name = label.value_or(std::string(key));
        g.formula = formula;
        g.coefficients = std::move(c);
        g.nd = g.index(587.56);
        if (!std::isfinite(g.nd) || g.nd < 1.0) f.error(key, fmt::format("gives n = {} at 587.56 nm", g.nd));
        return g;
    };
    if (!sellmeier.empty()) return coefficients_glass(Glass::Formula::Sellmeier, sellmeier, "sellmeier");
    if (!polynomial.empty()) return coefficients_glass(Glass::Formula::Polynomial, polynomial, "polynomial");
    return std::nullopt;
}

Coating read_coating(const toml::node& n, std::string_view origin, const std::string& context) {
    if (const auto* s = n.as_string()) {
        const std::string v = s->get();
        if (v == "none") return {};
        if (v == "mgf2") return mgf2();
        if (const auto design = parse_design(v)) {
            Coating c;
            c.kind = Coating::Kind::Design;
            c.design = *design;
            return c;
        }
        fail(origin, line_of(n), fmt::format("{}coating: '{}' is not {} or a table", context, v, kCoatingNames));
    }
    const auto* t = n.as_table();
    if (!t) fail(origin, line_of(n), fmt::format("{}coating: expected {} or a table", context, kCoatingNames));
    Fields f(*t, origin, context + "coating.");
    Coating c;
    if (const auto name = f.opt_string("design")) {
        const auto design = parse_design(*name);
        if (!design) f.error("design", fmt::format("'{}' is not \"v-coat\", \"broadband-3\" or \"broadband-4\"", *name));
        c.kind = Coating::Kind::Design;
        c.design = *design;
        if (auto v = f.opt_number("wavelength")) c.design_wavelength_nm = *v;
        if (c.design_wavelength_nm < 200.0 || c.design_wavelength_nm > 2000.0) f.error("wavelength", "outside 200-2000 nm");
    } else if (const toml::node* layers = f.get("layers")) {
        const auto* a = layers->as_array();
        if (!a || a->empty()) f.error("layers", "expected an array of { nd = ..., nm = ... } tables");
        c.kind = Coating::Kind::Stack;
        int k = 0;
        for (const auto& e : *a) {
            ++k;
            const auto* lt = e.as_table();
            if (!lt) f.error("layers", "expected inline tables");
            Fields lf(*lt, origin, fmt::format("{}coating.layers[{}].", context, k));
            auto m = read_medium(lf);
            if (!m) lf.error("nd", "missing (the layer's medium)");
            const double nm = lf.required_number("nm", "physical thickness in nm");
            if (nm <= 0.0) lf.error("nm", "must be positive");
            lf.reject_unknown();
            c.layers.push_back({*m, nm});
        }
    } else {
        c.kind = Coating::Kind::QuarterWave;
        if (auto v = f.opt_number("index")) c.layer_index = *v;
        if (auto v = f.opt_number("wavelength")) c.design_wavelength_nm = *v;
        if (auto v = f.opt_number("offset")) c.thickness_offset = *v;
        if (c.layer_index < 1.0) f.error("index", "must be at least 1");
        if (c.design_wavelength_nm < 200.0 || c.design_wavelength_nm > 2000.0) f.error("wavelength", "outside 200-2000 nm");
    }
    f.reject_unknown();
    return c;
}

bool air_glass(const Glass& before, const Glass& after) { return before.is_air() != after.is_air(); }

// Writes a number so that it reads back to the same double; planes (0) are written as inf for radii.
std::string num(double v) {
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    return fmt::format("{}", v);
}

std::string toml_string(std::string_view s) {
    std::ostringstream os;
    os << toml::value<std::string>(std::string(s));
    return os.str();
}

std::string numbers(const std::vector<double>& v) {
    std::string out = "[";
    for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + num(v[i]);
    return out + "]";
}

std::string medium_fields(const Glass& g) {
    if (g.is_air()) return {};
    switch (g.formula) {
        case Glass::Formula::Abbe:
            return fmt::format("nd = {}, vd = {}{}", num(g.nd), num(g.vd), g.name.empty() ? "" : ", label = " + toml_string(g.name));
        case Glass::Formula::Constant:
            if (g.name == fmt::format("n={}", g.nd)) return fmt::format("nd = {}", num(g.nd));
            return fmt::format("nd = {}, label = {}", num(g.nd), toml_string(g.name));
        case Glass::Formula::Sellmeier:
        case Glass::Formula::Polynomial: {
            if (auto c = catalog_glass(g.name); c && same_glass(*c, g)) return "glass = " + toml_string(g.name);
            const char* key = g.formula == Glass::Formula::Sellmeier ? "sellmeier" : "polynomial";
            return fmt::format("{} = {}, label = {}", key, numbers(g.coefficients), toml_string(g.name));
        }
    }
    return {};
}

std::string coating_value(const Coating& c) {
    switch (c.kind) {
        case Coating::Kind::None: return "\"none\"";
        case Coating::Kind::QuarterWave:
            if (same_coating(c, mgf2())) return "\"mgf2\"";
            return fmt::format("{{ index = {}, wavelength = {}, offset = {} }}", num(c.layer_index),
                               num(c.design_wavelength_nm), num(c.thickness_offset));
        case Coating::Kind::Design:
            if (c.design_wavelength_nm == 550.0) return fmt::format("\"{}\"", design_name(c.design));
            return fmt::format("{{ design = \"{}\", wavelength = {} }}", design_name(c.design), num(c.design_wavelength_nm));
        case Coating::Kind::Stack: {
            std::string out = "{ layers = [";
            for (std::size_t i = 0; i < c.layers.size(); ++i)
                out += fmt::format("{}{{ {}, nm = {} }}", i ? ", " : " ", medium_fields(c.layers[i].material),
                                   num(c.layers[i].thickness_nm));
            return out + " ] }";
        }
    }
    return "\"none\"";
}

}  // namespace

// Thicknesses and clear semi-diameters beyond this (mm) are no lens's: 10 m. A thickness of 1e300 once made a lens
// of focal length 0 and a 180-degree field that drew no flare and said nothing.
constexpr double kMaxLengthMm = 1e4;

void validate_lens(const Lens& lens, std::string_view origin) {
    const auto at = [&](std::size_t i, std::string_view field, const std::string& msg) {
        fail(origin, lens.surfaces[i].source_line, fmt::format("surface {}: {}: {}", i + 1, field, msg));
    };
    if (lens.surfaces.empty()) fail(origin, 0, "surfaces: no surfaces");
    int stops = 0;
    for (const auto& s : lens.surfaces) stops += s.is_stop ? 1 : 0;
    if (stops == 0) fail(origin, 0, "surfaces: no aperture stop (mark one row with stop = true)");
    if (stops > 1) {
        for (std::size_t i = lens.surfaces.size(); i-- > 0;)
            if (lens.surfaces[i].is_stop) at(i, "stop", "a second aperture stop (a lens has exactly one)");
    }
    // The first row with several zoom columns sets their number; a row that differs is the one at fault.
    int zooms = 1;
    for (const auto& s : lens.surfaces)
        if (s.thickness_mm.size() > 1) {
            zooms = static_cast<int>(s.thickness_mm.size());
            break;
        }
    Glass before = Glass::air();
    for (std::size_t i = 0; i < lens.surfaces.size(); ++i) {
        const auto& s = lens.surfaces[i];
        if (!std::isfinite(s.radius_mm)) at(i, "r", "not a finite number (write 0 or inf for a plane)");
        if (s.thickness_mm.empty()) at(i, "t", "missing (axial distance to the next surface)");
        if (s.thickness_mm.size() != 1 && static_cast<int>(s.thickness_mm.size()) != zooms)
            at(i, "t", fmt::format("{} zoom columns where the rows before have {}", s.thickness_mm.size(), zooms));
        const Glass& after = s.is_stop ? before : s.medium;
        const bool next_to_stop = s.is_stop || (i + 1 < lens.surfaces.size() && lens.surfaces[i + 1].is_stop);
        for (double t : s.thickness_mm) {
            if (!std::isfinite(t)) at(i, "t", "not a finite number");
            if (std::abs(t) > kMaxLengthMm) at(i, "t", fmt::format("{} mm is beyond any lens (at most {} mm)", t, kMaxLengthMm));
            if (t < 0.0 && (!after.is_air() || !next_to_stop || i + 1 == lens.surfaces.size()))
                at(i, "t", fmt::format("negative thickness {} (allowed only for an air gap next to the stop)", t));
        }
        if (!std::isfinite(s.semi_diameter_mm) || s.semi_diameter_mm <= 0.0)
            at(i, "sd", fmt::format("clear semi-diameter {} must be positive", s.semi_diameter_mm));
        if (s.semi_diameter_mm > kMaxLengthMm) at(i, "sd", fmt::format("{} mm is beyond any lens (at most {} mm)", s.semi_diameter_mm, kMaxLengthMm));
        if (s.radius_mm != 0.0 && s.semi_diameter_mm > std::abs(s.radius_mm) && s.aspheric.empty() && s.conic == 0.0)
            at(i, "sd", fmt::format("semi-diameter {} exceeds |r| = {}", s.semi_diameter_mm, std::abs(s.radius_mm)));
        if (!std::isfinite(s.conic)) at(i, "k", "not a finite number");
        for (double a : s.aspheric)
            if (!std::isfinite(a)) at(i, "asph", "not a finite number");
        // The same bounds as the TOML reader's, so that every importer's lens writes a file that reads back.
        if (!std::isfinite(after.nd) || after.nd < 1.0 || after.nd > kMaxIndex)
            at(i, "nd", fmt::format("refractive index {} is not valid (1 to {})", after.nd, kMaxIndex));
        if (after.formula == Glass::Formula::Abbe && !(after.vd > 0.0 && after.vd <= kMaxAbbe))
            at(i, "vd", fmt::format("Abbe number {} outside (0, {}]", after.vd, kMaxAbbe));
        before = after;
    }
    if (!before.is_air()) at(lens.surfaces.size() - 1, "glass", "the last surface must leave the light in air");
    if (!lens.zoom_focal_labels.empty() && static_cast<int>(lens.zoom_focal_labels.size()) != zooms)
        fail(origin, 0, fmt::format("zoom_labels: {} labels for {} zoom columns", lens.zoom_focal_labels.size(), zooms));
    if (lens.stated_focal_mm.size() > 1 && static_cast<int>(lens.stated_focal_mm.size()) != zooms)
        fail(origin, 0, fmt::format("focal_length: {} values for {} zoom columns", lens.stated_focal_mm.size(), zooms));
}

Lens parse_lens_toml(std::string_view text, std::string_view origin) {
    const toml::table doc = parse_toml(text, origin);
    Fields top(doc, origin, "");
    Lens lens;
    const auto name = top.opt_string("name");
    if (!name || name->empty()) fail(origin, 1, "name: missing (the lens's name)");
    lens.name = *name;
    lens.source = top.opt_string("source").value_or("");
    lens.notes = top.opt_string("notes").value_or("");
    lens.stated_focal_mm = top.numbers("focal_length", true);
    lens.stated_f_number = top.opt_number("f_number").value_or(0.0);
    if (top.get("f_number") && !(lens.stated_f_number > 0.0 && std::isfinite(lens.stated_f_number)))
        top.error("f_number", fmt::format("{} must be positive (the lens's widest aperture)", lens.stated_f_number));
    lens.zoom_focal_labels = top.numbers("zoom_labels", false);
    if (auto focus = top.opt_string("focus")) {
        if (*focus == "as-written") lens.sensor_as_written = true;
        else if (*focus != "infinity") top.error("focus", fmt::format("'{}' is not \"infinity\" or \"as-written\"", *focus));
    }
    std::optional<Coating> default_coating = mgf2();
    if (const toml::node* c = top.get("coating")) default_coating = read_coating(*c, origin, "");
    if (const toml::node* a = top.get("aperture")) {
        const auto* t = a->as_table();
        if (!t) top.error("aperture", "expected a table { blades = ..., rotation = ..., curvature = ... }");
        Fields f(*t, origin, "aperture.");
        if (auto b = f.opt_number("blades")) {
            if (*b < 0 || *b != std::floor(*b) || *b == 1 || *b == 2 || *b > 64) f.error("blades", "0 (round) or 3 to 64");
            lens.aperture.blades = static_cast<int>(*b);
        }
        lens.aperture.rotation_deg = f.opt_number("rotation").value_or(0.0);
        lens.aperture.blade_curvature = f.opt_number("curvature").value_or(0.0);
        if (lens.aperture.blade_curvature < 0.0 || lens.aperture.blade_curvature > 1.0) f.error("curvature", "outside [0, 1]");
        f.reject_unknown();
    }
    const toml::node* rows = top.get("surfaces");
    if (!rows) fail(origin, 0, "surfaces: missing (an array of { r = ..., t = ..., sd = ... } rows)");
    const auto* arr = rows->as_array();
    if (!arr || arr->empty()) top.error("surfaces", "expected a non-empty array of inline tables");
    top.reject_unknown();

    std::vector<std::optional<Coating>> coatings;
    int index = 0;
    for (const auto& row : *arr) {
        ++index;
        const auto* t = row.as_table();
        if (!t) fail(origin, line_of(row), fmt::format("surface {}: expected an inline table {{ r = ..., t = ..., sd = ... }}", index));
        Fields f(*t, origin, fmt::format("surface {}: ", index));
        Surface s;
        s.source_line = f.line();
        s.is_stop = f.opt_bool("stop").value_or(false);
        if (auto r = f.opt_number("r")) {
            if (s.is_stop && *r != 0.0 && !std::isinf(*r)) f.error("r", "the stop is a plane (leave r out)");
            s.radius_mm = std::isinf(*r) ? 0.0 : *r;
        } else if (!s.is_stop) {
            fail(origin, f.line(), fmt::format("surface {}: r: missing (radius; 0 or inf for a plane)", index));
        }
        s.thickness_mm = f.numbers("t", true);
        if (s.thickness_mm.empty()) fail(origin, f.line(), fmt::format("surface {}: t: missing (axial distance to the next surface)", index));
        const auto sd = f.opt_number("sd");
        if (!sd) fail(origin, f.line(), fmt::format("surface {}: sd: missing (clear semi-diameter in mm)", index));
        s.semi_diameter_mm = *sd;
        auto medium = read_medium(f);
        if (s.is_stop && medium) f.error("glass", "the stop has no medium of its own (the medium continues)");
        s.medium = medium.value_or(Glass::air());
        s.conic = f.opt_number("k").value_or(0.0);
        s.aspheric = f.numbers("asph", false);
        if (s.aspheric.size() > 4) f.error("asph", "at most a4, a6, a8, a10");
        if (const toml::node* c = f.get("coating")) coatings.push_back(read_coating(*c, origin, f.context()));
        else coatings.push_back(std::nullopt);
        f.reject_unknown();
        lens.surfaces.push_back(std::move(s));
    }
    Glass before = Glass::air();
    for (std::size_t i = 0; i < lens.surfaces.size(); ++i) {
        auto& s = lens.surfaces[i];
        const Glass& after = s.is_stop ? before : s.medium;
        if (coatings[i]) s.coating = *coatings[i];
        else if (!s.is_stop && air_glass(before, after) && default_coating) s.coating = *default_coating;
        before = after;
    }
    validate_lens(lens, origin);
    return lens;
}

Lens read_lens_toml(const std::filesystem::path& path) { return parse_lens_toml(read_text(path), path.string()); }

std::string write_lens_toml(const Lens& lens) {
    std::string out = "# lensfx lens file (docs/lens-format.md). Lengths in mm; surfaces from the object side;\n"
                      "# r > 0: centre of curvature towards the sensor; t: axial distance to the next surface.\n";
    out += "name = " + toml_string(lens.name) + "\n";
    if (!lens.source.empty()) out += "source = " + toml_string(lens.source) + "\n";
    if (!lens.notes.empty()) out += "notes = " + toml_string(lens.notes) + "\n";
    if (lens.stated_focal_mm.size() == 1) out += "focal_length = " + num(lens.stated_focal_mm[0]) + "\n";
    if (lens.stated_focal_mm.size() > 1) out += "focal_length = " + numbers(lens.stated_focal_mm) + "\n";
    if (lens.stated_f_number > 0.0) out += "f_number = " + num(lens.stated_f_number) + "\n";
    if (!lens.zoom_focal_labels.empty()) out += "zoom_labels = " + numbers(lens.zoom_focal_labels) + "\n";
    if (lens.sensor_as_written) out += "focus = \"as-written\"\n";
    out += fmt::format("aperture = {{ blades = {}, rotation = {}, curvature = {} }}\n", lens.aperture.blades,
                       num(lens.aperture.rotation_deg), num(lens.aperture.blade_curvature));

    // The default coating rule (the given coating on air-glass interfaces, none elsewhere), if it fits.
    const auto fits = [&](const Coating& d) {
        Glass before = Glass::air();
        for (const auto& s : lens.surfaces) {
            const Glass& after = s.is_stop ? before : s.medium;
            const Coating expected = (!s.is_stop && air_glass(before, after)) ? d : Coating{};
            if (!same_coating(expected, s.coating)) return false;
            before = after;
        }
        return true;
    };
    // The candidate: the first air-glass interface's coating.
    Coating first_air_glass;
    {
        Glass before = Glass::air();
        for (const auto& s : lens.surfaces) {
            const Glass& after = s.is_stop ? before : s.medium;
            if (!s.is_stop && air_glass(before, after)) {
                first_air_glass = s.coating;
                break;
            }
            before = after;
        }
    }
    const bool rule_mgf2 = fits(mgf2()), rule_none = !rule_mgf2 && fits(Coating{});
    const bool rule_other = !rule_mgf2 && !rule_none && fits(first_air_glass);
    if (rule_none) out += "coating = \"none\"\n";
    else if (rule_mgf2) out += "coating = \"mgf2\"  # single MgF2 quarter wave at 550 nm on air-glass interfaces\n";
    else if (rule_other) out += "coating = " + coating_value(first_air_glass) + "\n";
    else out += "coating = \"none\"  # per surface below\n";

    std::vector<std::vector<std::string>> cells;
    for (const auto& s : lens.surfaces) {
        std::vector<std::string> c;
        c.push_back(s.is_stop ? "stop = true," : fmt::format("r = {},", s.radius_mm == 0.0 ? "inf" : num(s.radius_mm)));
        c.push_back(fmt::format("t = {},", s.thickness_mm.size() == 1 ? num(s.thickness_mm[0]) : numbers(s.thickness_mm)));
        c.push_back(fmt::format("sd = {},", num(s.semi_diameter_mm)));
        const std::string m = s.is_stop ? "" : medium_fields(s.medium);
        c.push_back(m.empty() ? "" : m + ",");
        std::string extra;
        if (s.conic != 0.0) extra += fmt::format("k = {}, ", num(s.conic));
        if (!s.aspheric.empty()) extra += fmt::format("asph = {}, ", numbers(s.aspheric));
        if (!rule_mgf2 && !rule_none && !rule_other) extra += fmt::format("coating = {}, ", coating_value(s.coating));
        c.push_back(extra);
        cells.push_back(std::move(c));
    }
    std::vector<std::size_t> width(5, 0);
    for (const auto& c : cells)
        for (std::size_t k = 0; k < c.size(); ++k) width[k] = std::max(width[k], c[k].size());
    out += "surfaces = [\n";
    for (const auto& c : cells) {
        std::string row = "  { ";
        for (std::size_t k = 0; k < c.size(); ++k) row += fmt::format("{:<{}} ", c[k], width[k]);
        while (!row.empty() && (row.back() == ' ' || row.back() == ',')) row.pop_back();
        out += row + " },\n";
    }
    out += "]\n";
    return out;
}

void write_lens_file(const Lens& lens, const std::filesystem::path& path) {
    std::ofstream out(path, std::ios::binary);
    if (!out) throw LensFileError(fmt::format("{}: cannot write the lens file", path.string()));
    out << write_lens_toml(lens);
    if (!out) throw LensFileError(fmt::format("{}: write failed", path.string()));
}

LensFormat detect_lens_format(const std::filesystem::path& path, std::string_view text) {
    const std::string ext = path.extension().string();
    if (ext == ".toml" || ext == ".lens") return LensFormat::Toml;
    if (ext == ".dat") return LensFormat::PbrtDat;
    if (ext == ".fx") return LensFormat::LentilFx;
    if (text.find("surfaces") != std::string_view::npos && text.find('=') != std::string_view::npos) return LensFormat::Toml;
    // pbrt rows hold exactly four numbers; lentil rows hold a material word.
    std::size_t pos = 0;
    while (pos < text.size()) {
        const std::size_t eol = std::min(text.find('\n', pos), text.size());
        const std::string_view line = text.substr(pos, eol - pos);
        pos = eol + 1;
        const auto first = line.find_first_not_of(" \t\r");
        if (first == std::string_view::npos || line[first] == '#' || line.substr(first).starts_with("//")) continue;
        int words = 0, numeric = 0;
        for (std::size_t i = first; i < line.size();) {
            const std::size_t j = std::min(line.find_first_of(" \t\r", i), line.size());
            const std::string w(line.substr(i, j - i));
            char* end = nullptr;
            std::strtod(w.c_str(), &end);
            ++words;
            if (end && *end == '\0') ++numeric;
            i = line.find_first_not_of(" \t\r", j);
            if (i == std::string_view::npos) break;
        }
        return (words == 4 && numeric == 4) ? LensFormat::PbrtDat : LensFormat::LentilFx;
    }
    return LensFormat::Toml;
}

Lens load_lens(std::string_view name_or_path) {
    const std::filesystem::path path{std::string(name_or_path)};
    std::error_code ec;
    if (std::filesystem::is_regular_file(path, ec)) {
        const std::string text = read_text(path);
        switch (detect_lens_format(path, text)) {
            case LensFormat::PbrtDat: return parse_pbrt_dat(text, path.string());
            case LensFormat::LentilFx: return parse_lentil_fx(text, path.string());
            case LensFormat::Toml: return parse_lens_toml(text, path.string());
        }
    }
    if (preset_text(name_or_path)) return load_preset(name_or_path);
    if (std::filesystem::exists(path, ec))  // a device, folder or pipe: never read (/dev/zero would not end)
        throw LensFileError(fmt::format("{}: not a regular file (a lens is a file or a preset name)", name_or_path));
    std::string names;
    for (const auto& n : preset_names()) names += (names.empty() ? "" : ", ") + n;
    throw LensFileError(fmt::format("{}: no such lens file or preset (presets: {})", name_or_path, names));
}

}  // namespace lensfx::optics
