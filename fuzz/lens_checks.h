// What the lens fuzz targets do with a lens that parsed: what `lensfx lens info` and the renderers do
// first (realise it at both zoom ends, paraxial data, ghost count), and the round trip through the
// project's own format, which must read back whatever the parsers accepted. fuzz_lens_parser is the whole of
// each lens target.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string_view>

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

// A lens target: parse(text, origin) on the fuzzer's bytes; a LensFileError is the parser's refusal, a lens
// that parsed goes through use_lens.
template <typename Parse>
int fuzz_lens_parser(const std::uint8_t* data, std::size_t size, Parse parse, const char* origin) {
    optics::Lens lens;
    try {
        lens = parse(std::string_view(reinterpret_cast<const char*>(data), size), origin);
    } catch (const optics::LensFileError&) {
        return 0;
    }
    use_lens(lens);
    return 0;
}

}  // namespace lensfx::fuzz
