// The diffraction starburst (flare paper section 3.3, eqs. 2-4): the Fraunhofer pattern of the iris, i.e.
// the Fourier power spectrum of its transmission function, summed over 380-780 nm in 5 nm steps (each
// wavelength's copy scaled with the wavelength, weighted by the CIE 1931 colour-matching functions and
// converted to linear RGB), normalised to unit flux per channel. Computed once per iris shape (FFTW) and
// placed at a light's image, sized with the f-number.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include <optics/colour_matrix.h>
#include <optics/imperfections.h>
#include <optics/lens.h>

namespace lensfx::optics {

struct StarburstOptions {
    int size = 512;                 // texture side in texels (power of two recommended)
    int pupil_samples = 96;         // samples across the iris radius in the FFT (resolution of the spikes)
    double first_nm = 380.0;
    double last_nm = 780.0;
    double step_nm = 5.0;
    Mat3 xyz_to_rgb = kXyzToRec709;  // the working space's primaries
    double smoothing = 0.6;          // Gaussian sigma in texels applied before summing, against aliasing
    PupilImperfections dirt;         // dust and scratches on the pupil (clean by default)
    ApertureImage image;             // when given, this transmission image replaces the iris shape
};

// A square RGB texture centred on the light; texel (size/2, size/2) holds the centre. Each channel sums to
// 1; the pattern fades out towards the texture's inscribed circle. One texel spans texel_per_fnumber_mm x f-number millimetres on the sensor (for a lens working at
// f-number N, the pattern's scale is proportional to wavelength x N, eq. 2 with z0 / D = N).
struct Starburst {
    int size = 0;
    double texel_per_fnumber_mm = 0.0;
    std::vector<float> rgb;  // size * size * 3, row 0 at the top of the upright image

    float at(int x, int y, int c) const {
        return rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(size) + static_cast<std::size_t>(x)) * 3 +
                   static_cast<std::size_t>(c)];
    }
    std::array<double, 3> sums() const;
};

Starburst make_starburst(const Aperture& aperture, const StarburstOptions& options = {});

// An RGB float image on the sensor that a pattern is added into: width x height pixels (rows from the top,
// 3 floats a pixel), each pixel_w_mm x pixel_h_mm of the sensor.
struct SensorImage {
    float* rgb = nullptr;
    int width = 0, height = 0;
    double pixel_w_mm = 0.0, pixel_h_mm = 0.0;
};

// A light's own image as the uniform ellipse with its second moments (detect::Extent): semi-axes in pixels,
// the major axis's angle in degrees counter-clockwise from +x with +y up. Every point of the light makes
// the pattern, so the pattern is spread over it (a sun 8 px across has spikes 8 px wide); 0 x 0 is a point.
// Semi-axes beyond kMaxSourceSpreadPx are taken as that (a point light is under 16 px; a track file may say more).
struct SourceEllipse {
    double major_px = 0.0, minor_px = 0.0;
    double angle_deg = 0.0;
};
inline constexpr double kMaxSourceSpreadPx = 64.0;

// Where a light's starburst goes: its centre (pixels, continuous, (0,0) the top-left corner), the lens's
// f-number N (the pattern's scale), the radius (texels) of the core left out and the light's own extent.
// only_core turns the core round: only the texels within core_radius_texels are drawn (draw_starburst_core).
struct StarburstPlacement {
    double cx = 0.0, cy = 0.0;
    double f_number = 0.0;
    double core_radius_texels = 0.0;
    SourceEllipse source{};
    bool only_core = false;
};

// Adds a starburst of the given total power per channel (image units x mm^2) placed as `at` says to `image`.
// Each output pixel integrates the texture over its footprint (box filter), so energy is kept at any scale.
// Texels closer to the centre than at.core_radius_texels are left out: for a light already in the image, its
// recorded pixels hold the pattern's core, and only the spikes and rings around it are new.
void splat_starburst(const Starburst& starburst, const StarburstPlacement& at, const std::array<double, 3>& power,
                     const SensorImage& image);

// The pattern beyond the texture (which reaches some 60 wavelength x f-number): Fraunhofer's asymptotic
// tail of the iris's edges. Each straight blade edge puts half its share of the light into a spike along
// its outward normal and half into the opposite one; a curved edge spreads its share evenly over the
// directions of its normals (a round iris: a faint halo all round). Whatever the shape, the light outside
// radius r is P R / (pi^2 A) x wavelength x N / r (P, A: the iris's perimeter and area, R its radius;
// 0.234 / rho for a hexagon, rho = r / (wavelength N)), so a spike's energy per unit length falls as 1 / r^2.
// Across, a spike is the edge's own diffraction, sinc^2 with its first zeros at +-2 wavelength N / (edge
// length / R), averaged over each channel's wavelengths (the red widest): a core under a pixel at most
// f-numbers, and wings falling as 1 / offset^2 that hold a few per cent of its light; near a bright light
// they are what shows (a spike's visible width narrows as it fades: it tapers), and between the spikes
// they are the pattern's faint 1 / r^4 field. Wings are drawn out to where a pixel would hold 1e-9 of the
// light, at most to the midline between two spikes. The spike is spread over the light's own extent (the
// ellipse's width across it), as the texture is.
// length_scale (--starburst-scale) lengthens the tail only: the energy outside r becomes that of r / scale.
struct StarburstTail {
    std::array<double, 3> share{};   // of the light, per channel, in the tail (drawn or beyond the frame)
};

// The texture (at the lens's own f-number) and its tail, together carrying `power` per channel: the
// texture gets power x (1 - tail share). Arguments as splat_starburst's; the tail is drawn to the frame
// edge, starting where the texture fades out.
StarburstTail draw_starburst(const Starburst& starburst, const Aperture& aperture, double length_scale,
                             const StarburstPlacement& at, const std::array<double, 3>& power, const SensorImage& image);

// The tail's share of the light per channel for this lens and length scale (what the texture gives up).
StarburstTail starburst_tail_share(const Starburst& starburst, const Aperture& aperture, double f_number, double length_scale);

// The tail alone of a light of `power` per channel (its whole power), drawn to the frame edge from where
// the texture fades out; arguments as draw_starburst's.
void draw_starburst_tail(const Starburst& starburst, const Aperture& aperture, double length_scale,
                         const StarburstPlacement& at, const std::array<double, 3>& power, const SensorImage& image);

// The core alone (the texels within at.core_radius_texels, spread over the light's extent) of a light of
// `power` per channel: what draw_starburst leaves out, for a light the image does not hold (--add-light on
// a plate without it). The core and draw_starburst's part of the same light sum to the whole pattern.
void draw_starburst_core(const Starburst& starburst, const Aperture& aperture, double length_scale, const StarburstPlacement& at,
                         const std::array<double, 3>& power, const SensorImage& image);

// Energy of the iris's pattern outside radius rho (in wavelength x f-number), asymptotically: P R / (pi^2 A rho).
double starburst_tail_coefficient(const Aperture& aperture);

// Radius in texels of the second dark ring of a round iris's pattern at 550 nm (2.23 lambda N), inside
// which about 91% of the energy lies: the core an image of the light already holds.
double starburst_core_radius_texels(const Starburst& starburst);

}  // namespace lensfx::optics
