// Fuzz target: flare looks (TOML) through parse_flare_look, then the styles they give the ghosts of a
// small lens (a Cooke triplet's interface pairs), as the flare stage asks for them.
#include <vector>

#include <optics/flare_look.h>
#include <optics/lens_file.h>

#include "fuzz_input.h"

namespace {

// Every pair of 7 interfaces, as enumerate_ghosts() gives them for a triplet with its stop.
std::vector<lensfx::optics::Ghost> triplet_ghosts() {
    std::vector<lensfx::optics::Ghost> ghosts;
    for (int j = 1; j < 7; ++j)
        for (int i = 0; i < j; ++i) ghosts.push_back({j, i, {}, false});
    return ghosts;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const std::vector<lensfx::optics::Ghost> ghosts = triplet_ghosts();
    lensfx::optics::FlareLook look;
    try {
        look = lensfx::optics::parse_flare_look(lensfx::fuzz::as_text(data, size), "fuzz-look.toml");
    } catch (const lensfx::optics::LensFileError&) {
        return 0;
    }
    try {
        (void)lensfx::optics::ghost_styles(look, ghosts);
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
