// What the stream fuzz targets (PFM, raw) do with the fuzzer's bytes: read up to 8 frames from them as a
// stream, write each back and read it again, which must give the same pixels bit for bit.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <stdexcept>

#include <filter/stream.h>

#include "fuzz_input.h"

namespace lensfx::fuzz {

// Writes `frame` with write(FILE*) into memory and reads it back with read(FILE*) (-> optional<Frame>);
// aborts unless the same pixels come back.
template <typename Write, typename Read>
void check_round_trip(const filter::Frame& frame, Write write, Read read) {
    char* text = nullptr;
    std::size_t size = 0;
    std::FILE* out = open_memstream(&text, &size);
    write(out, frame);
    std::fclose(out);
    auto in = memory_stream(reinterpret_cast<const std::uint8_t*>(text), size);
    const std::optional<filter::Frame> back = read(in.get());
    const bool same = back && back->pixels.size() == frame.pixels.size() &&
                      std::memcmp(back->pixels.data(), frame.pixels.data(), frame.pixels.size()) == 0;
    std::free(text);
    if (!same) std::abort();
}

// Up to 8 frames read with read(FILE*) from the bytes as a stream, each written with write(FILE*, frame) and
// checked by check_round_trip; a std::runtime_error (the readers' refusal) ends the input.
template <typename Write, typename Read>
int read_write_read(const std::uint8_t* data, std::size_t size, Write write, Read read) {
    auto in = memory_stream(data, size);
    if (!in) return 0;
    try {
        for (int frames = 0; frames < 8; ++frames) {
            const std::optional<filter::Frame> frame = read(in.get());
            if (!frame) break;
            check_round_trip(*frame, write, read);
        }
    } catch (const std::runtime_error&) {
    }
    return 0;
}

}  // namespace lensfx::fuzz
