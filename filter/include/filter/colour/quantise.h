// Display-referred float pixels in [0, 1] to 8 or 16-bit integers with deterministic dither (Bayer or
// blue noise), and which output formats are display-referred.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include <filter/colour/pixel_span.h>
#include <filter/dither.h>

namespace lensfx::colour {

// Output files: those lensfx writes as display-referred integer pixels always get the display transform
// (PNG, JPEG, IFF, ...); scene-linear ones (EXR, TIFF, HDR, PFM, raw float) only when asked.
bool is_display_referred_format(std::string_view path_or_extension);
// Display formats whose alpha is straight (unassociated) by their specification: PNG, WebP, TGA, GIF,
// AVIF, HEIC. Their colour is written divided by alpha, as such a file's readers composite it.
bool holds_straight_alpha(std::string_view path_or_extension);

// Quantises display-referred values in [0, 1] to `bits` (8 or 16) with deterministic dither: Ordered is a
// 16x16 Bayer matrix, BlueNoise a fixed, spatially decorrelated pattern; `frame` shifts the pattern over
// time so that a static picture does not show a fixed pattern in video. Values outside [0, 1] clamp.
std::vector<std::uint8_t> quantise8(const PixelSpan& pixels, Dither dither, std::uint64_t frame = 0);
std::vector<std::uint16_t> quantise16(const PixelSpan& pixels, Dither dither, std::uint64_t frame = 0);
// The dither threshold offset in (-0.5, 0.5) LSB at a pixel and channel, for tests and the GPU path.
float dither_offset(Dither dither, std::size_t x, std::size_t y, int channel, std::uint64_t frame);

}  // namespace lensfx::colour
