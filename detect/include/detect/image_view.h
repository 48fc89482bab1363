// A read-only view of a float RGB(A) frame in memory, the detector's input whatever the frame came from,
// and the luminance weights every stage uses.
#pragma once

#include <array>
#include <cstddef>

namespace lensfx::detect {

// Rec.709 / sRGB primaries, D65: Y = 0.2126 R + 0.7152 G + 0.0722 B (scene-linear).
inline constexpr std::array<double, 3> kRec709Luma{0.2126, 0.7152, 0.0722};

// Pixel (i, j) is column i, row j, row 0 at the top; it covers [i, i+1) x [j, j+1), so its centre is at
// (i + 0.5, j + 0.5). Positions reported by the detector are in these units, shifted by (x_offset,
// y_offset): pass the data window's origin there and positions come out in display-window pixels.
struct ImageView {
    const float* data = nullptr;
    int width = 0;
    int height = 0;
    int channels = 3;              // floats per pixel; R, G, B are the first three
    std::ptrdiff_t row_stride = 0; // floats from one row to the next; 0 means width * channels
    int x_offset = 0;
    int y_offset = 0;

    [[nodiscard]] std::ptrdiff_t stride() const {
        return row_stride != 0 ? row_stride : static_cast<std::ptrdiff_t>(width) * channels;
    }
    [[nodiscard]] const float* row(int y) const { return data + static_cast<std::ptrdiff_t>(y) * stride(); }
};

}  // namespace lensfx::detect
