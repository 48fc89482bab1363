// What detection finds in one frame and what tracking hands to the renderer: plain value types.
// Positions are in pixels of the frame (see image_view.h for the pixel-centre convention); fluxes are
// sums of scene-linear pixel values (the energy the image recorded), per channel.
#pragma once

#include <array>
#include <optional>
#include <vector>

namespace lensfx::detect {

// Semi-axes of the uniform ellipse with the same second moments as the source's light (2 sigma along
// each principal axis), in pixels; angle of the major axis in degrees, counter-clockwise from +x with +y up
// (as the photographer sees the image), in [0, 180).
struct Extent {
    double major = 0.0;
    double minor = 0.0;
    double angle_deg = 0.0;
    friend bool operator==(const Extent&, const Extent&) = default;
};

// A small image of an extended source's light, for convolving a ghost with it: cells of `cell` x `cell`
// pixels, row 0 at the top, weights summing to 1. The top-left corner of cell (0, 0) lies at
// (x + origin_x, y + origin_y) where (x, y) is the source's position, so the shape moves with the light.
struct Shape {
    int width = 0;
    int height = 0;
    double cell = 1.0;
    double origin_x = 0.0;
    double origin_y = 0.0;
    std::vector<float> weights;  // width * height, row-major
    friend bool operator==(const Shape&, const Shape&) = default;
};

// One bright source found in one frame.
struct Source {
    double x = 0.0;  // flux-weighted centroid, sub-pixel
    double y = 0.0;
    std::array<double, 3> flux{};  // RGB sum over the source's pixels
    double luminous_flux = 0.0;    // Rec.709 luminance of `flux`
    double peak = 0.0;             // highest pixel luminance
    double peak_channel = 0.0;     // highest R, G or B value
    int pixel_count = 0;
    int members = 1;               // connected components merged or clustered into this source
    std::array<int, 4> bbox{};     // x0, y0, x1, y1 in pixels, x1/y1 exclusive, frame coordinates
    Extent extent;
    bool clipped = false;          // peak at the clip level, or a flat top (several pixels at the peak)
    std::optional<Shape> shape;    // for extended sources only
};

// Frame-wide figures the detector measured on the way.
struct FrameStats {
    int width = 0;
    int height = 0;
    double median_luminance = 0.0;
    double max_luminance = 0.0;        // the brightest pixel's (sanitised) luminance
    double total_luminous_flux = 0.0;  // of the whole frame (finite, non-negative pixels)
    double threshold = 0.0;            // resolved birth threshold (luminance)
    double low_threshold = 0.0;        // resolved continuation threshold: threshold / 2^hysteresis_ev
    int invalid_pixels = 0;            // NaN, Inf or negative in R, G or B
    int components = 0;                // connected components at full resolution
    bool clustered = false;            // grid clustering was applied
    int dropped_invisible = 0;         // sources below the visibility fraction
    int dropped_budget = 0;            // sources beyond max_lights
    std::vector<float> histogram;      // fraction of pixels per stop of luminance (cut detection)
};

struct Detection {
    std::vector<Source> sources;  // brightest (luminous flux) first
    FrameStats stats;
};

// A light to render at one frame: a tracked (or hand-authored) source after smoothing.
struct Light {
    int id = 0;
    double x = 0.0;
    double y = 0.0;
    std::array<double, 3> flux{};
    Extent extent;
    double weight = 1.0;  // fade in [0, 1]: multiply the flare by it
    double gain = 1.0;    // artistic scale of this light's flare (a track file's per-track "gain"), >= 0
    bool clipped = false;
    std::optional<Shape> shape;
    friend bool operator==(const Light&, const Light&) = default;
};

}  // namespace lensfx::detect
