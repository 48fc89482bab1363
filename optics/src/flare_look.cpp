#include <optics/flare_look.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include <optics/random.h>

#include "toml_fields.h"

namespace lensfx::optics {

FlareLook parse_flare_look(std::string_view text, std::string_view origin) {
    const toml::table doc = parse_toml(text, origin);
    Fields top(doc, origin, "");
    FlareLook look;
    if (const toml::node* sym = top.get("symmetry")) {
        if (!sym->is_table()) top.error("symmetry", "expected a table");
        Fields f(*sym->as_table(), origin, "symmetry.");
        look.symmetry_jitter_mm = f.opt_number("jitter_mm").value_or(0.0);
        if (look.symmetry_jitter_mm < 0.0) f.error("jitter_mm", "must not be negative");
        if (const auto seed = f.opt_number("seed")) {
            if (*seed < 0.0 || *seed != std::floor(*seed)) f.error("seed", "expected a whole number >= 0");
            look.seed = static_cast<std::uint64_t>(*seed);
        }
        f.reject_unknown();
    }
    if (const toml::node* ghosts = top.get("ghost")) {
        const toml::array* rows = ghosts->as_array();
        if (!rows) top.error("ghost", "expected [[ghost]] tables");
        for (std::size_t i = 0; i < rows->size(); ++i) {
            const toml::node& row = *rows->get(i);
            if (!row.is_table()) fail(origin, line_of(row), fmt::format("ghost {}: expected a table", i + 1));
            Fields f(*row.as_table(), origin, fmt::format("ghost {}: ", i + 1));
            GhostStyle style;
            const std::vector<double> surfaces = f.numbers("surfaces", false);
            if (surfaces.size() != 2 || surfaces[0] < 1 || surfaces[1] < 1 || surfaces[0] == surfaces[1] ||
                surfaces[0] != std::floor(surfaces[0]) || surfaces[1] != std::floor(surfaces[1]))
                f.error("surfaces", "expected two different surface numbers (1-based, as in --ghost)");
            style.first = static_cast<int>(surfaces[0]) - 1;
            style.second = static_cast<int>(surfaces[1]) - 1;
            const double gain = f.opt_number("gain").value_or(1.0);
            if (gain < 0.0) f.error("gain", "must not be negative");
            std::array<double, 3> colour{1.0, 1.0, 1.0};
            if (const std::vector<double> c = f.numbers("colour", false); !c.empty()) {
                if (c.size() != 3 || *std::min_element(c.begin(), c.end()) < 0.0)
                    f.error("colour", "expected three non-negative numbers (R, G, B)");
                colour = {c[0], c[1], c[2]};
            }
            for (std::size_t k = 0; k < 3; ++k) style.gain[k] = gain * colour[k];
            if (const std::vector<double> o = f.numbers("offset_mm", false); !o.empty()) {
                if (o.size() != 2) f.error("offset_mm", "expected two numbers (right, up)");
                style.offset_mm = {o[0], o[1]};
            }
            f.reject_unknown();
            look.ghosts.push_back(style);
        }
    }
    top.reject_unknown();
    return look;
}

FlareLook read_flare_look(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw LensFileError(fmt::format("{}: cannot read the flare look", path));
    std::stringstream text;
    text << in.rdbuf();
    return parse_flare_look(text.str(), path);
}

std::vector<GhostStyle> ghost_styles(const FlareLook& look, const std::vector<Ghost>& ghosts) {
    std::vector<GhostStyle> out;
    for (const Ghost& g : ghosts) {
        GhostStyle style{g.first, g.second, {1.0, 1.0, 1.0}, {}};
        bool changed = false;
        if (look.symmetry_jitter_mm > 0.0) {
            // Box-Muller on a generator seeded by the look's seed and this ghost alone.
            Random rng(look.seed * 0x100000001b3ULL ^ (static_cast<std::uint64_t>(g.first) << 32 | static_cast<std::uint64_t>(g.second)));
            const double r = look.symmetry_jitter_mm / std::sqrt(2.0) * std::sqrt(-2.0 * std::log(1.0 - rng.uniform()));
            const double a = 2.0 * std::numbers::pi * rng.uniform();
            style.offset_mm = {r * std::cos(a), r * std::sin(a)};
            changed = true;
        }
        for (const GhostStyle& s : look.ghosts) {
            if (std::max(s.first, s.second) != g.first || std::min(s.first, s.second) != g.second) continue;
            for (std::size_t k = 0; k < 3; ++k) style.gain[k] *= s.gain[k];
            style.offset_mm[0] += s.offset_mm[0];
            style.offset_mm[1] += s.offset_mm[1];
            changed = true;
        }
        if (changed) out.push_back(style);
    }
    for (const GhostStyle& s : look.ghosts) {
        const bool found = std::any_of(ghosts.begin(), ghosts.end(), [&](const Ghost& g) {
            return std::max(s.first, s.second) == g.first && std::min(s.first, s.second) == g.second;
        });
        if (!found)
            throw std::invalid_argument(fmt::format(
                "flare look: surfaces {},{} make no ghost of this lens (the stop and index-matched surfaces do not reflect)",
                s.first + 1, s.second + 1));
    }
    return out;
}

}  // namespace lensfx::optics
