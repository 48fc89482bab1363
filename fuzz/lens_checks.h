// What the lens fuzz targets do with a lens that parsed: what `lensfx lens info` and the renderers do
// first (realise it at both zoom ends, paraxial data, ghost count), and the round trip through the
// project's own format, which must read back whatever the parsers accepted.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>

#include <optics/ghosts.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/system.h>

namespace lensfx::fuzz {

inline void use_lens(const optics::Lens& lens) {
    for (const double zoom : {0.0, 1.0}) {
        try {
            const optics::System sys = optics::realize(lens, zoom);
            const optics::Paraxial p = optics::paraxial(sys);
            (void)optics::field_of_view(p, 36.0, 24.0);
            (void)optics::ghost_count(sys);
        } catch (const std::invalid_argument&) {
        } catch (const std::runtime_error&) {
        }
    }
    const std::string text = optics::write_lens_toml(lens);
    try {
        (void)optics::parse_lens_toml(text, "round-trip.toml");
    } catch (const std::exception& e) {
        std::fprintf(stderr, "a parsed lens does not read back from its own TOML: %s\n%s\n", e.what(), text.c_str());
        std::abort();
    }
}

}  // namespace lensfx::fuzz
