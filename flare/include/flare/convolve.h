// Convolution of an RGB float image with a wide kernel through FFTs (FFTW, double precision): what extended
// sources' footprints (flare/footprint.h) and their starburst tails are spread with.
#pragma once

#include <string>
#include <vector>

namespace lensfx::flare {

// rgb (width x height, 3 floats a pixel, top row first) replaced by its convolution with `kernel`:
// (2 ry + 1) rows of (2 rx + 1) floats, its centre at (rx, ry); the image is zero outside. out(x, y) is the
// sum of kernel(rx + a, ry + b) * in(x - a, y - b). Summed in double (each result within float rounding of
// the exact sum, as OpenCV's filter2D gave before), tile by tile over a large image (at most
// kMaxFftSide^2 values a transform, so the scratch stays some 25 MB a thread). The tiles' channels are shared
// by the calling thread and one more (the extended groups are convolved while the GPU has nothing to do).
void convolve_rgb(std::vector<float>& rgb, int width, int height, const float* kernel, int rx, int ry);

// Keeps what FFTW's planner learns (its wisdom) in the cache folder `dir` (flare/cache.h; empty: not kept):
// read at the next plan, written back when the folder changes (keep_fft_wisdom_in("") saves it now) or the
// process ends, if a plan added to it. For the process: the planner is one.
void keep_fft_wisdom_in(const std::string& dir);

// The side of the largest transform convolve_rgb makes; a larger image is convolved in tiles.
inline constexpr int kMaxFftSide = 1024;

// The smallest n' >= n with no prime factor over 7 (FFTW's fast sizes).
int fft_size(int n);

}  // namespace lensfx::flare
