// Convolution of an RGB float image with a wide kernel through FFTs (FFTW, double precision): what extended
// sources' footprints (flare/footprint.h) and their starburst tails are spread with.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace lensfx::flare {

// The arrays convolve_rgb transforms in, kept between its calls by whoever makes a series of them (the flare
// stage: a frame convolves its groups one after another, at a few sizes, and a fresh allocation's first
// touch costs more than the transforms). At most three are kept, the largest (some 50 MB at kMaxFftSide),
// and freed with the owner. Calls on several threads may share one.
class ConvolveScratch {
public:
    ConvolveScratch();
    ~ConvolveScratch();
    ConvolveScratch(const ConvolveScratch&) = delete;
    ConvolveScratch& operator=(const ConvolveScratch&) = delete;

    // The bytes kept between calls.
    std::size_t held_bytes() const;

    struct Pool;  // convolve.cpp's

private:
    friend void convolve_rgb(std::vector<float>& rgb, int width, int height, const float* kernel, int rx, int ry,
                             ConvolveScratch& scratch);
    std::unique_ptr<Pool> pool_;
};

// rgb (width x height, 3 floats a pixel, top row first) replaced by its convolution with `kernel`:
// (2 ry + 1) rows of (2 rx + 1) floats, its centre at (rx, ry); the image is zero outside. out(x, y) is the
// sum of kernel(rx + a, ry + b) * in(x - a, y - b). Summed in double (each result within float rounding of
// the exact sum, as OpenCV's filter2D gave before), tile by tile over a large image (at most
// kMaxFftSide^2 values a transform, so the scratch stays some 25 MB a thread). The tiles' channels are shared
// by the calling thread and one more (the extended groups are convolved while the GPU has nothing to do).
// The arrays come from `scratch` and go back to it.
void convolve_rgb(std::vector<float>& rgb, int width, int height, const float* kernel, int rx, int ry, ConvolveScratch& scratch);

// Keeps what FFTW's planner learns (its wisdom) in the cache folder `dir` (flare/cache.h; empty: not kept):
// read at the next plan (a file over 1 MiB, or not a regular file, is no wisdom and is replaced), written
// back when the folder changes (keep_fft_wisdom_in("") saves it now) or the process ends, if a plan added to
// it. For the process, as are the plans for each transform size: FFTW's planner and its wisdom are global to
// the process (not thread-safe, so planning is serialised under one lock), and a plan, some kilobytes, is
// made once per size and run on any caller's arrays. The arrays, the memory that counts, are the caller's
// (ConvolveScratch).
void keep_fft_wisdom_in(const std::string& dir);

// The side of the largest transform convolve_rgb makes; a larger image is convolved in tiles.
inline constexpr int kMaxFftSide = 1024;

// The smallest n' >= n with no prime factor over 7 (FFTW's fast sizes).
int fft_size(int n);

}  // namespace lensfx::flare
