// The quality levels' passes (issue 5): RGB is three one-channel wavelengths; N spectral bands carry CIE
// 1931 weights in the working primaries that put a flat spectrum at 1 in every channel.
#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

#include <flare/flare.h>

namespace lensfx::flare {
namespace {

TEST(SpectralPasses, RgbModeIsThreeOneChannelWavelengths) {
    const FlareView view;
    const auto passes = view.passes();
    ASSERT_EQ(passes.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(passes[i].wavelength_nm, kRgbWavelengths_nm[i]);
        for (std::size_t c = 0; c < 3; ++c) EXPECT_EQ(passes[i].weight[c], c == i ? 1.0 : 0.0);
    }
}

TEST(SpectralPasses, BandsCoverTheSpectrumAndAFlatSpectrumIsWhite) {
    for (int bands : {7, 16, 40, 81}) {
        FlareView view;
        view.bands = bands;
        const auto passes = view.passes();
        ASSERT_EQ(passes.size(), static_cast<std::size_t>(bands));
        const double width = (kSpectrumLast_nm - kSpectrumFirst_nm) / bands;
        EXPECT_NEAR(passes.front().wavelength_nm, kSpectrumFirst_nm + width / 2, 1e-9);
        EXPECT_NEAR(passes.back().wavelength_nm, kSpectrumLast_nm - width / 2, 1e-9);
        std::array<double, 3> sum{};
        for (const SpectralPass& p : passes)
            for (std::size_t c = 0; c < 3; ++c) sum[c] += p.weight[c];
        for (double s : sum) EXPECT_NEAR(s, 1.0, 1e-12) << bands << " bands";
        // Red peaks at long wavelengths, blue at short ones, green between.
        std::array<double, 3> peak{};
        std::array<double, 3> best{};
        for (const SpectralPass& p : passes)
            for (std::size_t c = 0; c < 3; ++c)
                if (p.weight[c] > best[c]) best[c] = p.weight[c], peak[c] = p.wavelength_nm;
        EXPECT_GE(peak[0], 575.0);
        EXPECT_GT(peak[1], 500.0);
        EXPECT_LT(peak[1], 580.0);
        EXPECT_LT(peak[2], 480.0);
    }
}

TEST(SpectralPasses, WeightsFollowTheWorkingPrimaries) {
    // A wider gamut (here XYZ itself as the "RGB") has no negative lobes; Rec.709 has.
    FlareView rec709;
    rec709.bands = 40;
    FlareView xyz = rec709;
    xyz.xyz_to_rgb = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    double most_negative_709 = 0.0, most_negative_xyz = 0.0;
    for (const SpectralPass& p : rec709.passes())
        for (double w : p.weight) most_negative_709 = std::min(most_negative_709, w);
    for (const SpectralPass& p : xyz.passes())
        for (double w : p.weight) most_negative_xyz = std::min(most_negative_xyz, w);
    EXPECT_LT(most_negative_709, -0.005);
    EXPECT_EQ(most_negative_xyz, 0.0);
    // The Y channel's weights are the normalised y-bar at the band centres.
    const auto passes = xyz.passes();
    double total = 0.0;
    for (const SpectralPass& p : passes) total += optics::cie1931_xyz(p.wavelength_nm)[1];
    for (const SpectralPass& p : passes) EXPECT_NEAR(p.weight[1], optics::cie1931_xyz(p.wavelength_nm)[1] / total, 1e-12);
}

TEST(SpectralPasses, BadBandCountsAreRefused) {
    for (int bands : {-1, 1, 3, 6, 82}) {
        FlareView view;
        view.bands = bands;
        EXPECT_THROW(view.passes(), std::invalid_argument) << bands;
    }
    FlareView both;
    both.bands = 16;
    both.wavelength_nm = 550.0;
    EXPECT_THROW(both.passes(), std::invalid_argument);
}

}  // namespace
}  // namespace lensfx::flare
