// Fuzz target: raw planar float streams (gbrpf32le / gbrapf32le) through read_raw. The first two bytes
// choose the frame size (1..16 each, as --size would) and the third the pixel format; the rest is the
// stream. Each frame is written back with write_raw and read again, which must give the same pixels.
#include <cstdlib>
#include <cstring>
#include <optional>
#include <stdexcept>

#include <filter/stream.h>

#include "fuzz_input.h"

namespace {

using lensfx::filter::Frame;
using lensfx::filter::RawPixFmt;

void check_round_trip(const Frame& frame, RawPixFmt fmt) {
    char* text = nullptr;
    std::size_t size = 0;
    std::FILE* out = open_memstream(&text, &size);
    lensfx::filter::write_raw(out, frame, fmt);
    std::fclose(out);
    auto in = lensfx::fuzz::memory_stream(reinterpret_cast<const std::uint8_t*>(text), size);
    const std::optional<Frame> back = lensfx::filter::read_raw(in.get(), fmt, frame.spec.width, frame.spec.height);
    const bool same = back && back->pixels.size() == frame.pixels.size() &&
                      std::memcmp(back->pixels.data(), frame.pixels.data(), frame.pixels.size()) == 0;
    std::free(text);
    if (!same) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 3) return 0;
    const int width = 1 + data[0] % 16, height = 1 + data[1] % 16;
    const RawPixFmt fmt = data[2] % 2 == 0 ? RawPixFmt::gbrpf32le : RawPixFmt::gbrapf32le;
    auto in = lensfx::fuzz::memory_stream(data + 3, size - 3);
    if (!in) return 0;
    try {
        for (int frames = 0; frames < 8; ++frames) {
            const std::optional<Frame> frame = lensfx::filter::read_raw(in.get(), fmt, width, height);
            if (!frame) break;
            check_round_trip(*frame, fmt);
        }
    } catch (const std::runtime_error&) {
    }
    return 0;
}
