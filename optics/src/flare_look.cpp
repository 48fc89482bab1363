#include <optics/flare_look.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include <optics/random.h>

#include "regular_file.h"
#include "toml_fields.h"

namespace lensfx::optics {

namespace {

// Bounds of a look's numbers: far beyond any artistic use, far inside float range once multiplied.
constexpr double kMaxLookGain = 1e6;
constexpr double kMaxLookOffsetMm = 1e3;

}  // namespace

FlareLook parse_flare_look(std::string_view text, std::string_view origin) {
    const toml::table doc = parse_toml(text, origin);
    Fields top(doc, origin, "");
    FlareLook look;
    if (const toml::node* sym = top.get("symmetry")) {
        if (!sym->is_table()) top.error("symmetry", "expected a table");
        Fields f(*sym->as_table(), origin, "symmetry.");
        look.symmetry_jitter_mm = f.opt_number("jitter_mm").value_or(0.0);
        if (!(look.symmetry_jitter_mm >= 0.0 && look.symmetry_jitter_mm <= kMaxLookOffsetMm))
            f.error("jitter_mm", fmt::format("expected a number in [0, {:g}]", kMaxLookOffsetMm));
        if (const auto seed = f.opt_number("seed")) {
            if (!(*seed >= 0.0 && *seed < 1.8e19) || *seed != std::floor(*seed)) f.error("seed", "expected a whole number >= 0");
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
            if (surfaces.size() != 2 || surfaces[0] < 1 || surfaces[1] < 1 || surfaces[0] > 10000 || surfaces[1] > 10000 || surfaces[0] == surfaces[1] ||
                surfaces[0] != std::floor(surfaces[0]) || surfaces[1] != std::floor(surfaces[1]))
                f.error("surfaces", "expected two different surface numbers (1-based, as in --ghost)");
            style.first = static_cast<int>(surfaces[0]) - 1;
            style.second = static_cast<int>(surfaces[1]) - 1;
            const double gain = f.opt_number("gain").value_or(1.0);
            if (!(gain >= 0.0 && gain <= kMaxLookGain)) f.error("gain", fmt::format("expected a number in [0, {:g}]", kMaxLookGain));
            std::array<double, 3> colour{1.0, 1.0, 1.0};
            if (const std::vector<double> c = f.numbers("colour", false); !c.empty()) {
                const bool in_range = std::all_of(c.begin(), c.end(), [](double v) { return v >= 0.0 && v <= kMaxLookGain; });
                if (c.size() != 3 || !in_range)
                    f.error("colour", fmt::format("expected three numbers in [0, {:g}] (R, G, B)", kMaxLookGain));
                colour = {c[0], c[1], c[2]};
            }
            for (std::size_t k = 0; k < 3; ++k) style.gain[k] = std::min(gain * colour[k], kMaxLookGain);
            if (const std::vector<double> o = f.numbers("offset_mm", false); !o.empty()) {
                const bool in_range = std::all_of(o.begin(), o.end(), [](double v) { return std::abs(v) <= kMaxLookOffsetMm; });
                if (o.size() != 2 || !in_range) f.error("offset_mm", fmt::format("expected two numbers (right, up) within +-{:g}", kMaxLookOffsetMm));
                style.offset_mm = {o[0], o[1]};
            }
            // A second entry for the same ghost would multiply the first's gains unseen.
            for (std::size_t k = 0; k < look.ghosts.size(); ++k) {
                const GhostStyle& other = look.ghosts[k];
                if (std::minmax(other.first, other.second) == std::minmax(style.first, style.second))
                    f.error("surfaces", fmt::format("ghost {},{} is already styled by ghost {}", style.first + 1, style.second + 1, k + 1));
            }
            f.reject_unknown();
            look.ghosts.push_back(style);
        }
    }
    top.reject_unknown();
    return look;
}

FlareLook read_flare_look(const std::string& path) {
    require_regular_file(path);
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
