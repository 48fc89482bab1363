// Scene culling (issue 17): what a frame can show of a flare added to it, as the ghost renderer's
// gpu::VisibilityMap. The visible level at a plate value L (frame units, 1 = display white) is one code value
// of the frame's 8-bit sRGB view at exposure 0: 1 / (255 x the sRGB curve's slope at L), L taken within
// [0, 1] (the slope above white is that at white, so a grade or the ACES view, which does not clip there,
// still sees what lands on bright parts). The ACES SDR view's error is measured (bench_cull), not bounded.
// Each of R, G and B has its own level and budget: a spectral pass adds to one channel, and the 8-bit view's
// codes are per channel. --visibility V: the ghosts left out together change no channel of any cell's 8-bit
// view by more than V codes (to first order, before rounding). docs/acceleration.md has the measured error.
#pragma once

#include <memory>

#include <filter/frame.h>
#include <gpu/acceleration.h>

namespace lensfx::filter {

inline constexpr int kVisibilityCell = 32;

// The scene-linear step at plate value `plate` that moves its 8-bit sRGB code by one.
double srgb8_code_step(double plate);

// The visibility map of a frame's plate (R, G, B as loaded, over its data window; pixels of the display window
// outside it are black) over its display window, with --visibility `budget`: per cell of `cell` pixels and
// channel, the code step at the least of its pixels' values in that channel. Cells grow (doubling) where the
// display window would need more than 2048 x 2048 of them.
std::shared_ptr<gpu::VisibilityMap> plate_visibility(const Frame& frame, double budget, int cell = kVisibilityCell);

}  // namespace lensfx::filter
