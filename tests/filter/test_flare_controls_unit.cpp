// The compositor's controls without the GPU: --add-light parsing and painting, the image the detector sees
// under a matte and with added lights (the plate untouched), and the end-of-run line.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include <filter/flare_controls.h>
#include <filter/option_checks.h>
#include <filter/frame.h>
#include <filter/image_io.h>

using namespace lensfx;
using filter::AddedLight;

namespace {

// A float RGB(A) frame of width x height pixels, data window at (x, y) in a 64x48 display window, every
// pixel `value` (alpha `alpha`).
filter::Frame frame_of(int x, int y, int width, int height, float value, bool with_alpha = false, float alpha = 0.0f) {
    const int channels = with_alpha ? 4 : 3;
    std::vector<float> px(static_cast<std::size_t>(width * height * channels), value);
    if (with_alpha)
        for (std::size_t i = 3; i < px.size(); i += 4) px[i] = alpha;
    filter::Frame f = filter::image_frame(width, height, channels, filter::PixelType::float32, px.data());
    f.spec.x = x;
    f.spec.y = y;
    f.spec.full_width = 64;
    f.spec.full_height = 48;
    filter::find_rgb_channels(f);
    filter::load_rgb(f);
    return f;
}

double sum_of(const detect::ImageView& v) {
    double s = 0.0;
    for (int y = 0; y < v.height; ++y)
        for (int x = 0; x < v.width; ++x) s += static_cast<double>(v.row(y)[x * v.channels + 1]);
    return s;
}

}  // namespace

TEST(FlareControls, AddLightParsesPositionValueAndRadius) {
    const AddedLight a = filter::parse_added_light("10.5,20,500");
    EXPECT_EQ(a.x, 10.5);
    EXPECT_EQ(a.y, 20.0);
    EXPECT_EQ(a.value, 500.0);
    EXPECT_EQ(a.radius, 2.0);
    EXPECT_EQ(filter::parse_added_light("-3,4,1e4,6").radius, 6.0) << "a light may lie outside the frame";
    for (const char* bad : {"10,20", "1,2,3,4,5", "a,b,c", "1,2,-3", "1,2,3,0", "1,2,inf", "1,2,3,", "1,,3"})
        EXPECT_THROW(filter::parse_added_light(bad), std::invalid_argument) << bad;
}

TEST(FlareControls, PaintedDiscHoldsItsAreaTimesItsValue) {
    for (const double radius : {0.7, 2.0, 5.3}) {
        std::vector<float> rgb(40 * 30 * 3, 0.0f);
        filter::paint_light({17.3, 11.8, 100.0, radius}, rgb.data(), 0, 0, 40, 30);
        double sum = 0.0;
        for (std::size_t i = 1; i < rgb.size(); i += 3) sum += static_cast<double>(rgb[i]);
        EXPECT_NEAR(sum / (100.0 * std::numbers::pi * radius * radius), 1.0, 0.02) << radius;
    }
    std::vector<float> rgb(10 * 10 * 3, 1.0f);
    filter::paint_light({5.0, 5.0, 9.0, 3.0}, rgb.data(), 0, 0, 10, 10);
    EXPECT_EQ(rgb[(5 * 10 + 5) * 3], 9.0f) << "a covered pixel takes the disc's value";
    EXPECT_EQ(rgb[0], 1.0f) << "an uncovered one keeps the plate's";
}

TEST(FlareControls, WithoutControlsTheDetectorSeesTheFrameItself) {
    filter::DetectionInput input(filter::FlareControls{});
    const filter::Frame f = frame_of(0, 0, 64, 48, 2.0f);
    EXPECT_FALSE(input.changes_the_plate());
    EXPECT_EQ(input.view(f).data, f.rgb.data());
}

TEST(FlareControls, MatteChannelTakesItsWhiteOutOfWhatTheDetectorSees) {
    filter::FlareControls c;
    c.matte_channel = "A";
    filter::DetectionInput input(c);
    const filter::Frame white = frame_of(4, 2, 30, 20, 50.0f, true, 1.0f);
    const filter::Frame grey = frame_of(4, 2, 30, 20, 50.0f, true, 0.25f);
    const std::vector<float> before = white.rgb;
    EXPECT_EQ(sum_of(input.view(white)), 0.0);
    EXPECT_EQ(white.rgb, before) << "the plate is never changed";
    const detect::ImageView v = input.view(grey);
    EXPECT_EQ(v.x_offset, 4);
    EXPECT_EQ(v.y_offset, 2);
    EXPECT_DOUBLE_EQ(sum_of(v), 0.75 * 50.0 * 30 * 20);
    c.matte_channel = "matte.Y";
    filter::DetectionInput missing(c);
    try {
        (void)missing.view(white);
        FAIL() << "a missing channel must be an error";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("--matte-channel matte.Y"), std::string::npos) << e.what();
    }
}

// A matte's display window of 10^12 pixels (a hostile file) costs only its data window: it is read under a
// 64 MB budget and takes the light of its own pixels out and nothing else.
TEST(FlareControls, MatteWithAHugeDisplayWindowTakesOnlyItsDataWindowsMemory) {
    const std::string path = "/tmp/lensfx-test-matte-" + std::to_string(::getpid()) + ".exr";
    filter::Frame matte = frame_of(3, 2, 8, 6, 1.0f);
    matte.spec.full_width = matte.spec.full_height = 1 << 20;
    filter::write_image(matte, path);
    const filter::MatteImage m = filter::read_matte(path, MemoryBudget{std::size_t{64} << 20});
    std::remove(path.c_str());
    EXPECT_EQ(m.full_width, 1 << 20);
    EXPECT_EQ(m.value.size(), 8u * 6u) << "only the data window is held";
    EXPECT_EQ(m.at(3, 2), 1.0f);
    EXPECT_EQ(m.at(10, 7), 1.0f);
    EXPECT_EQ(m.at(11, 7), 0.0f);
    EXPECT_EQ(m.at(2, 2), 0.0f);
    EXPECT_EQ(m.at(-1, 1 << 30), 0.0f);
}

// The matte's white over part of the plate: the detector sees the plate less the matte's pixels.
TEST(FlareControls, MatteFileTakesItsWhiteOutOfWhatTheDetectorSees) {
    const std::string path = "/tmp/lensfx-test-matte-part-" + std::to_string(::getpid()) + ".exr";
    filter::write_image(frame_of(10, 5, 4, 4, 1.0f), path);
    filter::FlareControls c;
    c.matte = path;
    filter::DetectionInput input(c, MemoryBudget{std::size_t{64} << 20});
    std::remove(path.c_str());
    const filter::Frame plate = frame_of(0, 0, 64, 48, 2.0f);
    EXPECT_DOUBLE_EQ(sum_of(input.view(plate)), 2.0 * (64 * 48 - 16));
}

TEST(FlareControls, AddedLightOutsideTheDataWindowGrowsTheDetectorsView) {
    filter::FlareControls c;
    c.add_lights = {"50.5,40.5,1000,3"};
    filter::DetectionInput input(c);
    const filter::Frame f = frame_of(0, 0, 20, 10, 0.0f);
    const detect::ImageView v = input.view(f);
    EXPECT_EQ(v.x_offset, 0);
    EXPECT_EQ(v.y_offset, 0);
    EXPECT_GE(v.width, 54);
    EXPECT_GE(v.height, 44);
    EXPECT_NEAR(sum_of(v) / (1000.0 * std::numbers::pi * 9.0), 1.0, 0.02);
    EXPECT_EQ(f.rgb, std::vector<float>(20 * 10 * 3, 0.0f));
}

TEST(FlareControls, SummarySaysWhatWasFoundOrWhyNothingWas) {
    filter::LightSummary s;
    s.threshold_text = "20";
    s.threshold_there = 20.0;
    s.lights_per_frame = {2, 0, 3, 1};
    EXPECT_EQ(filter::describe(s), "lensfx: 4 frames, lights per frame min 0, median 1, max 3");
    s.ghosts_drawn = 90;  // --no-scene-cull, or a frame that culls none: the ghosts drawn are said all the same
    EXPECT_EQ(filter::describe(s), "lensfx: 4 frames, lights per frame min 0, median 1, max 3, ghosts drawn 90");
    s.ghosts_culled = 10;
    EXPECT_EQ(filter::describe(s), "lensfx: 4 frames, lights per frame min 0, median 1, max 3, ghosts drawn 90, culled against the plate 10");
    s.ghosts_drawn = s.ghosts_culled = 0;
    s.lights_per_frame = {0};
    s.brightest_luminance = 12.06;
    EXPECT_EQ(filter::describe(s),
              "lensfx: no light in any of 1 frame: the brightest luminance is 12.06, below the threshold 20 "
              "(lower --threshold, or give one with --add-light)");
    s.threshold_text = "+6ev";
    s.threshold_there = 31.5;
    EXPECT_NE(filter::describe(s).find("below the threshold +6ev (31.5 on that frame)"), std::string::npos) << filter::describe(s);
    s.brightest_luminance = 40.0;
    EXPECT_NE(filter::describe(s).find("reaches the threshold"), std::string::npos) << filter::describe(s);
    s.tracks = "shot.json";
    EXPECT_EQ(filter::describe(s), "lensfx: no light in any of 1 frame from track file shot.json");
}

TEST(FlareControls, GainOptionsRefuseWhatIsNotAFiniteNonNegativeNumber) {
    for (std::string ok : {"0", "1", "2.5", "1e30"}) EXPECT_EQ(filter::finite_non_negative()(ok), "") << ok;
    for (std::string bad : {"-1", "inf", "nan", "1e999", "x"}) EXPECT_NE(filter::finite_non_negative()(bad), "") << bad;
}
