// Fuzz target: a PFM stream (one image or many concatenated, as on stdin) through read_pfm, each image
// written back with write_pfm and read again, which must give the same pixels.
#include <cstdlib>
#include <cstring>
#include <optional>
#include <stdexcept>

#include <filter/stream.h>

#include "fuzz_input.h"

namespace {

using lensfx::filter::Frame;

void check_round_trip(const Frame& frame, bool top_first) {
    char* text = nullptr;
    std::size_t size = 0;
    std::FILE* out = open_memstream(&text, &size);
    lensfx::filter::write_pfm(out, frame, top_first);
    std::fclose(out);
    auto in = lensfx::fuzz::memory_stream(reinterpret_cast<const std::uint8_t*>(text), size);
    const std::optional<Frame> back = lensfx::filter::read_pfm(in.get(), top_first);
    const bool same = back && back->pixels.size() == frame.pixels.size() &&
                      std::memcmp(back->pixels.data(), frame.pixels.data(), frame.pixels.size()) == 0;
    std::free(text);
    if (!same) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    auto in = lensfx::fuzz::memory_stream(data, size);
    if (!in) return 0;
    const bool top_first = size % 2 == 0;
    try {
        for (int images = 0; images < 8; ++images) {
            const std::optional<Frame> frame = lensfx::filter::read_pfm(in.get(), top_first LENSFX_FUZZ_BUDGET);
            if (!frame) break;
            check_round_trip(*frame, top_first);
        }
    } catch (const std::runtime_error&) {
    }
    return 0;
}
