// Colour maths of the optics core, one form for every layer: 3x3 colour matrices (Mat3) with their product
// and inverse, the default working space's XYZ -> RGB, and the CIE 1931 colour-matching functions. The
// starburst's and the flare renderers' primaries and filter/colour's maths all use these.
#pragma once

#include <array>
#include <cstddef>

namespace lensfx::optics {

// Row-major 3x3 matrix acting on column vectors: out = m * in (out[r] = row r of m times in).
using Mat3 = std::array<double, 9>;

// CIE XYZ -> linear Rec.709 / sRGB (D65), the default working space.
inline constexpr Mat3 kXyzToRec709{3.2404542, -1.5371385, -0.4985314,  //
                                   -0.9692660, 1.8760108, 0.0415560,   //
                                   0.0556434, -0.2040259, 1.0572252};

Mat3 multiply(const Mat3& a, const Mat3& b);
Mat3 inverse(const Mat3& m);  // throws std::invalid_argument when singular

// Component `row` of m * v.
inline double row_times(const Mat3& m, std::size_t row, const std::array<double, 3>& v) {
    return m[3 * row] * v[0] + m[3 * row + 1] * v[1] + m[3 * row + 2] * v[2];
}
std::array<double, 3> apply_matrix(const Mat3& m, const std::array<double, 3>& v);

// CIE 1931 2-degree colour-matching functions (x-bar, y-bar, z-bar) at a wavelength in nm, by the
// multi-lobe Gaussian fit of Wyman, Sloan and Shirley (JCGT 2013), within about 1% of the tabulated
// functions where they are not small.
std::array<double, 3> cie1931_xyz(double wavelength_nm);

}  // namespace lensfx::optics
