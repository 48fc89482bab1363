// What a ghost-flare image is, shared by the GPU renderer and the dense CPU reference: the view (light
// angles, sensor, pixels, wavelengths), the image (sensor irradiance, upright, row 0 at the top), the
// iris as a signed distance field, the entrance-pupil region of each ghost, and the reference renderer
// itself (many exact double-precision rays per ghost, binned into pixels).
#pragma once

#include <array>
#include <optional>
#include <utility>
#include <vector>

#include <optics/aperture.h>
#include <optics/ghosts.h>
#include <optics/lens.h>
#include <optics/starburst.h>
#include <optics/tracer.h>

namespace lensfx::flare {

using optics::Aperture;
using optics::Ghost;
using optics::System;
using optics::TraceResult;
using optics::TraceSystem;

// RGB mode renders one wavelength per channel: R 650 nm, G 550 nm, B 450 nm.
inline constexpr std::array<double, 3> kRgbWavelengths_nm = {650.0, 550.0, 450.0};

// Spectral mode: N equal bands over 380..780 nm (issue 5's quality levels).
inline constexpr int kMinBands = 7;
inline constexpr int kMaxBands = 81;
inline constexpr double kSpectrumFirst_nm = 380.0;
inline constexpr double kSpectrumLast_nm = 780.0;

// One rendered wavelength and what its image adds to each output channel (image x weight).
struct SpectralPass {
    double wavelength_nm = 550.0;
    std::array<double, 3> weight{};
};

// The passes of `bands` bands (kMinBands..kMaxBands) at the band centres, weighted by the CIE 1931 colour
// matching functions converted by xyz_to_rgb (the working space's primaries), each channel's weights
// normalised to sum to 1: a flat spectrum of irradiance 1 gives 1 in every channel. Weights may be
// negative (spectral colours lie outside most gamuts). Throws std::invalid_argument on a bad band count.
std::vector<SpectralPass> spectral_passes(int bands, const optics::Mat3& xyz_to_rgb = optics::kXyzToRec709);

// The frame as the lens sees it: the sensor's size, its pixels (the upright photograph, row 0 at the top)
// and the rectilinear mapping of pixels to field angles through focal_mm.
struct SensorView {
    double sensor_width_mm = 36.0;
    double sensor_height_mm = 24.0;
    int width = 360;   // pixels
    int height = 240;
    double focal_mm = 0.0;  // from the lens (paraxial EFL) or --fov; only angles_at needs it

    double pixel_area_mm2() const { return (sensor_width_mm / width) * (sensor_height_mm / height); }
    // Field angles (ax right, ay up, degrees) of a light imaged at pixel position (x, y) (pixel centres at
    // +0.5; row 0 at the top).
    std::array<double, 2> angles_at(double x, double y) const;
};

// What a flare image is drawn for: the sensor view, the light's direction and the wavelengths.
struct FlareView : SensorView {
    double angle_x_deg = 0.0;  // light ax degrees right of the view axis (DESIGN.md)
    double angle_y_deg = 0.0;  // ay degrees above it
    // Empty: RGB mode (kRgbWavelengths_nm), or `bands` spectral bands. One value: that wavelength into
    // every channel.
    std::optional<double> wavelength_nm;
    int bands = 0;                                   // 0: RGB mode; kMinBands..kMaxBands: spectral
    optics::Mat3 xyz_to_rgb = optics::kXyzToRec709;  // the working space, for the spectral weights
    // Only these ghosts (Ghost::first, Ghost::second as System interface indices); empty = all.
    std::vector<std::pair<int, int>> only_ghosts;

    // What to render: three one-channel passes in RGB mode, spectral_passes(bands, xyz_to_rgb) in
    // spectral mode, one pass into every channel for a single wavelength. Throws on a bad band count or
    // on both a wavelength and bands.
    std::vector<SpectralPass> passes() const;
};

struct GhostPower {
    int first = 0;   // System interface indices, as in Ghost
    int second = 0;
    std::array<double, 3> power{};  // per channel: power landing on the image (mm^2 x irradiance 1)
};

// RGB float image of sensor irradiance for a light of irradiance 1 per channel; row 0 is the top of the
// upright photograph. ghosts: one entry per rendered ghost when the renderer was asked for them.
struct FlareImage {
    int width = 0;
    int height = 0;
    std::vector<float> rgb;  // width * height * 3
    std::vector<GhostPower> ghosts;

    float at(int x, int y, int c) const {
        return rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 3 +
                   static_cast<std::size_t>(c)];
    }
    // Sum of irradiance x pixel area over the image, per channel.
    std::array<double, 3> total_power(const FlareView& view) const;
    // Total variation (|horizontal| + |vertical| neighbour differences, all channels) over the sum of |values|:
    // how much edge an image has (separate copies of a ghost per band add edges a smooth spectrum has not).
    // 0 for an empty image.
    double edge_measure() const;
};

// The iris shape (optics/aperture.h): negative inside, in stop radii, the upright frame.
using optics::aperture_sdf;

// Drops every anti-reflection coating (`--coating none`): bare Fresnel interfaces.
System without_coatings(System system);

// The ghosts a view asks for (all of them, or view.only_ghosts); throws std::invalid_argument naming a
// requested pair that is no ghost of the system.
std::vector<Ghost> selected_ghosts(const System& system, const FlareView& view);

// Rectangle on the plane z = 0 (the first vertex's tangent plane) that the collimated rays of a ghost
// cross. full_square: the whole front element seen along the light direction. bounds: where a coarse
// trace found rays that reach the sensor unblocked (r_rel <= 1, inside the iris at every stop crossing),
// grown by one coarse cell; empty when none did.
struct PupilRect {
    double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;
    bool empty() const { return !(x1 > x0 && y1 > y0); }
};
PupilRect entrance_square(const TraceSystem& system, const FlareView& view);
PupilRect ghost_pupil_bounds(const TraceSystem& system, const Ghost& ghost, const Aperture& aperture,
                             const FlareView& view, double entrance_pupil_diameter_mm);

// Whether a traced ray passes: traced to the sensor, r_rel <= 1 and inside the iris at each stop crossing.
bool ray_passes(const TraceResult& result, const Aperture& aperture);

// Upright image position (pixels, continuous, (0,0) = top-left corner) of a sensor point (lens x/y, mm).
std::array<double, 2> sensor_to_pixel(const FlareView& view, double x_mm, double y_mm);

struct ReferenceOptions {
    int rays = 512;               // N: N x N rays per ghost and wavelength over the entrance square
    int threads = 2;              // bands of ray rows; the same thread count repeats the image exactly
    bool per_ghost_power = true;  // fill FlareImage::ghosts
    // false: the rays cover the whole entrance square. true: each ghost's rays cover its
    // ghost_pupil_bounds (exact CPU coarse trace) grown by 10% on every side, so that the same N samples
    // a small iris densely; ghosts whose coarse trace found nothing are left out.
    bool ghost_bounds = false;
};

// The dense reference: for each ghost and wavelength, N x N collimated rays over the entrance square,
// one at a fixed pseudo-random point of each cell of an N x N grid (stratified, so no moire), each traced
// exactly (double, coatings per ray) and carrying the power of its cell (cell area x cos of the light's
// angle x transmission), added into the pixel it lands in.
FlareImage render_reference(const System& system, const FlareView& view, const ReferenceOptions& options = {});

// How far a flare image is from a reference of the same view, channel by channel (the worst channel).
struct FlareError {
    double total = 0.0;        // |power - reference power| / reference power over the whole image
    double worst_ghost = 0.0;  // the same per ghost, over the ghosts holding more than 1% of the total
                               // (both images need FlareImage::ghosts; 0 when either lacks them)
    double block_l1 = 0.0;     // sum over block x block pixel tiles of |sum - reference sum| / reference total
    int compared_ghosts = 0;
    std::pair<int, int> worst{-1, -1};  // (first, second) of the ghost behind worst_ghost
};
FlareError compare_flare(const FlareImage& image, const FlareImage& reference, const FlareView& view, int block = 8);

// Structure error: the relative L1 of the images' gradients, sum |grad a - grad b| / sum |grad b| over
// forward differences in x and y and all channels. Flat-shaded cells and stair-stepped rims show here
// where block sums hide them. 0 when the reference has no gradient.
double gradient_error(const FlareImage& image, const FlareImage& reference);

}  // namespace lensfx::flare
