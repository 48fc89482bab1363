// Scene culling (issue 17): ghosts left out where the plate hides them, kept where it does not; the budget
// per cell; --no-scene-cull; the error of a real frame's 8-bit sRGB view against drawing every ghost; and
// --visibility's refusals.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <gtest/gtest.h>

#include <filter/frame.h>
#include <filter/visibility.h>
#include <gpu/acceleration.h>

#include "filter_test_util.h"

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

namespace {

// "flare.ghosts culled" (or another figure) of the single frame of a --report file.
double report_figure(const fs::path& report, const std::string& name) {
    std::ifstream in(report);
    std::stringstream text;
    text << in.rdbuf();
    const std::string key = "\"" + name + "\": ";
    const auto at = text.str().find(key);
    return at == std::string::npos ? -1.0 : std::stod(text.str().substr(at + key.size()));
}

// The 8-bit sRGB codes of an EXR's R, G, B (clipped to [0, 1], as the display shows them).
std::vector<int> srgb8_codes(const fs::path& file) {
    OIIO::ImageBuf image(file.string());
    const OIIO::ROI roi = image.roi();
    std::vector<float> rgb(static_cast<std::size_t>(roi.npixels()) * 3);
    EXPECT_TRUE(image.get_pixels(OIIO::ROI(roi.xbegin, roi.xend, roi.ybegin, roi.yend, 0, 1, 0, 3), OIIO::TypeDesc::FLOAT, rgb.data()));
    std::vector<int> codes(rgb.size());
    for (std::size_t i = 0; i < rgb.size(); ++i) {
        const double v = std::clamp(static_cast<double>(rgb[i]), 0.0, 1.0);
        const double e = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
        codes[i] = static_cast<int>(std::lround(255.0 * e));
    }
    return codes;
}

}  // namespace

namespace {

// `input` through `lens` at each gain, with and without scene culling (sharing one cache folder): something
// culled, and the 8-bit sRGB view moved by at most 1 code at 99.9% of values and 4 anywhere.
void expect_within_a_code_of_drawing_every_ghost(const fs::path& input, const std::string& lens, const std::vector<std::string>& gains) {
    const fs::path dir = lensfx::test::scratch_dir("scene_cull");
    for (const std::string& gain : gains) {
        std::vector<std::vector<int>> codes;
        std::vector<double> culled;
        for (const std::string cull : {"", " --no-scene-cull"}) {
            const fs::path out = dir / ("out" + gain + (cull.empty() ? "c" : "n") + ".exr");
            const fs::path report = dir / ("r" + gain + (cull.empty() ? "c" : "n") + ".json");
            const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i '" + input.string() + "' -o '" + out.string() +
                                             "' --lens " + lens + " --gain " + gain + cull + " -q --cache-dir '" + (dir / "cache").string() + "' --report '" +
                                             report.string() + "'");
            ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
            codes.push_back(srgb8_codes(out));
            culled.push_back(report_figure(report, "flare.ghosts culled"));
        }
        EXPECT_GT(culled[0], 0.0) << "gain " << gain;
        EXPECT_EQ(culled[1], 0.0) << "gain " << gain;
        ASSERT_EQ(codes[0].size(), codes[1].size());
        std::vector<int> diff(codes[0].size());
        for (std::size_t i = 0; i < diff.size(); ++i) diff[i] = std::abs(codes[0][i] - codes[1][i]);
        std::sort(diff.begin(), diff.end());
        EXPECT_LE(diff[static_cast<std::size_t>(0.999 * static_cast<double>(diff.size() - 1))], 1) << "gain " << gain;
        EXPECT_LE(diff.back(), 4) << "gain " << gain;
    }
    fs::remove_all(dir);
}

}  // namespace

// The sample pan's first frame (480 x 270 of StageEnvLatLong.exr), at physical strength and x20.
TEST(SceneCull, RealFrameWithinOneCodeOfDrawingEveryGhost) {
    const fs::path input = fs::path(LENSFX_SOURCE_DIR) / "samples" / "pan" / "pan.0001.exr";
    if (!fs::exists(input)) GTEST_SKIP() << input << " is missing";
    expect_within_a_code_of_drawing_every_ghost(input, "mld-double-gauss", {"1", "20"});
}

// StillLife.exr's lamp (at half size, 620 x 423) is an extended light dimmer than 1 (its ghosts' power scaled
// below their pass weight): its magnified groups' spread peaks once counted the light twice and culled a ghost
// 9 codes bright at one pixel.
TEST(SceneCull, DimExtendedLightsGroupsWithinOneCodeOfDrawingEveryGhost) {
    const fs::path full = fs::path(LENSFX_SHARED_DIR) / "data" / "hdr" / "ScanLines" / "StillLife.exr";
    if (!fs::exists(full)) GTEST_SKIP() << full << " is missing";
    const fs::path dir = lensfx::test::scratch_dir("scene_cull_still");
    const fs::path input = dir / "half.exr";
    const OIIO::ImageBuf src(full.string());
    const OIIO::ImageBuf half = OIIO::ImageBufAlgo::resize(src, "", 0.0f, OIIO::ROI(0, 620, 0, 423, 0, 1, 0, src.nchannels()));
    ASSERT_TRUE(half.write(input.string())) << half.geterror();
    expect_within_a_code_of_drawing_every_ghost(input, "angenieux-double-gauss", {"1"});
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
