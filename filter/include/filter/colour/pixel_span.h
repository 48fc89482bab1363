// A view of float pixels that the colour transforms and quantisation work on.
#pragma once

#include <cstddef>

namespace lensfx::colour {

// A view of float pixels with at least 3 channels (RGB first; further channels such as alpha are left
// untouched). `row_stride` in floats, 0 = width * channels.
struct PixelSpan {
    float* data = nullptr;
    std::size_t width = 0;
    std::size_t height = 0;
    int channels = 3;
    std::size_t row_stride = 0;
};

}  // namespace lensfx::colour
