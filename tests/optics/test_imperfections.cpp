// Dust, scratches and image apertures (flare paper section 5): how much light the dirt blocks, which way
// scratches streak the starburst, an image of a disc behaving as the round iris, and determinism.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <optics/imperfections.h>
#include <optics/starburst.h>

using namespace lensfx::optics;

namespace {

StarburstOptions small() {
    StarburstOptions o;
    o.size = 256;
    o.pupil_samples = 48;
    o.first_nm = 550.0;
    o.last_nm = 550.0;
    o.smoothing = 0.0;
    return o;
}

// Energy of channel 1 in a thin band through the centre along x (horizontal) or y, beyond radius r0.
double band(const Starburst& s, bool horizontal, int r0) {
    double e = 0.0;
    const int c = s.size / 2;
    for (int k = r0; k < s.size / 3; ++k)
        for (int w = -1; w <= 1; ++w)
            for (int sign : {-1, 1})
                e += static_cast<double>(horizontal ? s.at(c + sign * k, c + w, 1) : s.at(c + w, c + sign * k, 1));
    return e;
}

}  // namespace

TEST(Imperfections, DustBlocksTheExpectedShareOfThePupil) {
    const int m = 1024, r = 400;
    std::vector<double> t(static_cast<std::size_t>(m) * m, 1.0);
    PupilImperfections dust;
    dust.dust_density = 300.0;
    dust.dust_radius = 0.01;
    apply_imperfections(dust, m, r, t.data());
    double clear = 0.0, count = 0.0;
    for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x) {
            const double u = double(x - m / 2) / r, v = double(m / 2 - y) / r;
            if (u * u + v * v > 0.9 * 0.9) continue;  // specks centred near the rim cover partly outside
            clear += t[static_cast<std::size_t>(y) * m + x];
            count += 1.0;
        }
    // Poisson specks of radius r0 2^U, U uniform on [-1, 1]: E[area] = pi r0^2 (4 - 1/4) / (2 ln 4).
    const double mean_area = std::numbers::pi * 0.01 * 0.01 * 3.75 / (2.0 * std::log(4.0));
    const double expected = std::exp(-dust.dust_density * mean_area);
    EXPECT_NEAR(clear / count, expected, 0.25 * (1.0 - expected));
    EXPECT_LT(clear / count, 0.995);
    RecordProperty("blocked", std::to_string(1.0 - clear / count));
    RecordProperty("predicted", std::to_string(1.0 - expected));
}

TEST(Imperfections, HorizontalScratchesStreakTheStarburstVertically) {
    StarburstOptions o = small();
    const Starburst clean = make_starburst(Aperture{0, 0.0, 0.0}, o);
    o.dirt.scratches = 40;
    o.dirt.scratch_length = 0.8;
    o.dirt.scratch_width = 0.02;
    o.dirt.scratch_angle_deg = 0.0;
    o.dirt.scratch_spread_deg = 0.0;
    const Starburst scratched = make_starburst(Aperture{0, 0.0, 0.0}, o);
    // A round iris spreads its rings evenly; horizontal lines diffract light along the vertical.
    const double clean_ratio = band(clean, false, 20) / band(clean, true, 20);
    const double scratched_ratio = band(scratched, false, 20) / band(scratched, true, 20);
    EXPECT_NEAR(clean_ratio, 1.0, 0.05);
    EXPECT_GT(scratched_ratio, 1.5 * clean_ratio);
    EXPECT_NEAR(scratched.sums()[1], 1.0, 1e-5);
    RecordProperty("clean_ratio", std::to_string(clean_ratio));
    RecordProperty("scratched_ratio", std::to_string(scratched_ratio));
}

TEST(Imperfections, AnImageOfADiscActsAsTheRoundIris) {
    StarburstOptions o = small();
    const Starburst round = make_starburst(Aperture{0, 0.0, 0.0}, o);
    const int n = 512;
    o.image.width = o.image.height = n;
    o.image.value.resize(static_cast<std::size_t>(n) * n);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const double u = 2.0 * (x + 0.5) / n - 1.0, v = 1.0 - 2.0 * (y + 0.5) / n;
            const double edge = (1.0 - std::hypot(u, v)) * n / 2.0;  // pixels inside the rim
            o.image.value[static_cast<std::size_t>(y) * n + x] = static_cast<float>(std::clamp(edge + 0.5, 0.0, 1.0));
        }
    const Starburst image = make_starburst(Aperture{6, 0.0, 0.0}, o);  // the image wins over the blades
    double diff = 0.0, total = 0.0;
    for (std::size_t i = 0; i < round.rgb.size(); ++i) {
        diff += std::abs(double(round.rgb[i]) - double(image.rgb[i]));
        total += double(round.rgb[i]);
    }
    EXPECT_LT(diff / total, 0.03);
}

TEST(Imperfections, TheSameSeedGivesTheSameDirt) {
    StarburstOptions o = small();
    o.dirt.dust_density = 200.0;
    o.dirt.scratches = 5;
    const Starburst a = make_starburst(Aperture{7, 0.0, 0.0}, o);
    const Starburst b = make_starburst(Aperture{7, 0.0, 0.0}, o);
    EXPECT_EQ(a.rgb, b.rgb);
    o.dirt.seed = 2;
    const Starburst c = make_starburst(Aperture{7, 0.0, 0.0}, o);
    EXPECT_NE(a.rgb, c.rgb);
}

TEST(Imperfections, AbsurdStatisticsAreRefused) {
    std::vector<double> t(64 * 64, 1.0);
    PupilImperfections d;
    d.dust_density = -1.0;
    EXPECT_THROW(apply_imperfections(d, 64, 16, t.data()), std::invalid_argument);
    d = {};
    d.scratches = 3;
    d.scratch_width = std::nan("");
    EXPECT_THROW(apply_imperfections(d, 64, 16, t.data()), std::invalid_argument);
    d = {};
    d.dust_density = 10.0;
    d.dust_opacity = 2.0;
    EXPECT_THROW(apply_imperfections(d, 64, 16, t.data()), std::invalid_argument);
}
