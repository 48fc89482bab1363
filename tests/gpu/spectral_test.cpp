// Spectral quality (issue 5) on the GPU against the dense CPU reference, and the convergence of the band
// count: 16 bands on the GPU against the reference, 16 against 40 bands, and RGB against 40 bands
// (printed: three wavelengths sample the coatings' reflectance at one point per channel, the bands weigh
// it over each colour-matching function, so RGB's power per channel is off while the shapes agree).
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <vector>

#include <fmt/core.h>
#include <unistd.h>
#include <gtest/gtest.h>

#include <gpu/band_filter.h>
#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace lensfx::gpu {
namespace {

using namespace lensfx::flare;  // the view, the reference and the comparisons the GPU image is held to

FlareView test_view(int bands) {
    FlareView view;
    view.angle_x_deg = 8.0;
    view.angle_y_deg = 5.0;
    view.width = 180;
    view.height = 120;
    view.bands = bands;
    // The three brightest ghosts of the Cooke triplet at this angle (surfaces 1-7, 2-3, 4-7): a third of the
    // flare at a fifth of the cost.
    view.only_ghosts = {{0, 6}, {1, 2}, {3, 6}};
    return view;
}

// Largest over channels of sum |a - b| / sum |b| (b the finer or reference image).
double relative_l1(const FlareImage& a, const FlareImage& b) {
    double worst = 0.0;
    for (std::size_t c = 0; c < 3; ++c) {
        double diff = 0.0, total = 0.0;
        for (std::size_t i = c; i < a.rgb.size(); i += 3) {
            diff += std::abs(static_cast<double>(a.rgb[i]) - static_cast<double>(b.rgb[i]));
            total += std::abs(static_cast<double>(b.rgb[i]));
        }
        worst = std::max(worst, diff / total);
    }
    return worst;
}

// relative_l1 of the images each scaled to the other's channel totals: where the light lands, not how much.
double shape_l1(const FlareImage& a, const FlareImage& b, const FlareView& view) {
    FlareImage scaled = a;
    const auto pa = a.total_power(view), pb = b.total_power(view);
    for (std::size_t i = 0; i < scaled.rgb.size(); ++i)
        scaled.rgb[i] = static_cast<float>(static_cast<double>(scaled.rgb[i]) * (pb[i % 3] / pa[i % 3]));
    return relative_l1(scaled, b);
}

// Largest over channels of |total power - reference's| / reference's.
double power_error(const FlareImage& a, const FlareImage& b, const FlareView& view) {
    const auto pa = a.total_power(view), pb = b.total_power(view);
    double worst = 0.0;
    for (std::size_t c = 0; c < 3; ++c) worst = std::max(worst, std::abs(pa[c] - pb[c]) / std::abs(pb[c]));
    return worst;
}

class Spectral : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        context_ = new Context(Platform::Surfaceless);
        renderer_ = new FlareRenderer(*context_);
    }
    static void TearDownTestSuite() {
        delete renderer_;
        delete context_;
    }
    // A fixed 96 x 96 grid per ghost and band: the spectral comparisons see the bands, not the
    // accelerations' per-image choices (reduced resolution, adaptive grids).
    static GpuFlareOptions fixed_grid() {
        GpuFlareOptions options;
        options.grid = 96;
        options.accel.adaptive = false;
        options.accel.reduced = false;
        options.accel.lod = false;
        return options;
    }
    static FlareImage gpu(const System& system, const FlareView& view) { return renderer_->render(system, view, fixed_grid()); }
    static Context* context_;
    static FlareRenderer* renderer_;
};
Context* Spectral::context_ = nullptr;
FlareRenderer* Spectral::renderer_ = nullptr;

TEST_F(Spectral, BandsOnTheGpuMatchTheReference) {
    const System system = optics::realize(optics::load_lens("cooke-triplet"));
    const FlareView view = test_view(16);
    const FlareImage image = gpu(system, view);
    ReferenceOptions options;
    options.rays = 192;
    options.per_ghost_power = false;
    const FlareImage reference = render_reference(system, view, options);
    const FlareError e = compare_flare(image, reference, view);
    fmt::print("16 bands, GPU vs reference: total power {:.4f}, 8x8 block L1 {:.4f}\n", e.total, e.block_l1);
    EXPECT_LT(e.total, 0.02);
    EXPECT_LT(e.block_l1, 0.10);
    for (float v : image.rgb) ASSERT_TRUE(std::isfinite(v));
}

TEST_F(Spectral, BandCountConvergesAndRgbIsACoarseSample) {
    const System system = optics::realize(optics::load_lens("cooke-triplet"));
    const FlareImage rgb = gpu(system, test_view(0));
    const FlareImage b16 = gpu(system, test_view(16));
    const FlareImage b40 = gpu(system, test_view(40));
    const FlareView view = test_view(40);
    const double l1_16 = relative_l1(b16, b40), l1_rgb = relative_l1(rgb, b40);
    const double p16 = power_error(b16, b40, view), prgb = power_error(rgb, b40, view);
    fmt::print("against 40 bands: 16 bands L1 {:.4f} power {:.4f} shape L1 {:.4f}; RGB L1 {:.4f} power {:.4f} shape L1 {:.4f}\n",
               l1_16, p16, shape_l1(b16, b40, view), l1_rgb, prgb, shape_l1(rgb, b40, view));
    EXPECT_LT(p16, 0.02);
    EXPECT_LT(l1_16, 0.10);
    EXPECT_LT(l1_16, l1_rgb);
}

// The band filter (paper section 4.2) smears the separate coloured copies of each ghost that 7 bands leave
// into one, keeping the power and staying close to the 40-band image. It does not
// bring 7 bands closer to 40 pixel by pixel (measured and printed), likely because a ghost also changes
// size and shape between bands, which a 1D smear along its centroid's path does not model.
TEST_F(Spectral, BandFilterSmearsTheBandCopiesAndKeepsThePower) {
    const System system = optics::realize(optics::load_lens("cooke-triplet"));
    const FlareImage b40 = gpu(system, test_view(40));
    const FlareView view = test_view(7);
    const FlareImage plain = gpu(system, view);
    const FlareImage filtered = render_band_filtered(system, view, render_one_on(*renderer_, system, fixed_grid()));
    const double l1_plain = shape_l1(plain, b40, view), l1_filtered = shape_l1(filtered, b40, view);
    fmt::print("7 bands against 40: L1 {:.4f} plain, {:.4f} band-filtered; shape L1 {:.4f} plain, {:.4f} band-filtered; "
               "power {:.4f} vs {:.4f}\n", relative_l1(plain, b40), relative_l1(filtered, b40), l1_plain, l1_filtered,
               power_error(plain, b40, view), power_error(filtered, b40, view));
    const double e_plain = plain.edge_measure(), e_filtered = filtered.edge_measure(), e_40 = b40.edge_measure();
    fmt::print("edge content (total variation / total): 7 bands {:.4f}, band-filtered {:.4f}, 40 bands {:.4f}\n", e_plain,
               e_filtered, e_40);
    // Measured with the splatted rasteriser: 7 bands already hold the 40 bands' edge content (0.0996 vs
    // 0.0993) and the filter smooths below it (0.0940), so it is no gain here; it must only stay close.
    EXPECT_LT(std::abs(e_filtered - e_40), 0.1 * e_40);
    EXPECT_LT(l1_filtered, 2.0 * l1_plain);
    EXPECT_LT(power_error(filtered, plain, view), 0.01);  // the filter moves energy, it does not make or lose it
}

// Every render of the band filter keeps the view's whole ghost list and draws one ghost of it, so a band's
// renders share one bounds table: one cache file per band, not one per ghost and band (a zoom lens's 528
// ghosts at 7 bands wrote 3,696 files and did not finish), and the image is that of the ghosts drawn alone.
TEST_F(Spectral, BandFilterKeepsOneBoundsTablePerBand) {
    const System system = optics::realize(optics::load_lens("cooke-triplet"));
    const auto dir = std::filesystem::temp_directory_path() / fmt::format("lensfx-band-filter-{}", static_cast<long long>(::getpid()));
    std::filesystem::remove_all(dir);
    GpuFlareOptions options = fixed_grid();
    options.accel.cache_dir = dir.string();
    FlareView whole_lens = test_view(7);
    const std::vector<std::pair<int, int>> drawn = whole_lens.only_ghosts;
    whole_lens.only_ghosts.clear();
    const FlareImage shared = render_band_filtered(system, whole_lens, render_one_on(*renderer_, system, options), drawn);
    std::size_t files = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) files += entry.path().filename().string().starts_with("bounds-");
    EXPECT_EQ(files, 7u);
    ASSERT_EQ(shared.ghosts.size(), drawn.size());

    options.accel.cache_dir = "none";
    const FlareImage alone = render_band_filtered(system, test_view(7), render_one_on(*renderer_, system, options));
    EXPECT_LT(relative_l1(shared, alone), 1e-5);
    std::filesystem::remove_all(dir);
}

// A zoom lens's 528 ghosts at 7 bands: the brightest (at most 32) rendered one ghost and band at a time, the
// rest together once per band, so the renders stay a few hundred (3,696 one by one did not finish in 4
// minutes on a 1080p frame), and every ghost is drawn exactly once per band.
TEST(BandFilter, FaintGhostsShareOneRenderPerBand) {
    const System system = optics::realize(optics::load_lens("canon-70-200"));
    FlareView view = test_view(7);
    view.only_ghosts.clear();
    std::size_t renders = 0;
    std::map<std::pair<double, std::pair<int, int>>, int> drawn;  // (wavelength, ghost) -> times
    const FlareImage image = render_band_filtered(system, view, [&](const FlareView& band, const std::vector<std::pair<int, int>>& ghosts) {
        ++renders;
        for (const auto& g : ghosts) ++drawn[{*band.wavelength_nm, g}];
        FlareImage one;
        one.width = band.width;
        one.height = band.height;
        one.rgb.assign(static_cast<std::size_t>(one.width) * static_cast<std::size_t>(one.height) * 3, 0.0f);
        one.rgb[(static_cast<std::size_t>(band.height / 2) * static_cast<std::size_t>(band.width) + static_cast<std::size_t>(band.width / 2)) * 3] = 1.0f;
        return one;
    });
    const std::size_t ghosts = selected_ghosts(system, view).size();
    EXPECT_EQ(ghosts, 528u);
    EXPECT_LE(renders, 7u * 33u);
    EXPECT_EQ(drawn.size(), 7u * ghosts);
    for (const auto& [key, times] : drawn) EXPECT_EQ(times, 1);
    EXPECT_EQ(image.width, view.width);
}

}  // namespace
}  // namespace lensfx::gpu
