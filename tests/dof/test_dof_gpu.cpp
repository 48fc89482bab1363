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
