// Extended sources (issue 6): the ghost of an extended source is the point light's ghost convolved with
// the source's footprint as that ghost images it, scaled by the ghost's magnification. Which ghosts need the
// footprint (and at which magnification), and the convolution itself.
#pragma once

#include <array>
#include <utility>
#include <vector>

#include <detect/source.h>
#include <flare/convolve.h>
#include <optics/ghosts.h>
#include <optics/starburst.h>

namespace lensfx::flare {

// A group of an extended light's ghosts drawn together.
struct FootprintGroup {
    double magnification = 0.0;  // the footprint's scale for these ghosts; 0: drawn as from a point
    std::vector<std::pair<int, int>> ghosts;  // Ghost::first, Ghost::second
};

// Ghosts too blurred (blur over kBlurOverFootprint times the scaled footprint) or too small (under a pixel)
// for the footprint to show are drawn as from a point; the others are grouped by magnification in steps of
// sqrt 2, limited to 1/16..16. Groups carrying under kMinGroupShare of the lens's ghost power at normal
// incidence (axial_power, per ghost) join the point group, which comes first when there is one.
inline constexpr double kBlurOverFootprint = 4.0;
inline constexpr double kMinGroupShare = 1e-3;
std::vector<FootprintGroup> footprint_groups(const std::vector<optics::Ghost>& ghosts,
                                             const std::vector<optics::GhostImaging>& imaging,
                                             const std::vector<double>& axial_power, const detect::Shape& shape,
                                             double pixel_mm);

// Convolves an RGB image (width x height, top row first) with a light's footprint scaled by magnification m
// (negative: turned round), normalised to keep the image's sum. One DFT-based filter of the image, so the
// cost follows the frame and kernel size, not the source's pixel count; only of the part the kernel reaches
// from the lit pixels where that is under half the image (the rest stays 0); kernels wider than
// kMaxKernelRadius pixels are applied to the image reduced so that they are half that. The FFTs' arrays
// come from `scratch` (flare/convolve.h).
inline constexpr int kMaxKernelRadius = 64;
void convolve_footprint(std::vector<float>& rgb, int width, int height, const detect::Shape& shape, double m,
                        ConvolveScratch& scratch);

// The footprint in the pixels of an image reduced by `factor` (flare/image_ops.h's reduced_side mapping).
detect::Shape reduced_footprint(detect::Shape shape, int factor);

// The largest share of a point's light one pixel holds after convolve_footprint at magnification m (the
// kernel's largest weight, normalised, in the image's pixels; for a kernel applied reduced, over the reduction
// squared): a ghost of power P convolved so peaks at P x share per pixel area, however sharp it was. 1 when
// nothing is convolved, 0 when the kernel clears the image.
double footprint_peak_share(const detect::Shape& shape, double m);

// An extended light's diffraction: every point's starburst over its footprint (magnification 1), less what
// the recorded source already holds, added to an RGB image of width x height (arguments as
// optics::splat_starburst's). Each point's pattern within the footprint's radius (the disc of its cells'
// area) is left out, as is all that lands on the light's own pixels (its cells holding any of its light,
// interpolated between cell centres): the source does not bloom, the spikes reaching beyond it remain.
// Only the region the pattern and the footprint reach is drawn and convolved. As for a point light, the
// texture gives up its tail's share and the tail (optics::draw_starburst_tail, lengthened by
// length_scale, --starburst-scale) runs to the frame edge, spread over the footprint too: the spikes of a
// source are as wide as the source, and a longer scale lengthens them without widening them. The FFTs'
// arrays come from `scratch`.
void add_extended_starburst(const optics::Starburst& sb, const optics::Aperture& aperture, double length_scale,
                            const optics::StarburstPlacement& at, const std::array<double, 3>& power,
                            const detect::Shape& shape, const optics::SensorImage& image, ConvolveScratch& scratch);

}  // namespace lensfx::flare
