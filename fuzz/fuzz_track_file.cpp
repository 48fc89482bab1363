// Fuzz target: track files (JSON) through parse_track_json, then what the filter asks of one: the frame
// range and the lights at frames in and around it.
#include <stdexcept>

#include <detect/track_file.h>

#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    lensfx::detect::TrackFile file;
    try {
        file = lensfx::detect::parse_track_json(lensfx::fuzz::as_text(data, size), "fuzz.json");
    } catch (const std::runtime_error&) {
        return 0;
    }
    const auto [first, last] = file.frame_range();
    for (const int frame : {first - 1, first, first + (last - first) / 2, last, last + 1}) (void)file.lights_at(frame);
    return 0;
}
