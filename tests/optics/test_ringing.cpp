// Ghost ringing by the fractional Fourier transform (flare paper eq. 5): the order's formula, order 0 as
// the identity, kept energy, fringes at the edge, and the square iris against a direct evaluation of
// the FrFT integral (separable, so one row is the 1-D transform of a slit).
#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <optics/ringing.h>

using namespace lensfx::optics;

namespace {

constexpr int kN = 256;
constexpr double kExtent = 1.25;

double sum(const std::vector<float>& v) {
    double s = 0.0;
    for (float x : v) s += static_cast<double>(x);
    return s;
}

// |FrFT_phi(slit of half-width a)|^2 at x, by direct quadrature of the kernel, coordinates in units s.
double slit_frft(double a, double x, double phi, double s) {
    const int steps = 40000;
    const double cot = 1.0 / std::tan(phi), csc = 1.0 / std::sin(phi);
    std::complex<double> acc = 0.0;
    const double du = 2.0 * a / steps;
    for (int k = 0; k < steps; ++k) {
        const double u = (-a + (k + 0.5) * du) / s;
        const double v = x / s;
        acc += std::polar(1.0, std::numbers::pi * (cot * u * u - 2.0 * csc * v * u));
    }
    return std::norm(acc * du);
}

}  // namespace

TEST(Ringing, OrderFollowsEquation5) {
    EXPECT_DOUBLE_EQ(ringing_order(400.0, 18.0), 0.15);
    EXPECT_NEAR(ringing_order(650.0, 8.0), 0.15 * 1.625 * 8.0 / 18.0, 1e-15);
    EXPECT_GT(ringing_order(650.0, 8.0), ringing_order(450.0, 8.0));
    EXPECT_GT(ringing_order(550.0, 16.0), ringing_order(550.0, 4.0));
}

TEST(Ringing, OrderZeroIsTheIrisItself) {
    const std::vector<float> zero = ringing_aperture(Aperture{6, 0.0, 0.0}, kN, kExtent, 0.0);
    const int c = kN / 2;
    EXPECT_FLOAT_EQ(zero[static_cast<std::size_t>(c) * kN + c], 1.0f);
    EXPECT_FLOAT_EQ(zero[0], 0.0f);
    // Area of the hexagon inscribed in the unit circle, 3 sqrt(3) / 2, less a little at the edge where the
    // intensity is the antialiased transmission squared.
    const double texel = 2.0 * kExtent / kN;
    EXPECT_NEAR(sum(zero) * texel * texel, 1.5 * std::sqrt(3.0), 0.01);
}

TEST(Ringing, EnergyIsKeptAndFringesAppearAtTheEdge) {
    const std::vector<float> plain = ringing_aperture(Aperture{0, 0.0, 0.0}, kN, kExtent, 0.0);
    for (double alpha : {0.05, 0.15, 0.3}) {
        const std::vector<float> ring = ringing_aperture(Aperture{0, 0.0, 0.0}, kN, kExtent, alpha);
        EXPECT_NEAR(sum(ring) / sum(plain), 1.0, 0.01) << "alpha " << alpha;
        // Along the +x radius: Fresnel edge diffraction overshoots inside the edge and oscillates.
        const int c = kN / 2;
        float peak = 0.0f;
        int extrema = 0;
        for (int i = c; i < kN - 1; ++i) {
            const float a = ring[static_cast<std::size_t>(c) * kN + i - 1];
            const float b = ring[static_cast<std::size_t>(c) * kN + i];
            const float d = ring[static_cast<std::size_t>(c) * kN + i + 1];
            peak = std::max(peak, b);
            if (b > 0.05f && ((b > a && b > d) || (b < a && b < d))) ++extrema;
        }
        EXPECT_GT(peak, 1.1f) << "alpha " << alpha;
        EXPECT_GE(extrema, 4) << "alpha " << alpha;
        for (float v : ring) ASSERT_TRUE(std::isfinite(v) && v >= 0.0f);
    }
}

TEST(Ringing, SquareIrisMatchesTheDirectFrftIntegral) {
    // Four blades, the first edge horizontal: an axis-aligned square of half-side cos 45 degrees.
    const double alpha = 0.15, phi = alpha * std::numbers::pi / 2.0;
    const std::vector<float> ring = ringing_aperture(Aperture{4, 0.0, 0.0}, kN, kExtent, alpha);
    const double h = 2.0 * kExtent / kN, s = 2.0 * kExtent / std::sqrt(double(kN)), a = std::sqrt(0.5);
    // Row through the centre (texel centres at +-h/2 about the axis): I(x) I(y0), y0 = h / 2.
    const int row = kN / 2;
    const double y0 = -0.5 * h;
    double diff = 0.0, total = 0.0;
    for (int i = 0; i < kN; ++i) {
        const double x = (i - kN / 2 + 0.5) * h;
        // The texture is the FrFT at the input's scale: cos^2(phi) |F(x cos phi)|^2 |F(y cos phi)|^2.
        const double c = std::cos(phi);
        const double expected =
            c * c * slit_frft(a, x * c, phi, s) * slit_frft(a, y0 * c, phi, s) / std::pow(s * s * std::sin(phi), 2);
        diff += std::abs(static_cast<double>(ring[static_cast<std::size_t>(row) * kN + i]) - expected);
        total += expected;
    }
    RecordProperty("relative_l1", std::to_string(diff / total));
    EXPECT_LT(diff / total, 0.05);
}

TEST(Ringing, AbsurdArgumentsAreRefused) {
    EXPECT_THROW(ringing_aperture(Aperture{}, 4, 1.25, 0.1), std::invalid_argument);
    EXPECT_THROW(ringing_aperture(Aperture{}, 64, 1.25, 0.7), std::invalid_argument);
    EXPECT_THROW(ringing_aperture(Aperture{}, 64, 1.25, std::nan("")), std::invalid_argument);
    EXPECT_THROW(fractional_ringing(std::vector<double>(10, 1.0), 64, 1.25, 0.1), std::invalid_argument);
}
