// The measured ghost model, its TOML files and the GPU renderer against the CPU reference.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include <gpu/context.h>
#include <gpu/measured_renderer.h>
#include <measured/model.h>
#include <measured/model_file.h>
#include <measured/predict.h>
#include <optics/lens_file.h>

namespace lensfx::measured {
namespace {

// A lens with two ghosts whose parameters move with the angle.
MeasuredLens two_ghost_lens() {
    MeasuredLens lens;
    lens.name = "test \"two\"";
    lens.focal_length_mm = 50.0;
    lens.capture = {2.8, 200.0, 0.5, 40.0};
    for (double side : {-1.0, 1.0}) {
        MeasuredGhost g;
        g.angle_min_deg = 1.0, g.angle_max_deg = 20.0;
        const GhostParams p = disc_ghost(0.0, 2.0, {1e-3, 2e-3, 3e-3});
        for (int k = 0; k < kParamCount; ++k) g.poly[static_cast<std::size_t>(k)] = {p[k], 0.0, 0.0};
        g.poly[kPosition] = {0.0, side * 0.8, 0.01};
        g.poly[kRight] = {2.0, 0.05, 0.0};
        g.poly[kCurveLeft] = {0.3, 0.0, 0.0};
        g.poly[kInsideG] = {1e-3, 0.0, 0.0};
        lens.ghosts.push_back(g);
    }
    return lens;
}

TEST(MeasuredModel, DiscDistanceIsTheRadiusLess) {
    const GhostParams p = disc_ghost(0.0, 2.0, {1, 1, 1});
    EXPECT_NEAR(signed_distance(p, 0.0, 0.0), -2.0, 1e-3);
    EXPECT_NEAR(signed_distance(p, 3.0, 0.0), 1.0, 1e-3);
    EXPECT_NEAR(signed_distance(p, 0.0, -2.5), 0.5, 1e-3);  // mirrored about the axis
    // The four-segment Bezier circle is within 0.03% of a circle (curve 0.5523).
    EXPECT_NEAR(signed_distance(p, 2.0 * std::cos(0.7), 2.0 * std::sin(0.7)), 0.0, 2e-3);
}

TEST(MeasuredModel, IntensityFallsFromTheBorder) {
    GhostParams p = disc_ghost(0.0, 2.0, {1, 1, 1});
    p[kInsideR] = 0.25, p[kFallInside] = 1.0, p[kFallOutside] = 0.5;
    EXPECT_DOUBLE_EQ(intensity(p, 0, 0.0), 1.0);
    EXPECT_DOUBLE_EQ(intensity(p, 0, -1.5), 0.25);
    EXPECT_NEAR(intensity(p, 0, -0.5), 0.625, 1e-12);
    EXPECT_NEAR(intensity(p, 0, 0.25), 0.5, 1e-12);
    EXPECT_DOUBLE_EQ(intensity(p, 0, 0.6), 0.0);
}

TEST(MeasuredModel, BrightnessScaleIsEquationTwo) {
    const Capture capture{2.0, 100.0, 1.0, 1.0};
    EXPECT_DOUBLE_EQ(brightness_scale(capture, {4.0, 100.0, 1.0, 1.0}), 0.25);  // two stops down
    EXPECT_DOUBLE_EQ(brightness_scale(capture, {2.0, 400.0, 0.5, 1.0}), 2.0);
    EXPECT_DOUBLE_EQ(brightness_scale(capture, capture, 3.0), 3.0);
}

TEST(MeasuredFile, RoundTrips) {
    const MeasuredLens lens = two_ghost_lens();
    const MeasuredLens back = parse_measured_toml(write_measured_toml(lens), "mem.toml");
    EXPECT_EQ(back.name, lens.name);
    EXPECT_DOUBLE_EQ(back.capture.light_energy, 40.0);
    ASSERT_EQ(back.ghosts.size(), 2u);
    for (std::size_t g = 0; g < 2; ++g)
        for (int k = 0; k < kParamCount; ++k)
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(back.ghosts[g].poly[static_cast<std::size_t>(k)][static_cast<std::size_t>(c)],
                            lens.ghosts[g].poly[static_cast<std::size_t>(k)][static_cast<std::size_t>(c)], 1e-12);
}

// The message of the error parsing `text`, or "" when it parses.
std::string error_of(const std::string& text) {
    try {
        parse_measured_toml(text, "bad.toml");
    } catch (const optics::LensFileError& e) {
        return e.what();
    }
    return "";
}

TEST(MeasuredFile, ErrorsNameTheFileAndField) {
    const std::string good = write_measured_toml(two_ghost_lens());
    EXPECT_EQ(error_of(good), "");
    auto replaced = [&](const std::string& from, const std::string& to) {
        std::string t = good;
        t.replace(t.find(from), from.size(), to);
        return t;
    };
    EXPECT_NE(error_of(replaced("focal_length = 50", "focal_length = -5")).find("bad.toml: focal_length"), std::string::npos);
    EXPECT_NE(error_of(replaced("iso = 200", "iso = nan")).find("iso"), std::string::npos);
    EXPECT_NE(error_of(replaced("angles = [1, 20]", "angles = [1, 95]")).find("ghost 1: angles"), std::string::npos);
    EXPECT_NE(error_of(replaced("right = [", "wrong = [")).find("ghost 1: right: missing"), std::string::npos);
    EXPECT_NE(error_of(replaced("kind = \"measured\"", "kind = \"lens\"")).find("bad.toml:3: kind"), std::string::npos);
    EXPECT_NE(error_of(replaced("left = [", "left = [1e9, ")).find("left"), std::string::npos);
}

TEST(MeasuredRender, TurnsWithTheLightsRoll) {
    const MeasuredLens lens = two_ghost_lens();
    MeasuredView view{8.0, 0.0, 36.0, 36.0, 96, 96};
    std::vector<float> right(96 * 96 * 3, 0.0f), up(96 * 96 * 3, 0.0f);
    render_add(lens, view, {1, 1, 1}, right.data());
    view.angle_x_deg = 0.0, view.angle_y_deg = 8.0;
    render_add(lens, view, {1, 1, 1}, up.data());
    // A quarter turn counter-clockwise: the upright image's (x, y) goes to (y, W - 1 - x).
    double diff = 0.0, total = 0.0;
    for (int y = 0; y < 96; ++y)
        for (int x = 0; x < 96; ++x)
            for (int c = 0; c < 3; ++c) {
                const double a = static_cast<double>(right[static_cast<std::size_t>((y * 96 + x) * 3 + c)]);
                const double b = static_cast<double>(up[static_cast<std::size_t>(((95 - x) * 96 + y) * 3 + c)]);
                diff += std::abs(a - b), total += a;
            }
    ASSERT_GT(total, 0.0);
    EXPECT_LT(diff / total, 1e-3);
}

TEST(MeasuredRender, GpuMatchesTheCpuReference) {
    const gpu::Context context(gpu::Platform::Surfaceless);
    gpu::MeasuredRenderer renderer(context);
    const MeasuredLens lens = two_ghost_lens();
    for (const auto& [ax, ay] : {std::pair{6.0, 0.0}, std::pair{5.0, -7.0}}) {
        const MeasuredView view{ax, ay, 36.0, 24.0, 120, 80};
        std::vector<float> cpu(120 * 80 * 3, 0.5f), gpu(120 * 80 * 3, 0.5f);  // both add to what is there
        render_add(lens, view, {2, 1, 0.5}, cpu.data());
        renderer.render_add(lens, view, {2, 1, 0.5}, gpu.data());
        double diff = 0.0, total = 0.0;
        for (std::size_t i = 0; i < cpu.size(); ++i)
            diff += std::abs(static_cast<double>(cpu[i] - gpu[i])), total += std::abs(static_cast<double>(cpu[i]) - 0.5);
        ASSERT_GT(total, 0.0);
        EXPECT_LT(diff / total, 1e-3) << ax << "," << ay;
    }
}

// The two-ghost lens plus a glow: a dark-bordered dome wider than the frame (smooth, drawn reduced).
MeasuredLens lens_with_a_glow() {
    MeasuredLens lens = two_ghost_lens();
    MeasuredGhost glow;
    glow.angle_min_deg = 0.0, glow.angle_max_deg = 20.0;
    GhostParams p = disc_ghost(0.0, 25.0, {0.0, 0.0, 0.0});
    p[kHeight] = 20.0, p[kFallInside] = 20.0, p[kSlopeInside] = 1.5, p[kFallOutside] = 1e-3;
    p[kInsideR] = 2e-4, p[kInsideG] = 3e-4, p[kInsideB] = 1e-4;
    for (int k = 0; k < kParamCount; ++k) glow.poly[static_cast<std::size_t>(k)] = {p[k], 0.0, 0.0};
    glow.poly[kPosition] = {0.0, 0.5, 0.0};
    lens.ghosts.push_back(glow);
    return lens;
}

double relative_l1(const std::vector<float>& a, const std::vector<float>& b, float base) {
    double diff = 0.0, total = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) diff += std::abs(static_cast<double>(a[i] - b[i])), total += std::abs(static_cast<double>(b[i] - base));
    return diff / total;
}

// Only a ghost with a dark border and a slow rise is smooth; the glow is drawn 8x reduced at 240x160.
TEST(MeasuredRender, SmoothGhostsAreThoseWithoutAnEdge) {
    const MeasuredLens lens = lens_with_a_glow();
    const MeasuredView view{6.0, 0.0, 36.0, 24.0, 240, 160};
    EXPECT_EQ(reduction_for(lens.ghosts[0].at(6.0), view), 1);
    EXPECT_EQ(reduction_for(lens.ghosts[2].at(6.0), view), 8);
    MeasuredView full = view;
    full.max_reduction = 1;
    EXPECT_EQ(reduction_for(lens.ghosts[2].at(6.0), full), 1);
    GhostParams steep = lens.ghosts[2].at(6.0);
    steep[kSlopeInside] = 0.5;
    EXPECT_EQ(smooth_scale_mm(steep), 0.0);
}

// The reduced glow, upsampled, against the glow at full size (CPU), and the GPU against the CPU.
TEST(MeasuredRender, ReducedGlowMatchesFullSizeAndTheGpu) {
    const MeasuredLens lens = lens_with_a_glow();
    const gpu::Context context(gpu::Platform::Surfaceless);
    gpu::MeasuredRenderer renderer(context);
    for (const auto& [ax, ay] : {std::pair{6.0, 0.0}, std::pair{5.0, -7.0}}) {
        MeasuredView view{ax, ay, 36.0, 24.0, 240, 160};
        std::vector<float> reduced(240 * 160 * 3, 0.5f), full(240 * 160 * 3, 0.5f), gpu(240 * 160 * 3, 0.5f);
        render_add(lens, view, {2, 1, 0.5}, reduced.data());
        renderer.render_add(lens, view, {2, 1, 0.5}, gpu.data());
        view.max_reduction = 1;
        render_add(lens, view, {2, 1, 0.5}, full.data());
        EXPECT_LT(relative_l1(reduced, full, 0.5f), 2e-3) << ax << "," << ay;
        EXPECT_LT(relative_l1(gpu, reduced, 0.5f), 1e-3) << ax << "," << ay;
    }
}

// More ghosts than one draw's uniform block holds (64): the GPU draws them in blocks, all of them.
TEST(MeasuredRender, GpuDrawsMoreGhostsThanOneBlock) {
    const gpu::Context context(gpu::Platform::Surfaceless);
    gpu::MeasuredRenderer renderer(context);
    MeasuredLens lens;
    for (int k = 0; k < 70; ++k) {
        MeasuredGhost g;
        g.angle_min_deg = 0.0, g.angle_max_deg = 20.0;
        const GhostParams p = disc_ghost(-15.0 + 0.45 * k, 0.4 + 0.01 * k, {1e-3, 2e-3, 1e-3});
        for (int i = 0; i < kParamCount; ++i) g.poly[static_cast<std::size_t>(i)] = {p[i], 0.0, 0.0};
        lens.ghosts.push_back(g);
    }
    const MeasuredView view{6.0, 2.0, 36.0, 24.0, 240, 160};
    std::vector<float> cpu(240 * 160 * 3, 0.0f), gpu(240 * 160 * 3, 0.0f), first(240 * 160 * 3, 0.0f);
    render_add(lens, view, {1, 1, 1}, cpu.data());
    renderer.render_add(lens, view, {1, 1, 1}, gpu.data());
    lens.ghosts.resize(64);
    render_add(lens, view, {1, 1, 1}, first.data());
    EXPECT_LT(relative_l1(gpu, cpu, 0.0f), 1e-3);
    EXPECT_GT(relative_l1(first, cpu, 0.0f), 0.05);  // the last six ghosts are a visible part of the image
}

// Ghosts of several shapes (a disc, a diamond with sharp corners, a near square, a lopsided one), large
// in the frame (the table coarser than the pixels), each with a bright rim: drawn from their distance
// tables against the exact Bezier search per pixel.
TEST(MeasuredRender, DistanceTablesMatchTheExactSearch) {
    MeasuredLens lens;
    const std::array<std::array<double, 5>, 4> shapes{{{6, 6, 6, 0.5523, 0.5523}, {5, 7, 4, 0.0, 0.0}, {6, 6, 5, 1.0, 1.0}, {3, 9, 5, 0.2, 0.8}}};
    for (const auto& [left, right, height, cl, cr] : shapes) {
        GhostParams p = disc_ghost(1.0, 6.0, {2e-3, 1e-3, 3e-3});
        p[kLeft] = left, p[kRight] = right, p[kHeight] = height, p[kCurveLeft] = cl, p[kCurveRight] = cr;
        p[kInsideR] = 5e-4, p[kInsideG] = 1e-4, p[kInsideB] = 2e-4, p[kSlopeInside] = 2.0, p[kSlopeOutside] = 3.0;
        MeasuredGhost g;
        g.angle_min_deg = 0.0, g.angle_max_deg = 20.0;
        for (int k = 0; k < kParamCount; ++k) g.poly[static_cast<std::size_t>(k)] = {p[k], 0.0, 0.0};
        lens.ghosts.assign(1, g);
        for (const auto& [ax, ay] : {std::pair{6.0, 0.0}, std::pair{5.0, -7.0}}) {
            MeasuredView view{ax, ay, 36.0, 24.0, 480, 320};
            std::vector<float> tables(480 * 320 * 3, 0.5f), exact(480 * 320 * 3, 0.5f);
            render_add(lens, view, {1, 1, 1}, tables.data());
            view.distance_tables = false;
            render_add(lens, view, {1, 1, 1}, exact.data());
            EXPECT_LT(relative_l1(tables, exact, 0.5f), 3e-3) << left << "," << right << "," << height << "," << cl << " at " << ax << "," << ay;
        }
        // Beyond its grid the table gives the fall-off outside: dark.
        const DistanceTable t = distance_table(p, 0.1);
        EXPECT_EQ(t.at(right + p[kFallOutside] + 0.1, 0.0), p[kFallOutside]);
        EXPECT_NEAR(t.at(0.0, 0.0), signed_distance(p, 0.0, 0.0), 0.02);
    }
}

TEST(MeasuredPredict, EstimatorsOfAKnownImage) {
    std::vector<float> flare(4 * 4 * 3, 0.0f);
    for (int c = 0; c < 3; ++c) flare[static_cast<std::size_t>(c)] = 1.0f;  // one pixel of luminance 1
    const FlareEstimate e = estimate(flare, 4, 4, {1.0f}, 0.5);
    EXPECT_NEAR(e.peak, 1.0, 1e-6);
    EXPECT_NEAR(e.total, 0.5, 1e-6);
    EXPECT_NEAR(e.glare, std::pow(2.0, 1.0 / 16) - 1.0, 1e-6);
    const double veil = 1.0 / 16;
    EXPECT_NEAR(e.contrast, 100.0 / ((1.0 + veil) / (0.01 + veil)), 1e-6);
    EXPECT_EQ(rated({1.0, 3.0, 2.0}), (std::vector<double>{0.0, 1.0, 0.5}));
}

}  // namespace
}  // namespace lensfx::measured
