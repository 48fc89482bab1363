// Colour maths without OpenColorIO: 3x3 matrices, RGB primaries and white points (CIE 1931 xy), the RGB ->
// XYZ matrix of a space, Bradford adaptation, and monochromatic light in a working space's RGB.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>

#include <optics/colour_matrix.h>

namespace lensfx::colour {

// The optics core's 3x3 matrices (row-major, out = m * in): one type for the renderers' primaries and this.
using optics::apply_matrix;
using optics::inverse;
using optics::Mat3;
using optics::multiply;

// CIE 1931 xy chromaticities of an RGB space's primaries and white point, in the order of the OpenEXR
// `chromaticities` attribute: red x, y, green x, y, blue x, y, white x, y.
struct Chromaticities {
    double rx, ry, gx, gy, bx, by, wx, wy;
};

// D65 as OCIO's built-in transforms and ITU-R BT.709 state it.
inline constexpr double d65_x = 0.3127, d65_y = 0.3290;

// The 8 values of an EXR chromaticities attribute as Chromaticities (widened) and back (packed), and in words.
Chromaticities widened(const std::array<float, 8>& exr_chromaticities);
std::array<float, 8> packed(const Chromaticities& c);
std::string describe(const std::array<float, 8>& exr_chromaticities);

enum class KnownPrimaries { Rec709, AcesAP0, AcesAP1, Rec2020, P3D65 };

Chromaticities chromaticities(KnownPrimaries p);
std::string_view name(KnownPrimaries p);

// Which of the known primary sets the 8 floats of an EXR chromaticities attribute are, allowing for the
// rounding of writers (each coordinate within `tolerance`); nullopt when none matches.
std::optional<KnownPrimaries> identify_primaries(const std::array<float, 8>& exr_chromaticities,
                                                 double tolerance = 2e-3);

// The RGB -> CIE XYZ matrix of an RGB space (no chromatic adaptation; white RGB (1,1,1) maps to the white
// point with Y = 1).
Mat3 rgb_to_xyz(const Chromaticities& c);
// Bradford chromatic adaptation of XYZ from one white point (xy) to another.
Mat3 bradford(double src_wx, double src_wy, double dst_wx, double dst_wy);
// Primaries and white of an RGB -> XYZ matrix (the xy of its columns and of their sum).
Chromaticities primaries_of(const Mat3& rgb_to_xyz);

// CIE 1931 2-degree colour matching functions (the optics core's Wyman-Sloan-Shirley fit).
using optics::cie1931_xyz;
// Working-space RGB of monochromatic light of unit spectral power at a wavelength: inverse(rgb_to_xyz) times
// the colour matching functions. A renderer that samples wavelengths sums these (times the sample spacing)
// to put a spectrum into the same RGB as the frame. Spectral colours lie outside most gamuts: expect
// negative components.
std::array<double, 3> wavelength_to_rgb(double wavelength_nm, const Mat3& rgb_to_xyz);

}  // namespace lensfx::colour
