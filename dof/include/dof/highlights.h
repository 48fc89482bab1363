// Bokeh of small bright lights: the gather samples the plate with N rays per pixel, so a light smaller than
// the rays' spacing over its blur disc is hit by well under one ray per output pixel and shows as a lattice
// of dots. Such lights are taken out of the plate the gather reads and scattered instead: each one's energy
// spread evenly over its bokeh, the polygon of the lens rays' crossings at its depth (the traced pupil, so
// blades, cat's eye and chromatic blur come with it), added to the gathered image.
#pragma once
#include <array>
#include <cstddef>
#include <vector>

#include <dof/lens_rays.h>

namespace lensfx::dof {

// Which pixels count as highlights (see take_highlights).
struct HighlightSettings {
    int radius = 5;              // the plate's level around a pixel: grey opening with a (2 radius + 1)^2 square
    double min_excess = 0.5;     // a highlight's excess over that level (largest channel) is at least this...
    double min_ratio = 1.0;      // ...and at least this many times the level (largest channel)
    double min_blur_px = 1.5;    // and its bokeh's radius at least this (the gather is smooth below)
    std::size_t max_count = 50000;  // the brightest this many; the rest stay with the gather
    // and the brightest whose bokehs' areas (pi r^2) sum to at most this many times the plate's pixels: the
    // splat's cost follows that area (a 1500 x 1000 checkerboard of 50,000 far lights took 161 s against the
    // gather's 50 s); the rest stay with the gather
    double max_area_ratio = 16.0;
};

// One highlight pixel of the plate: where it is (the layers' pixels), its inverse depth, its excess energy.
struct Highlight {
    int x = 0, y = 0;
    float w = 0.0f;
    std::array<float, 3> excess{};
};

// Finds the highlights of a flat plate (rgb interleaved, depth in metres per pixel; width x height, the
// table's raster from (origin_x, origin_y)) and subtracts each one's excess from rgb. A highlight's excess
// is its value above the grey opening of the plate (what remains when features narrower than 2 radius + 1
// pixels are removed: the white top-hat), taken where that excess passes min_excess and min_ratio and the
// lens blurs the pixel's depth to a bokeh wider than min_blur_px; the brightest within max_count and
// max_area_ratio.
std::vector<Highlight> take_highlights(std::vector<float>& rgb, const std::vector<float>& depth_m, int width, int height,
                                       const RayTable& table, int origin_x, int origin_y, const HighlightSettings& settings = {});

// Adds each highlight's bokeh to rgb (the blurred raster of the same size): its excess over the convex hull
// of where the table's rays at the highlight's pixel cross its depth, mirrored through the pixel, per band
// (chromatic: each band's own rays, else the achromatic band's), covering each pixel by its area and scaled
// like the gather's (the focused lens's magnification of that depth). Pixels whose visible surface
// (front_m, metres per pixel) lies nearer than the highlight by more than `step` (relative) hide it there.
void splat_highlights(const std::vector<Highlight>& highlights, const RayTable& table, int origin_x, int origin_y, bool chromatic,
                      const std::vector<float>& front_m, int width, int height, std::vector<float>& rgb, double step = 0.05);

}  // namespace lensfx::dof
