// The GPU hierarchy trace (llvmpipe in CI) against the dense CPU reference on the same layers and lens
// rays: a defocused point (size, energy), an in-focus edge before a blurred background (no halo), and the
// min-max pyramid's bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include <dof/reference.h>
#include <dof/renderer.h>
#include <gpu/context.h>
#include <optics/lens_file.h>
#include <optics/system.h>

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

// Ground receding from 1.5 m to 40 m under a sky at infinity, with a checker, and a bar at 1 m before it
// all (bench_dof's synthetic scene, without its bright spots so that one ray more or less is a small
// difference): rays through the blurred bar and along the ground cross many cells, so traces are long.
LayerStack bar_over_ground_scene(int w, int h) {
    const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
    std::vector<float> rgb(3 * n), depth(n);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
            const double v = static_cast<double>(y) / h;
            const bool ground = v > 0.4, bar = x > w / 5 && x < w / 3;
            const float checker = ((x / 6 + y / 6) % 2) ? 0.8f : 0.3f;
            depth[i] = bar ? 1.0f : ground ? static_cast<float>(std::min(40.0, 1.5 / std::pow((v - 0.4) / 0.6, 1.5))) : 0.0f;
            const std::array<float, 3> c = bar      ? std::array<float, 3>{0.2f, 0.1f, 0.1f}
                                         : ground ? std::array<float, 3>{checker, 0.9f * checker, 0.6f * checker}
                                                  : std::array<float, 3>{0.6f, 0.7f, 0.9f};
            for (std::size_t k = 0; k < 3; ++k) rgb[3 * i + k] = c[k];
        }
    return layers_from_flat(rgb.data(), depth.data(), w, h);
}

// mld-double-gauss f/2.8 focused at 3 m over a w x h crop of a full-frame sensor 1024 px wide (bench_dof's).
Camera bench_camera(int w, int h) {
    Camera cam;
    cam.system = optics::realize(optics::load_lens("mld-double-gauss"), 0.0, 2.8);
    cam.focus_m = 3.0;
    cam.width = w, cam.height = h;
    cam.centre_x = 0.5 * w, cam.centre_y = 0.5 * h;
    cam.sensor_width_mm = 36.0 * w / 1024.0;
    return cam;
}

// The largest error of any channel at any pixel, relative to the reference's value there plus `floor`.
double worst_channel_error(const std::vector<float>& gpu, const std::vector<float>& ref, double floor) {
    double worst = 0.0;
    for (std::size_t i = 0; i < gpu.size(); ++i) worst = std::max(worst, std::abs(double{gpu[i]} - double{ref[i]}) / (double{ref[i]} + floor));
    return worst;
}

// Every band of every pixel against the reference's same rays where traces run long. llvmpipe gives each
// invocation one count of loop iterations shared by every loop; tracing every band's 256 rays in one
// invocation spent it, and some pixels lost their later bands (one band 0, or its first few rays standing
// for it, up to 4x too bright): relative L1 0.046, a channel 88 % off.
TEST_F(DofGpu, EveryBandMatchesTheReferenceWhereTheTraceRunsLong) {
    constexpr int w = 96, h = 48;
    const LayerStack scene = bar_over_ground_scene(w, h);
    const RayTable table = make_ray_table(bench_camera(w, h), 256, 9);
    TraceSettings settings;
    settings.rays = table.samples;
    const std::vector<float> gpu = renderer.render(scene, table, settings), ref = render_reference(scene, table);
    EXPECT_LT(relative_l1(gpu, ref), 0.003);
    EXPECT_LT(worst_channel_error(gpu, ref, 0.1), 0.15);
}

// A chunk of rays that still runs out of the loop budget (here a band's 512 rays in one dispatch, over the
// blurred bar's edge) is noticed and traced again ray by ray there: the same image as in chunks that fit.
TEST_F(DofGpu, AChunkThatRunsOutOfLoopBudgetIsTracedAgain) {
    constexpr int w = 96, h = 48, crop = 24, at = 12;
    const RayTable table = make_ray_table(bench_camera(w, h), 512, 9);
    const LayerStack whole = bar_over_ground_scene(w, h);
    LayerStack scene;  // the crop of the bar's edge, its pixel (0, 0) at (at, at) of the table's raster
    scene.resize(crop, crop, whole.count);
    for (int k = 0; k < whole.count; ++k)
        for (int y = 0; y < crop; ++y)
            for (int x = 0; x < crop; ++x) {
                const std::size_t i = scene.at(k, x, y), j = whole.at(k, x + at, y + at);
                scene.front[i] = whole.front[j], scene.back[i] = whole.back[j];
                for (std::size_t c = 0; c < 4; ++c) scene.rgba[4 * i + c] = whole.rgba[4 * j + c];
            }
    TraceSettings settings;
    settings.rays = table.samples;
    settings.origin_x = settings.origin_y = at;
    const std::vector<float> chunked = renderer.render(scene, table, settings);
    settings.rays_per_dispatch = table.samples;
    const std::vector<float> one_dispatch = renderer.render(scene, table, settings);
    if (context.info().software) {
        EXPECT_GT(renderer.last_retried(), 0u) << "512 rays in one invocation run out on llvmpipe";
    }
    EXPECT_EQ(one_dispatch, chunked);
}

// More rays where the blur is wide (TraceSettings::max_rays): a near bar's blur gets them, the error against
// the reference falls, and the in-focus checker's tiles, which keep the minimum, are the fixed-count
// render's exactly.
TEST_F(DofGpu, MoreRaysWhereTheBlurIsWideLowerTheErrorThereOnly) {
    constexpr int w = 160, h = 48, tile = 8;
    const std::size_t n = static_cast<std::size_t>(w) * h;
    std::vector<float> rgb(3 * n), depth(n);
    for (std::size_t i = 0; i < n; ++i) {
        const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
        const bool bar = x >= 16 && x < 40;
        depth[i] = bar ? 1.0f : 3.0f;  // the bar near, the checker at the focus
        const float v = bar ? 2.0f : ((x / 4 + y / 4) % 2 ? 0.8f : 0.1f);
        rgb[3 * i] = v, rgb[3 * i + 1] = 0.9f * v, rgb[3 * i + 2] = 0.7f * v;
    }
    const LayerStack scene = layers_from_flat(rgb.data(), depth.data(), w, h);
    const RayTable table = make_ray_table(bench_camera(w, h), 256, 9);
    const std::vector<float> ref = render_reference(scene, table);
    TraceSettings fixed;
    fixed.rays = 8;
    const std::vector<float> few = renderer.render(scene, table, fixed);
    EXPECT_DOUBLE_EQ(renderer.last_rays(), 8.0);
    TraceSettings adaptive = fixed;
    adaptive.max_rays = table.samples;
    const std::vector<float> more = renderer.render(scene, table, adaptive);
    EXPECT_GT(renderer.last_rays(), 8.0);
    EXPECT_LT(renderer.last_rays(), 0.9 * table.samples) << "only where the blur is wide";
    EXPECT_LT(relative_l1(more, ref), 0.6 * relative_l1(few, ref));

    int pw = 0, ph = 0;
    const auto pyramid = minmax_pyramid(scene, pw, ph);
    const std::vector<float> counts = tile_ray_counts(pyramid, pw, ph, w, h, table, uniform_reach_px(scene, table), 8, table.samples, 2.0);
    int kept = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (counts[static_cast<std::size_t>((y / tile) * ((w + tile - 1) / tile) + x / tile)] != 8.0f) continue;
            ++kept;
            for (std::size_t c = 0; c < 3; ++c) {
                const std::size_t i = 3 * static_cast<std::size_t>(y * w + x) + c;
                ASSERT_EQ(more[i], few[i]) << "pixel " << x << "," << y;
            }
        }
    EXPECT_GT(kept, 0) << "the sky's tiles keep the minimum";
}

// The ray count per tile follows the widest blur near it: the count of a disc that wide at the spacing,
// clamped; no spacing, or no room above the minimum, gives the minimum everywhere.
TEST(DofTileRays, FollowTheWidestBlurNearTheTile) {
    constexpr int w = 256, h = 16;
    const RayTable table = make_ray_table(bench_camera(w, h), 64, 5);
    const std::size_t n = static_cast<std::size_t>(w) * h;
    std::vector<float> rgb(3 * n, 0.5f), depth(n);
    for (std::size_t i = 0; i < n; ++i) depth[i] = (i % w) < 16 ? 1.0f : 3.0f;  // a near strip, then the focus
    const LayerStack scene = layers_from_flat(rgb.data(), depth.data(), w, h);
    int pw = 0, ph = 0;
    const auto pyramid = minmax_pyramid(scene, pw, ph);
    const double reach = uniform_reach_px(scene, table);
    const std::vector<float> counts = tile_ray_counts(pyramid, pw, ph, w, h, table, reach, 4, 64, 2.0);
    ASSERT_EQ(counts.size(), 64u);
    const double d = 2.0 * table.max_slope * std::abs(1.0 - table.focus_w);  // the near strip's blur, px
    const float near = static_cast<float>(std::clamp(std::ceil(std::numbers::pi / 4.0 * (d / 2.0) * (d / 2.0)), 4.0, 64.0));
    EXPECT_GT(near, 4.0f);
    EXPECT_EQ(counts[0], near);
    EXPECT_EQ(counts[31], 4.0f) << "beyond the strip's blur, everything is in focus";
    for (float c : tile_ray_counts(pyramid, pw, ph, w, h, table, reach, 4, 64, 0.0)) EXPECT_EQ(c, 4.0f);
    for (float c : tile_ray_counts(pyramid, pw, ph, w, h, table, reach, 64, 8, 2.0)) EXPECT_EQ(c, 64.0f);
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
