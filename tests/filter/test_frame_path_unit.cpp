// The frame side of the flare stage without the GPU: the --min-light fade and the frame operations the composite needs (growing the data window, adding a flare layer).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <Imath/half.h>
#include <gtest/gtest.h>

#include <filter/flare_stage.h>
#include <filter/frame.h>
#include <optics/aperture.h>
#include <optics/lens_file.h>
#include <optics/starburst.h>
#include <optics/system.h>

namespace fs = std::filesystem;
using namespace lensfx;
using Imath::half;

namespace {

// A frame with channels R, G, B (half) and Z (float), data window (x, y, w, h) inside a 20 x 10 display
// window; channel c of pixel i holds 10 i + c.
filter::Frame make_frame(int x, int y, int w, int h) {
    filter::Frame frame;
    frame.spec = filter::ImageSpec(w, h, 4, filter::PixelType::half);
    frame.spec.channelnames = {"R", "G", "B", "Z"};
    frame.spec.channeltypes = {filter::PixelType::half, filter::PixelType::half, filter::PixelType::half, filter::PixelType::float32};
    frame.spec.x = x;
    frame.spec.y = y;
    frame.spec.full_x = 0;
    frame.spec.full_y = 0;
    frame.spec.full_width = 20;
    frame.spec.full_height = 10;
    frame.pixels = filter::PixelBuffer(frame.spec.image_bytes());
    std::vector<float> values(static_cast<std::size_t>(w * h * 4));
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<float>(10 * (i / 4) + i % 4);
    const auto offsets = filter::channel_offsets(frame.spec);
    const std::size_t px = frame.spec.pixel_bytes();
    for (std::size_t i = 0; i < static_cast<std::size_t>(w * h); ++i) {
        for (std::size_t c = 0; c < 3; ++c) {
            const half v(values[i * 4 + c]);
            std::memcpy(frame.pixels.data() + i * px + offsets[c], &v, sizeof v);
        }
        std::memcpy(frame.pixels.data() + i * px + offsets[3], &values[i * 4 + 3], sizeof(float));
    }
    filter::find_rgb_channels(frame);
    return frame;
}

}  // namespace

TEST(FramePath, MinLightFadeIsSmoothAndSkipsOnlyDimLights) {
    EXPECT_EQ(filter::min_light_fade(0.0005, 1e-3), 0.0);
    EXPECT_EQ(filter::min_light_fade(1e-3, 1e-3), 0.0);
    EXPECT_EQ(filter::min_light_fade(2e-3, 1e-3), 1.0);
    EXPECT_EQ(filter::min_light_fade(1.0, 1e-3), 1.0);
    EXPECT_EQ(filter::min_light_fade(1e-9, 0.0), 1.0);  // 0: every light is kept
    EXPECT_NEAR(filter::min_light_fade(1.5e-3, 1e-3), 0.5, 1e-12);
    double previous = 0.0;
    for (int i = 0; i <= 1000; ++i) {  // monotone, and no step larger than the slope allows
        const double w = filter::min_light_fade(1e-3 + 1e-3 * i / 1000.0, 1e-3);
        EXPECT_GE(w, previous);
        EXPECT_LE(w - previous, 1.5 / 1000.0 + 1e-12);
        previous = w;
    }
}

TEST(FramePath, GrowDataWindowKeepsPixelsAndZeroFillsTheRest) {
    filter::Frame frame = make_frame(3, 2, 4, 3);
    filter::load_rgb(frame);
    const std::vector<float> before_z = filter::channels_as_float(frame, {3});
    filter::grow_data_window(frame, 0, 0, 20, 10);
    EXPECT_EQ(frame.spec.x, 0);
    EXPECT_EQ(frame.spec.y, 0);
    EXPECT_EQ(frame.spec.width, 20);
    EXPECT_EQ(frame.spec.height, 10);
    ASSERT_EQ(frame.rgb.size(), 200u * 3u);
    ASSERT_EQ(frame.pixels.size(), frame.spec.image_bytes());
    const std::vector<float> z = filter::channels_as_float(frame, {3});
    const std::vector<float> r = filter::channels_as_float(frame, {0});
    for (int y = 0; y < 10; ++y)
        for (int x = 0; x < 20; ++x) {
            const bool inside = x >= 3 && x < 7 && y >= 2 && y < 5;
            const std::size_t i = static_cast<std::size_t>(y * 20 + x);
            const std::size_t old = inside ? static_cast<std::size_t>((y - 2) * 4 + (x - 3)) : 0;
            EXPECT_EQ(z[i], inside ? before_z[old] : 0.0f) << x << "," << y;
            EXPECT_EQ(r[i], inside ? static_cast<float>(10 * old) : 0.0f) << x << "," << y;
            EXPECT_EQ(frame.rgb[i * 3 + 1], inside ? static_cast<float>(10 * old + 1) : 0.0f) << x << "," << y;
        }
    // Already covered: nothing changes.
    const filter::PixelBuffer copy = frame.pixels;
    filter::grow_data_window(frame, 5, 5, 6, 6);
    EXPECT_EQ(frame.spec.width, 20);
    EXPECT_EQ(std::vector<std::byte>(copy.data(), copy.data() + copy.size()),
              std::vector<std::byte>(frame.pixels.data(), frame.pixels.data() + frame.pixels.size()));
}

TEST(FramePath, AddRgbLayerAppendsChannelsBesideTheOriginals) {
    filter::Frame frame = make_frame(0, 0, 4, 3);
    const std::vector<float> original = filter::channels_as_float(frame, {0, 1, 2, 3});
    std::vector<float> flare(12 * 3);
    for (std::size_t i = 0; i < flare.size(); ++i) flare[i] = 0.25f * static_cast<float>(i);
    filter::add_rgb_layer(frame, "flare", flare);
    ASSERT_EQ(frame.spec.nchannels(), 7);
    EXPECT_EQ(frame.spec.channelnames, (std::vector<std::string>{"R", "G", "B", "Z", "flare.R", "flare.G", "flare.B"}));
    EXPECT_EQ(frame.spec.channel_type(4), filter::PixelType::half);  // the R channel's type
    EXPECT_EQ(frame.pixels.size(), frame.spec.image_bytes());
    EXPECT_EQ(filter::channels_as_float(frame, {0, 1, 2, 3}), original);
    EXPECT_EQ(filter::channels_as_float(frame, {4, 5, 6}), flare);
    EXPECT_THROW(filter::add_rgb_layer(frame, "flare", flare), std::invalid_argument);
    EXPECT_THROW(filter::add_rgb_layer(frame, "more", std::vector<float>(5)), std::invalid_argument);
}
