// Fuzz target: the lens parser parse_pbrt_dat on arbitrary text, then what consumers do with the lens.
#include <optics/importers.h>
#include <optics/lens_file.h>

#include "lens_checks.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return lensfx::fuzz::fuzz_lens_parser(data, size, lensfx::optics::parse_pbrt_dat, "fuzz.dat");
}
