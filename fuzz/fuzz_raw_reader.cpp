// Fuzz target: raw planar float streams (gbrpf32le / gbrapf32le) through read_raw. The first two bytes
// choose the frame size (1..16 each, as --size would) and the third the pixel format; the rest is the
// stream. Each frame is written back with write_raw and read again, which must give the same pixels.
#include <filter/stream.h>

#include "fuzz_input.h"
#include "stream_round_trip.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using lensfx::filter::Frame;
    using lensfx::filter::RawPixFmt;
    if (size < 3) return 0;
    const int width = 1 + data[0] % 16, height = 1 + data[1] % 16;
    const RawPixFmt fmt = data[2] % 2 == 0 ? RawPixFmt::gbrpf32le : RawPixFmt::gbrapf32le;
    return lensfx::fuzz::read_write_read(
        data + 3, size - 3, [&](std::FILE* out, const Frame& frame) { lensfx::filter::write_raw(out, frame, fmt); },
        [&](std::FILE* in) { return lensfx::filter::read_raw(in, fmt, width, height); });
}
