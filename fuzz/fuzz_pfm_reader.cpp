// Fuzz target: a PFM stream (one image or many concatenated, as on stdin) through read_pfm, each image
// written back with write_pfm and read again, which must give the same pixels.
#include <filter/stream.h>

#include "fuzz_input.h"
#include "stream_round_trip.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using lensfx::filter::Frame;
    const bool top_first = size % 2 == 0;
    return lensfx::fuzz::read_write_read(
        data, size, [&](std::FILE* out, const Frame& frame) { lensfx::filter::write_pfm(out, frame, top_first); },
        [&](std::FILE* in) { return lensfx::filter::read_pfm(in, top_first LENSFX_FUZZ_BUDGET); });
}
