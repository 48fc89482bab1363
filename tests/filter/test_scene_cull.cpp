// Scene culling (issue 17): ghosts left out where the plate hides them, kept where it does not; the budget
// per cell; --no-scene-cull; the error of a real frame's 8-bit sRGB view against drawing every ghost; and
// --visibility's refusals.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <filter/frame.h>
#include <filter/visibility.h>
#include <gpu/acceleration.h>

#include "filter_test_util.h"
#include "scene_cull_check.h"

namespace fs = std::filesystem;
using lensfx::gpu::CullItem;
using lensfx::gpu::SceneVerdict;

namespace {

// A 256 x 128 RGB plate: its left half at `left`, its right half at `right`.
lensfx::filter::Frame split_plate(float left, float right) {
    lensfx::filter::Frame frame;
    frame.spec = lensfx::filter::ImageSpec(256, 128, 3, lensfx::filter::PixelType::float32);
    frame.rgb.resize(256 * 128 * 3);
    for (std::size_t y = 0; y < 128; ++y)
        for (std::size_t x = 0; x < 256; ++x)
            for (std::size_t c = 0; c < 3; ++c) frame.rgb[(y * 256 + x) * 3 + c] = x < 128 ? left : right;
    return frame;
}

// A ghost over pixels [x0, x0 + 60) x [30, 90) adding `peak` at most.
CullItem ghost_at(double x0, double peak) { return {x0, 30.0, x0 + 60.0, 90.0, {peak, peak, peak}}; }

}  // namespace

TEST(SceneCull, SkipsAGhostOnABrightPlateAndKeepsItOnADarkOne) {
    const auto map = lensfx::filter::plate_visibility(split_plate(1.0f, 0.001f), 1.0);
    const double peak = 0.3 * lensfx::filter::srgb8_code_step(1.0);  // a third of a code over white
    EXPECT_GT(peak, lensfx::filter::srgb8_code_step(0.001));          // several codes over near black
    const auto verdicts = lensfx::gpu::scene_cull({ghost_at(20.0, peak), ghost_at(170.0, peak)}, *map);
    EXPECT_EQ(verdicts[0], SceneVerdict::Cull);
    EXPECT_EQ(verdicts[1], SceneVerdict::Draw);
}

TEST(SceneCull, CulledGhostsTogetherStayWithinTheBudget) {
    auto map = lensfx::filter::plate_visibility(split_plate(0.5f, 0.5f), 1.0);
    const double step = lensfx::filter::srgb8_code_step(0.5);
    std::vector<CullItem> items(10, ghost_at(40.0, 0.3 * step));  // together three codes
    const auto verdicts = lensfx::gpu::scene_cull(items, *map);
    EXPECT_EQ(std::count(verdicts.begin(), verdicts.end(), SceneVerdict::Cull), 3);
    EXPECT_EQ(std::count(verdicts.begin(), verdicts.end(), SceneVerdict::Faint), 7);  // each alone under a code
    for (double used : map->used) EXPECT_LE(used, 1.0 + 1e-12);
    // The budget is the map's, spent across calls: a second call over the same cells culls nothing there.
    const auto again = lensfx::gpu::scene_cull({ghost_at(40.0, 0.3 * step), ghost_at(200.0, 0.3 * step)}, *map);
    EXPECT_EQ(again[0], SceneVerdict::Faint);
    EXPECT_EQ(again[1], SceneVerdict::Cull);
}

// A ghost with caustics (spike 16) is Faint only when its peak times its spike is under a code; between that
// and its peak alone under a code it is Spiky (drawn coarsened but with its small triangles); a smooth one is Faint.
TEST(SceneCull, ACausticGhostIsFaintOnlyWhenItsSpikeIsUnderACode) {
    auto map = lensfx::filter::plate_visibility(split_plate(0.5f, 0.5f), 1.0);
    map->budget = 0.0;  // nothing culled: only the Faint or Spiky verdict is weighed
    const double step = lensfx::filter::srgb8_code_step(0.5);
    CullItem spiky = ghost_at(40.0, 0.5 * step), faint = ghost_at(40.0, 0.5 * step / 32.0), smooth = ghost_at(40.0, 0.5 * step);
    spiky.spike = faint.spike = 16.0;
    const auto verdicts = lensfx::gpu::scene_cull({spiky, faint, smooth}, *map);
    EXPECT_EQ(verdicts[0], SceneVerdict::Spiky);
    EXPECT_EQ(verdicts[1], SceneVerdict::Faint);
    EXPECT_EQ(verdicts[2], SceneVerdict::Faint);
    // The spike is how caustic_spike weighs an estimate: by its cells' unevenness.
    lensfx::gpu::GhostEstimate e;
    e.area_cv = 0.05;
    EXPECT_EQ(lensfx::gpu::caustic_spike(e), 1.0);
    e.area_cv = 1.0;
    EXPECT_EQ(lensfx::gpu::caustic_spike(e), lensfx::gpu::kCausticSpike);
}

// A faint ghost far under a code (its peak times its spike under kVeilRatio of one) is a Veil, drawn coarser still;
// at the ratio and above it stays Faint, and a caustic ghost is weighed with its spike.
TEST(SceneCull, AGhostFarUnderACodeIsAVeil) {
    auto map = lensfx::filter::plate_visibility(split_plate(0.5f, 0.5f), 1.0);
    map->budget = 0.0;  // nothing culled
    const double step = lensfx::filter::srgb8_code_step(0.5);
    const double veil = 0.9 * lensfx::gpu::kVeilRatio * step, faint = 1.1 * lensfx::gpu::kVeilRatio * step;
    CullItem caustic = ghost_at(40.0, veil);
    caustic.spike = lensfx::gpu::kCausticSpike;
    const auto verdicts = lensfx::gpu::scene_cull({ghost_at(40.0, veil), ghost_at(40.0, faint), caustic}, *map);
    EXPECT_EQ(verdicts[0], SceneVerdict::Veil);
    EXPECT_EQ(verdicts[1], SceneVerdict::Faint);
    EXPECT_EQ(verdicts[2], SceneVerdict::Faint);  // its spike brings it over the ratio
    map->veil_ratio = 0.0;  // no Veils: Faint
    EXPECT_EQ(lensfx::gpu::scene_cull({ghost_at(40.0, veil)}, *map)[0], SceneVerdict::Faint);
    // Weighed against the least visible value under its box: over a dark corner the same ghost is Faint.
    auto dark = lensfx::filter::plate_visibility(split_plate(0.5f, 0.02f), 1.0);
    dark->budget = 0.0;
    EXPECT_EQ(lensfx::gpu::scene_cull({ghost_at(100.0, veil)}, *dark)[0], SceneVerdict::Faint);
}

namespace {

// A ghost of one spectral pass: over the same pixels as ghost_at, adding `peak` to channel `channel` only.
CullItem ghost_in(std::size_t channel, double peak) {
    CullItem item = ghost_at(40.0, 0.0);
    item.peak[channel] = peak;
    return item;
}

}  // namespace

// Each of R, G and B has its own budget: a pass adds to one channel, and the 8-bit view's codes are per
// channel, so ten third-of-a-code ghosts per channel cull three in each (one shared budget culled three in all).
TEST(SceneCull, EachChannelSpendsItsOwnBudget) {
    auto map = lensfx::filter::plate_visibility(split_plate(0.5f, 0.5f), 1.0);
    const double step = lensfx::filter::srgb8_code_step(0.5);
    std::vector<CullItem> items;
    for (std::size_t c = 0; c < 3; ++c)
        for (int i = 0; i < 10; ++i) items.push_back(ghost_in(c, 0.3 * step));
    const auto verdicts = lensfx::gpu::scene_cull(items, *map);
    for (std::size_t c = 0; c < 3; ++c)
        EXPECT_EQ(std::count(verdicts.begin() + static_cast<std::ptrdiff_t>(c * 10), verdicts.begin() + static_cast<std::ptrdiff_t>(c * 10 + 10),
                             SceneVerdict::Cull), 3) << "channel " << c;
    ASSERT_EQ(map->used.size(), map->visible.size());
    for (double used : map->used) EXPECT_LE(used, 1.0 + 1e-12);
}

// A plate bright in R and dark in G and B hides a ghost in R, not the same ghost in G.
TEST(SceneCull, ABrightChannelHidesOnlyItsOwnGhosts) {
    lensfx::filter::Frame plate = split_plate(0.001f, 0.001f);
    for (std::size_t i = 0; i < plate.rgb.size(); i += 3) plate.rgb[i] = 1.0f;
    auto map = lensfx::filter::plate_visibility(plate, 1.0);
    const double peak = 0.3 * lensfx::filter::srgb8_code_step(1.0);
    const auto verdicts = lensfx::gpu::scene_cull({ghost_in(0, peak), ghost_in(1, peak)}, *map);
    EXPECT_EQ(verdicts[0], SceneVerdict::Cull);
    EXPECT_EQ(verdicts[1], SceneVerdict::Draw);  // several codes over the dark G
}

TEST(SceneCull, UnknownGhostsAreDrawnAndGhostsOffTheImageCulled) {
    auto map = lensfx::filter::plate_visibility(split_plate(1.0f, 1.0f), 1.0);
    CullItem negative = ghost_at(20.0, 1e-9);
    negative.peak[2] = -1e-9;
    const auto verdicts = lensfx::gpu::scene_cull(
        {CullItem{}, ghost_at(20.0, 0.0), ghost_at(20.0, std::nan("")), ghost_at(20.0, HUGE_VAL), ghost_at(400.0, 1e6), negative}, *map);
    EXPECT_EQ(verdicts[0], SceneVerdict::Draw);
    EXPECT_EQ(verdicts[1], SceneVerdict::Draw);
    EXPECT_EQ(verdicts[2], SceneVerdict::Draw);
    EXPECT_EQ(verdicts[3], SceneVerdict::Draw);
    EXPECT_EQ(verdicts[4], SceneVerdict::Cull);
    EXPECT_EQ(verdicts[5], SceneVerdict::Draw);  // a negative channel: not a peak scene culling can weigh
}

// The sample pan's first frame (480 x 270 of StageEnvLatLong.exr), at physical strength and x20.
TEST(SceneCull, RealFrameWithinOneCodeOfDrawingEveryGhost) {
    const fs::path input = fs::path(LENSFX_SOURCE_DIR) / "samples" / "pan" / "pan.0001.exr";
    if (!fs::exists(input)) GTEST_SKIP() << input << " is missing";
    lensfx::test::expect_within_a_code_of_drawing_every_ghost(input, "mld-double-gauss", {"1", "20"});
}

// StillLife.exr's lamp (at half size, 620 x 423) is an extended light dimmer than 1 (its ghosts' power scaled
// below their pass weight): its magnified groups' spread peaks once counted the light twice and culled a ghost
// 9 codes bright at one pixel.
TEST(SceneCull, DimExtendedLightsGroupsWithinOneCodeOfDrawingEveryGhost) {
    const fs::path full = fs::path(LENSFX_SHARED_DIR) / "data" / "hdr" / "ScanLines" / "StillLife.exr";
    if (!fs::exists(full)) GTEST_SKIP() << full << " is missing";
    const fs::path dir = lensfx::test::scratch_dir("scene_cull_still");
    const fs::path input = lensfx::test::resized_frame(full, 620, 423, dir);
    lensfx::test::expect_within_a_code_of_drawing_every_ghost(input, "angenieux-double-gauss", {"1"});
    fs::remove_all(dir);
}

TEST(SceneCull, VisibilityRefusesNegativeAndNonFiniteValues) {
    const fs::path input = fs::path(LENSFX_SOURCE_DIR) / "samples" / "pan" / "pan.0001.exr";
    for (const std::string v : {"-1", "nan", "inf", "-inf", "x"}) {
        const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i '" + input.string() +
                                         "' -o /tmp/never.exr --lens mld-double-gauss --visibility=" + v);
        EXPECT_EQ(r.exit_code, 2) << v << ": " << r.stderr_text;
        EXPECT_EQ(r.stderr_text.rfind("lensfx: ", 0), 0u) << v << ": " << r.stderr_text;
        EXPECT_EQ(std::count(r.stderr_text.begin(), r.stderr_text.end(), '\n'), 1) << v << ": " << r.stderr_text;
        EXPECT_FALSE(fs::exists("/tmp/never.exr"));
    }
}

// A plate of 256 x 128 pixels in a 10^6 x 10^6 display window (issue 14: a tiny file declaring a huge
// window): the map's cells grow so that it holds at most 2048 x 2048 of them, covering the whole window,
// and the plate's cells still see its level.
TEST(SceneCull, HugeDisplayWindowGetsCoarserCells) {
    lensfx::filter::Frame frame = split_plate(1.0f, 1.0f);
    frame.spec.full_width = frame.spec.full_height = 1000000;
    const auto map = lensfx::filter::plate_visibility(frame, 1.0);
    EXPECT_GT(map->cell, lensfx::filter::kVisibilityCell);
    EXPECT_LE(static_cast<std::size_t>(map->cols) * static_cast<std::size_t>(map->rows), std::size_t{1} << 22);
    EXPECT_GE(static_cast<long long>(map->cols) * map->cell, 1000000LL);
    EXPECT_GE(static_cast<long long>(map->rows) * map->cell, 1000000LL);
    EXPECT_EQ(map->visible.size(), static_cast<std::size_t>(map->cols) * static_cast<std::size_t>(map->rows) * 3);  // per channel
    // The plate fills less than its cell: the cell's least value is the black around it.
    EXPECT_FLOAT_EQ(map->visible[0], static_cast<float>(lensfx::filter::srgb8_code_step(0.0)));

    const auto normal = lensfx::filter::plate_visibility(split_plate(1.0f, 1.0f), 1.0);
    EXPECT_EQ(normal->cell, lensfx::filter::kVisibilityCell);
}
