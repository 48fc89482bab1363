// The diffraction starburst: energy, the Airy ring of a round iris, spikes across the blade edges, and
// its scale with the f-number.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include <optics/aperture.h>
#include <optics/starburst.h>

using namespace lensfx::optics;

namespace {

StarburstOptions small(double first_nm = 380.0, double last_nm = 780.0) {
    StarburstOptions o;
    o.size = 256;
    o.pupil_samples = 48;
    o.first_nm = first_nm;
    o.last_nm = last_nm;
    o.smoothing = 0.0;
    return o;
}

// Mean of channel c over a ring of the texture at radius r texels, angle in degrees (0 = +x, 90 = up).
double at_polar(const Starburst& s, double r, double angle_deg, int c) {
    const double a = angle_deg * std::numbers::pi / 180.0;
    const int x = static_cast<int>(std::lround(s.size / 2 + r * std::cos(a)));
    const int y = static_cast<int>(std::lround(s.size / 2 - r * std::sin(a)));
    return s.at(x, y, c);
}

}  // namespace

TEST(Starburst, EachChannelHoldsUnitFlux) {
    const Starburst s = make_starburst(Aperture{6, 0.0, 0.0}, small());
    for (double v : s.sums()) EXPECT_NEAR(v, 1.0, 1e-5);
    for (float v : s.rgb) ASSERT_TRUE(std::isfinite(v) && v >= 0.0f);
}

TEST(Starburst, RoundIrisShowsTheAiryMinimumAt1_22LambdaN) {
    const Starburst s = make_starburst(Aperture{0, 0.0, 0.0}, small(550.0, 550.0));
    // First zero of the Airy pattern: 1.22 lambda N on the sensor.
    const double expected = 1.22 * 550e-6 / s.texel_per_fnumber_mm;
    double best_r = 0.0, best = 1e300;
    for (double r = 0.5 * expected; r < 1.5 * expected; r += 0.05) {
        double ring = 0.0;
        for (int a = 0; a < 360; a += 5) ring += at_polar(s, r, a, 1);
        if (ring < best) best = ring, best_r = r;
    }
    EXPECT_NEAR(best_r, expected, 0.6) << "texels; one texel is " << s.texel_per_fnumber_mm * 1e3 << " um at f/1";
}

TEST(Starburst, SpikesRunAcrossTheBladeEdges) {
    // Six blades, first edge horizontal at the bottom: the edges' normals point at -90, -30, 30, 90... so
    // the spikes lie along those directions and not halfway between them.
    const Starburst s = make_starburst(Aperture{6, 0.0, 0.0}, small());
    const double r = s.size * 0.3;
    for (double spike : {90.0, 30.0, -30.0}) {
        const double on = at_polar(s, r, spike, 1);
        const double off = at_polar(s, r, spike + 15.0, 1);
        EXPECT_GT(on, 20.0 * off) << "spike at " << spike << " degrees";
    }
}

TEST(Starburst, PointSymmetric) {
    const Starburst s = make_starburst(Aperture{5, 12.0, 0.3}, small());
    const int n = s.size;
    double diff = 0.0, total = 0.0;
    for (int y = 1; y < n; ++y)
        for (int x = 1; x < n; ++x) {
            diff += static_cast<double>(std::abs(s.at(x, y, 1) - s.at(n - x, n - y, 1)));
            total += static_cast<double>(s.at(x, y, 1));
        }
    EXPECT_LT(diff / total, 1e-3);
}

TEST(Starburst, SplatKeepsEnergyAndGrowsWithTheFNumber) {
    const Starburst s = make_starburst(Aperture{6, 0.0, 0.0}, small());
    const int w = 200, h = 200;
    const double pixel = 0.002;  // mm: texels are larger than pixels at f/16, smaller at f/2
    for (double n : {2.0, 16.0}) {
        std::vector<float> img(static_cast<std::size_t>(w * h * 3), 0.0f);
        splat_starburst(s, {100.3, 99.7, n}, {2.0, 1.0, 0.5}, {img.data(), w, h, pixel, pixel});
        std::array<double, 3> sum{};
        double spread = 0.0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                for (int c = 0; c < 3; ++c) {
                    const double v = img[static_cast<std::size_t>((y * w + x) * 3 + c)];
                    sum[static_cast<std::size_t>(c)] += v * pixel * pixel;
                    if (c == 1) spread += v * std::hypot(x + 0.5 - 100.3, y + 0.5 - 99.7);
                }
        EXPECT_NEAR(sum[0], 2.0, 0.02 * 2.0) << "f/" << n;
        EXPECT_NEAR(sum[1], 1.0, 0.02) << "f/" << n;
        EXPECT_NEAR(sum[2], 0.5, 0.02 * 0.5) << "f/" << n;
        if (n == 16.0) {
            // mean radius of the pattern in pixels against the texture's own, scaled by the f-number
            double tex_spread = 0.0;
            for (int y = 0; y < s.size; ++y)
                for (int x = 0; x < s.size; ++x)
                    tex_spread += static_cast<double>(s.at(x, y, 1)) * std::hypot(x - s.size / 2, y - s.size / 2);
            const double expected = tex_spread * s.texel_per_fnumber_mm * n / pixel;
            EXPECT_NEAR(spread / sum[1] * pixel * pixel, expected, 0.1 * expected);
        }
    }
}

TEST(Starburst, CoreLeftOutHoldsMostOfTheEnergy) {
    // A round iris at one wavelength: inside the second dark ring lies about 91% of the Airy pattern.
    const Starburst s = make_starburst(Aperture{0, 0.0, 0.0}, small(550.0, 550.0));
    const int w = 64, h = 64;
    std::vector<float> img(static_cast<std::size_t>(w * h * 3), 0.0f);
    const double pixel = s.texel_per_fnumber_mm * 8.0 * 20.0;  // texels much smaller than pixels at f/8
    splat_starburst(s, {32.0, 32.0, 8.0, starburst_core_radius_texels(s)}, {1.0, 1.0, 1.0}, {img.data(), w, h, pixel, pixel});
    double sum = 0.0;
    for (std::size_t i = 1; i < img.size(); i += 3) sum += static_cast<double>(img[i]) * pixel * pixel;
    EXPECT_GT(sum, 0.05);
    EXPECT_LT(sum, 0.13);
}

TEST(Starburst, SmallTexelSplatMatchesEachTexelBilinearlyAtTheFramesCorner) {
    // Texels smaller than pixels (f/4), the light near the top-left corner so part of the pattern is cut
    // off, a core left out: the row-by-row splat against each texel shared bilinearly on its own.
    const Starburst s = make_starburst(Aperture{6, 0.0, 0.0}, small());
    const int w = 40, h = 30;
    const double f_number = 4.0, pixel = s.texel_per_fnumber_mm * f_number * 7.3, core = 9.0;
    const std::array<double, 3> power{2.0, 1.0, 0.5};
    const double cx = 4.3, cy = 6.8;
    std::vector<float> img(static_cast<std::size_t>(w * h * 3), 0.0f);
    splat_starburst(s, {cx, cy, f_number, core}, power, {img.data(), w, h, pixel, pixel});
    std::vector<double> ref(img.size(), 0.0);
    const double t = 1.0 / 7.3, half = s.size / 2;
    for (int j = 0; j < s.size; ++j)
        for (int i = 0; i < s.size; ++i) {
            if (std::hypot(i - half, j - half) < core) continue;
            const double px = cx + (i - half) * t - 0.5, py = cy + (j - half) * t - 0.5;
            const int x0 = static_cast<int>(std::floor(px)), y0 = static_cast<int>(std::floor(py));
            for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx) {
                    const int x = x0 + dx, y = y0 + dy;
                    if (x < 0 || y < 0 || x >= w || y >= h) continue;
                    const double wt = (dx ? px - x0 : 1.0 - (px - x0)) * (dy ? py - y0 : 1.0 - (py - y0));
                    for (int c = 0; c < 3; ++c)
                        ref[static_cast<std::size_t>((y * w + x) * 3 + c)] +=
                            wt * power[static_cast<std::size_t>(c)] / (pixel * pixel) * static_cast<double>(s.at(i, j, c));
                }
        }
    double peak = 0.0, sum = 0.0, ref_sum = 0.0;
    for (double v : ref) peak = std::max(peak, v);
    ASSERT_GT(peak, 0.0);
    for (std::size_t k = 0; k < img.size(); ++k) {
        EXPECT_NEAR(img[k], ref[k], 1e-5 * peak) << "pixel " << k / 3 % w << "," << k / 3 / w;
        sum += static_cast<double>(img[k]);
        ref_sum += ref[k];
    }
    EXPECT_NEAR(sum, ref_sum, 1e-5 * ref_sum);
    EXPECT_LT(ref_sum * pixel * pixel, 0.9 * (power[0] + power[1] + power[2])) << "part of it is cut off";
}
