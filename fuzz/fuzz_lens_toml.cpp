// Fuzz target: the lens parser parse_lens_toml on arbitrary text, then what consumers do with the lens.
#include <optics/importers.h>
#include <optics/lens_file.h>

#include "fuzz_input.h"
#include "lens_checks.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    lensfx::optics::Lens lens;
    try {
        lens = lensfx::optics::parse_lens_toml(lensfx::fuzz::as_text(data, size), "fuzz.toml");
    } catch (const lensfx::optics::LensFileError&) {
        return 0;
    }
    lensfx::fuzz::use_lens(lens);
    return 0;
}
