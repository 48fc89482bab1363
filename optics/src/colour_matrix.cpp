// Colour matrices and the CIE 1931 colour-matching functions (optics/colour_matrix.h).
#include <optics/colour_matrix.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace lensfx::optics {

Mat3 multiply(const Mat3& a, const Mat3& b) {
    Mat3 r{};
    for (std::size_t i = 0; i < 3; ++i)
        for (std::size_t j = 0; j < 3; ++j)
            for (std::size_t k = 0; k < 3; ++k) r[3 * i + j] += a[3 * i + k] * b[3 * k + j];
    return r;
}

Mat3 inverse(const Mat3& m) {
    const double c00 = m[4] * m[8] - m[5] * m[7];
    const double c01 = m[5] * m[6] - m[3] * m[8];
    const double c02 = m[3] * m[7] - m[4] * m[6];
    const double det = m[0] * c00 + m[1] * c01 + m[2] * c02;
    double scale = 0.0;
    for (double v : m) scale = std::max(scale, std::abs(v));
    if (!(std::abs(det) > 1e-12 * scale * scale * scale))
        throw std::invalid_argument("colour: singular 3x3 matrix (degenerate primaries?)");
    const double s = 1.0 / det;
    return {c00 * s, (m[2] * m[7] - m[1] * m[8]) * s, (m[1] * m[5] - m[2] * m[4]) * s,
            c01 * s, (m[0] * m[8] - m[2] * m[6]) * s, (m[2] * m[3] - m[0] * m[5]) * s,
            c02 * s, (m[1] * m[6] - m[0] * m[7]) * s, (m[0] * m[4] - m[1] * m[3]) * s};
}

std::array<double, 3> apply_matrix(const Mat3& m, const std::array<double, 3>& v) {
    return {row_times(m, 0, v), row_times(m, 1, v), row_times(m, 2, v)};
}

namespace {

double lobe(double x, double mu, double sigma_left, double sigma_right) {
    const double t = (x - mu) / (x < mu ? sigma_left : sigma_right);
    return std::exp(-0.5 * t * t);
}

}  // namespace

std::array<double, 3> cie1931_xyz(double l) {
    const double x = 1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7) -
                     0.065 * lobe(l, 501.1, 20.4, 26.2);
    const double y = 0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1);
    const double z = 1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8);
    return {x, y, z};
}

}  // namespace lensfx::optics
