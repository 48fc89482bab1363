// The GPU hierarchy trace (llvmpipe in CI) against the dense CPU reference on the same layers and lens
// rays: a defocused point (size, energy), an in-focus edge before a blurred background (no halo), and the
// min-max pyramid's bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <dof/reference.h>
#include <dof/renderer.h>
#include <gpu/context.h>

#include "dof_scenes.h"

namespace lensfx::dof {
namespace {

constexpr int kSize = 80;

double relative_l1(const std::vector<float>& a, const std::vector<float>& b) {
    double d = 0, s = 0;
    for (std::size_t i = 0; i < a.size(); ++i) d += double{std::abs(a[i] - b[i])}, s += double{std::abs(b[i])};
    return d / s;
}

class DofGpu : public ::testing::Test {
protected:
    gpu::Context context{gpu::Platform::Auto};
    Renderer renderer;
};

TEST_F(DofGpu, DefocusedPointMatchesTheReference) {
    const Camera cam = test::camera_for("mld-double-gauss", 4.0, 1.0, 2.0, kSize, 20.0);
    const RayTable table = make_ray_table(cam, 512, 3);
    const LayerStack scene = test::point_scene(kSize, 2.0, kSize / 2, kSize / 2, 1000.0f);
    TraceSettings settings;
    settings.rays = table.samples;  // every pixel the reference's rays (from another start): the same sums
    const std::vector<float> gpu = renderer.render(scene, table, settings);
    const std::vector<float> ref = render_reference(scene, table);
    const test::Moments g = test::moments(gpu, kSize, kSize, 1), r = test::moments(ref, kSize, kSize, 1);
    const double expected_px = test::thin_lens_blur_mm(cam.system, 2.0, 1.0) / cam.pitch_mm();
    EXPECT_NEAR(test::disc_diameter(g) / test::disc_diameter(r), 1.0, 0.005) << "thin lens " << expected_px << " px";
    EXPECT_NEAR(g.sum / r.sum, 1.0, 0.002);
    EXPECT_LT(relative_l1(gpu, ref), 0.01) << "the hierarchy finds the surfaces the exact walk finds";
}

TEST_F(DofGpu, InFocusEdgeBeforeBlurredBackgroundMatchesTheReferenceWithoutHalo) {
    const Camera cam = test::camera_for("mld-double-gauss", 4.0, 1.0, 10.0, kSize, 16.0);
    const LayerStack layers = test::edge_scene(kSize);
    const RayTable table = make_ray_table(cam, 128, 5);
    TraceSettings settings;
    settings.rays = 32;
    const std::vector<float> gpu = renderer.render(layers, table, settings);
    const std::vector<float> ref = render_reference(layers, table);
    float worst = 0.0f;
    for (int y = 10; y < kSize - 10; ++y)
        for (int x = 0; x < kSize / 2 - 3; ++x) worst = std::max(worst, gpu[3 * static_cast<std::size_t>(y * kSize + x) + 1]);
    EXPECT_LE(worst, 0.1f);
    EXPECT_LT(relative_l1(gpu, ref), 0.05);
}

// The alpha a blurred foreground gets over nothing (flat RGBA + Z) equals the reference's.
TEST_F(DofGpu, BlurredAlphaMatchesTheReference) {
    const Camera cam = test::camera_for("mld-double-gauss", 4.0, 2.0, 0.5, kSize, 16.0);
    const RayTable table = make_ray_table(cam, 128, 5);
    const LayerStack scene = test::alpha_square_scene(kSize, 20, 60, 0.5);
    TraceSettings settings;
    settings.rays = table.samples;
    std::vector<float> gpu_alpha, ref_alpha;
    const std::vector<float> gpu = renderer.render(scene, table, settings, &gpu_alpha);
    const std::vector<float> ref = render_reference(scene, table, 0, 0, &ref_alpha);
    EXPECT_LT(relative_l1(gpu_alpha, ref_alpha), 0.01);
    EXPECT_LT(relative_l1(gpu, ref), 0.01);
    const float edge = gpu_alpha[static_cast<std::size_t>(kSize / 2 * kSize + 20)];
    EXPECT_GT(edge, 0.3f);
    EXPECT_LT(edge, 0.7f);
}

// A patterned square at 2 m in the middle of a black frame at infinity (flat), focus 1 m: a crop around
// it, traced with its origin in the table's raster, gives the whole raster's pixels (the stage traces only
// what its blur reaches), and the whole raster is black beyond the crop.
TEST_F(DofGpu, ACropTracedAtItsOriginGivesTheWholeRastersPixels) {
    constexpr int size = 128, lo = 56, hi = 72, crop_at = 32, crop = 64;
    const Camera cam = test::camera_for("mld-double-gauss", 4.0, 1.0, 2.0, size, 12.0);
    const RayTable table = make_ray_table(cam, 64, 5);
    const auto n = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
    std::vector<float> rgb(3 * n, 0.0f), depth(n, 0.0f);
    for (int y = lo; y < hi; ++y)
        for (int x = lo; x < hi; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(size) + static_cast<std::size_t>(x);
            depth[i] = 2.0f;
            for (std::size_t c = 0; c < 3; ++c) rgb[3 * i + c] = static_cast<float>(1 + (x * 7 + y * 3 + static_cast<int>(c)) % 5);
        }
    std::vector<float> part_rgb, part_depth;
    for (int y = crop_at; y < crop_at + crop; ++y)
        for (int x = crop_at; x < crop_at + crop; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(size) + static_cast<std::size_t>(x);
            part_depth.push_back(depth[i]);
            for (std::size_t c = 0; c < 3; ++c) part_rgb.push_back(rgb[3 * i + c]);
        }
    TraceSettings settings;
    settings.rays = 16;
    const std::vector<float> whole = renderer.render(layers_from_flat(rgb.data(), depth.data(), size, size), table, settings);
    settings.origin_x = settings.origin_y = crop_at;
    const std::vector<float> part = renderer.render(layers_from_flat(part_rgb.data(), part_depth.data(), crop, crop), table, settings);
    double inside = 0.0, beyond = 0.0, worst = 0.0;
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x)
            for (std::size_t c = 0; c < 3; ++c) {
                const float v = whole[3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(size) + static_cast<std::size_t>(x)) + c];
                const bool in_crop = x >= crop_at && x < crop_at + crop && y >= crop_at && y < crop_at + crop;
                if (!in_crop) {
                    beyond = std::max(beyond, double{std::abs(v)});
                    continue;
                }
                inside += double{v};
                const float u = part[3 * (static_cast<std::size_t>(y - crop_at) * crop + static_cast<std::size_t>(x - crop_at)) + c];
                worst = std::max(worst, double{std::abs(u - v)});
            }
    EXPECT_GT(inside, 100.0);  // the square, blurred, is in the crop
    EXPECT_EQ(beyond, 0.0);
    EXPECT_LT(worst, 1e-4);
}

// Chromatic passes only where the bands' blurs differ: a lens without dispersion (pbrt-dgauss-50, one
// index per glass) needs none anywhere and its chromatic render is green's; the Cooke triplet's
// dispersion keeps them, so its red and blue blurs differ (a white point: with green's rays they are one).
TEST_F(DofGpu, ChromaticPassesRunOnlyWhereTheBandsBlurDiffer) {
    const LayerStack scene = test::point_scene(kSize, 2.0, kSize / 2, kSize / 2, 1000.0f);
    const double w_near = 1.0001 / double{scene.nearest()}, w_far = 1.0 / double{scene.farthest()};
    TraceSettings chromatic, green;
    chromatic.rays = green.rays = 64;
    green.chromatic = false;
    const RayTable plain = make_ray_table(test::camera_for("pbrt-dgauss-50", 2.8, 1.0, 2.0, kSize, 20.0), 64, 3);
    const std::vector<float> one = achromatic_cells(plain, w_near, w_far, 0.0);
    EXPECT_EQ(std::count(one.begin(), one.end(), 1.0f), static_cast<std::ptrdiff_t>(one.size()));
    EXPECT_EQ(renderer.render(scene, plain, chromatic), renderer.render(scene, plain, green));

    const RayTable cooke = make_ray_table(test::camera_for("cooke-triplet", 5.6, 1.0, 2.0, kSize, 20.0), 64, 3);
    const std::vector<float> cells = achromatic_cells(cooke, w_near, w_far, chromatic.chroma_tolerance_px);
    EXPECT_EQ(std::count(cells.begin(), cells.end(), 1.0f), 0);
    const std::vector<float> rgb = renderer.render(scene, cooke, chromatic), g = renderer.render(scene, cooke, green);
    const double ratio = test::disc_diameter(test::moments(rgb, kSize, kSize, 0)) / test::disc_diameter(test::moments(rgb, kSize, kSize, 2));
    EXPECT_GT(std::abs(ratio - 1.0), 0.01);
    EXPECT_EQ(test::disc_diameter(test::moments(g, kSize, kSize, 0)), test::disc_diameter(test::moments(g, kSize, kSize, 2)));
}

TEST(DofPyramid, EveryLevelBoundsTheLayersBelowIt) {
    std::vector<float> rgb(3 * 13 * 7, 1.0f), depth(13 * 7);
    for (std::size_t i = 0; i < depth.size(); ++i) depth[i] = 1.0f + static_cast<float>((i * 7919) % 23);
    const LayerStack l = layers_from_flat(rgb.data(), depth.data(), 13, 7);
    int pw = 0, ph = 0;
    const auto levels = minmax_pyramid(l, pw, ph);
    ASSERT_EQ(pw, 16);
    ASSERT_EQ(ph, 8);
    ASSERT_EQ(levels.size(), 5u);
    EXPECT_FLOAT_EQ(levels.back()[0], 1.0f / l.farthest());
    EXPECT_FLOAT_EQ(levels.back()[1], 1.0f / l.nearest());
}

}  // namespace
}  // namespace lensfx::dof
