// Fuzz target: EXR files through the project's own reader (read_exr, OpenEXR underneath), then the R, G, B
// working buffer the pipeline makes of a frame. read_exr takes a path, so the bytes go to a file in
// /dev/shm (memory) first.
#include <cstdio>
#include <stdexcept>
#include <string>

#include <fmt/core.h>
#include <unistd.h>

#include <filter/frame.h>

#include "exr_io.h"
#include "fuzz_input.h"

namespace {

const std::string& scratch_path() {
    static const std::string path = fmt::format("/dev/shm/lensfx-fuzz-exr-{}.exr", ::getpid());
    return path;
}

bool write_file(const std::string& path, const std::uint8_t* data, std::size_t size) {
    lensfx::fuzz::File f(std::fopen(path.c_str(), "wb"));
    return f && std::fwrite(data, 1, size, f.get()) == size;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (!write_file(scratch_path(), data, size)) return 0;
    try {
        lensfx::filter::Frame frame = lensfx::filter::read_exr(scratch_path() LENSFX_FUZZ_BUDGET);
        if (frame.has_rgb()) lensfx::filter::load_rgb(frame);
    } catch (const std::runtime_error&) {
    }
    std::remove(scratch_path().c_str());
    return 0;
}
