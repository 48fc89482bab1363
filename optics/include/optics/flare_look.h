// An artistic flare look (flare paper section 5), in a TOML file people write: per-ghost colour, gain
// and offset for artistic presets, and imperfect symmetry (every ghost off centre by a seeded amount, as
// from slightly decentred elements). Format: docs/lens-format.md, "Flare looks".
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <optics/ghosts.h>

namespace lensfx::optics {

// A change to one ghost's look on top of its physics.
struct GhostStyle {
    int first = 0;   // the ghost's two reflecting interfaces (Ghost::first, Ghost::second; either order)
    int second = 0;
    std::array<double, 3> gain{1.0, 1.0, 1.0};  // per channel (colour x gain)
    std::array<double, 2> offset_mm{};          // shift on the sensor: right, up in the upright photograph
};

struct FlareLook {
    std::vector<GhostStyle> ghosts;  // explicit styles, interfaces 0-based
    double symmetry_jitter_mm = 0.0; // RMS offset drawn for every ghost
    std::uint64_t seed = 1;
};

// Throws LensFileError (optics/lens_file.h) naming the file, line and field.
FlareLook parse_flare_look(std::string_view text, std::string_view origin);
FlareLook read_flare_look(const std::string& path);

// One style per ghost the look changes: the seeded jitter (the same ghost gets the same offset whatever
// else is rendered) plus the explicit styles. Throws std::invalid_argument when an explicit style names
// interfaces that make no ghost of `ghosts`.
std::vector<GhostStyle> ghost_styles(const FlareLook& look, const std::vector<Ghost>& ghosts);

}  // namespace lensfx::optics
