// The Frame's RGB working buffer: loading and storing touches R, G, B only, in their native types.
#include <filter/frame.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include <Imath/half.h>
#include <gtest/gtest.h>

using namespace lensfx::filter;
using Imath::half;

namespace {

// 3x2 pixels: Z (float), R, G, B (half), id (uint32): per-channel types, RGB not first.
Frame mixed_frame() {
    Frame f;
    f.spec = ImageSpec(3, 2, 5, PixelType::half);
    f.spec.channelnames = {"Z", "R", "G", "B", "id"};
    f.spec.channeltypes = {PixelType::float32, PixelType::half, PixelType::half, PixelType::half, PixelType::uint32};
    f.pixels = PixelBuffer(f.spec.image_bytes());
    EXPECT_EQ(f.spec.pixel_bytes(), 4u + 6u + 4u);
    for (std::size_t i = 0; i < 6; ++i) {
        std::byte* p = f.pixels.data() + i * 14;
        const float z = 100.0f + static_cast<float>(i);
        const half rgb[3] = {half(0.5f * static_cast<float>(i)), half(1000.0f), half(-2.0f)};
        const std::uint32_t id = 0xdeadbe00u + static_cast<std::uint32_t>(i);
        std::memcpy(p, &z, 4);
        std::memcpy(p + 4, rgb, 6);
        std::memcpy(p + 10, &id, 4);
    }
    find_rgb_channels(f);
    return f;
}

}  // namespace

TEST(Frame, FindsRgbByNameOrLayer) {
    Frame f = mixed_frame();
    EXPECT_EQ(f.rgb_channels, (std::array<int, 3>{1, 2, 3}));
    f.spec.channelnames = {"depth.Z", "beauty.R", "beauty.G", "beauty.B", "id"};
    find_rgb_channels(f);
    EXPECT_EQ(f.rgb_channels, (std::array<int, 3>{1, 2, 3}));
    f.spec.channelnames = {"Z", "Y", "G", "B", "id"};
    find_rgb_channels(f);
    EXPECT_FALSE(f.has_rgb());
    EXPECT_THROW(load_rgb(f), std::runtime_error);
}

TEST(Frame, LoadStoreChangesOnlyRgb) {
    Frame f = mixed_frame();
    const PixelBuffer before = f.pixels;
    load_rgb(f);
    ASSERT_EQ(f.rgb.size(), 18u);
    EXPECT_EQ(f.rgb[3 * 4 + 0], 2.0f);
    EXPECT_EQ(f.rgb[3 * 4 + 1], 1000.0f);
    EXPECT_EQ(f.rgb[3 * 4 + 2], -2.0f);
    store_rgb(f);  // unchanged values: bit-identical
    EXPECT_EQ(std::memcmp(before.data(), f.pixels.data(), before.size()), 0);
    for (std::size_t i = 0; i < 6; ++i) f.rgb[i * 3 + 1] += 1.0f;
    store_rgb(f);
    for (std::size_t i = 0; i < 6; ++i) {
        const std::byte* p = f.pixels.data() + i * 14;
        const std::byte* q = before.data() + i * 14;
        EXPECT_EQ(std::memcmp(p, q, 6), 0);             // Z and R untouched
        EXPECT_EQ(std::memcmp(p + 8, q + 8, 6), 0);     // B and id untouched
        half g;
        std::memcpy(&g, p + 6, 2);
        EXPECT_EQ(static_cast<float>(g), 1001.0f);
    }
    f.rgb.pop_back();
    EXPECT_THROW(store_rgb(f), std::runtime_error);
}

TEST(Frame, ChannelsAsFloatInAnyOrder) {
    const Frame f = mixed_frame();
    const auto v = channels_as_float(f, {4, 0});
    ASSERT_EQ(v.size(), 12u);
    EXPECT_EQ(v[1], 100.0f);
    EXPECT_EQ(v[3], 101.0f);
}

// Half conversions (F16C where the CPU has it, eight at a time plus a tail): every value as Imath rounds
// it, finite values beyond half's range at the largest finite half, +-Inf kept, NaN still NaN.
TEST(Frame, HalfConversionsRoundAsImathAndSaturate) {
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<float> values{0.0f,   -0.0f,   0.1f,    1e-8f,   6.1e-5f, 1000.3f, 65504.0f, 65519.0f, 65520.0f,
                              7e4f,   -7e4f,   1e30f,   inf,     -inf,    3.14159f, -2.5e-3f, 1.0f + 1.0f / 2048.0f,
                              1.0f + 3.0f / 4096.0f, std::nanf(""), 12345.678f};
    for (int i = 0; i < 23; ++i) values.push_back(std::ldexp(1.37f, i - 16));  // 43 values: 5 blocks and a tail
    Frame f;
    f.spec = ImageSpec(static_cast<int>(values.size()), 1, 3, PixelType::half);
    f.pixels = PixelBuffer(f.spec.image_bytes());
    find_rgb_channels(f);
    f.rgb.resize(values.size() * 3);
    for (std::size_t i = 0; i < values.size(); ++i)
        for (std::size_t c = 0; c < 3; ++c) f.rgb[i * 3 + c] = c == 1 ? -values[i] : values[i];
    store_rgb(f);
    for (std::size_t i = 0; i < f.rgb.size(); ++i) {
        half h;
        std::memcpy(&h, f.pixels.data() + i * 2, 2);
        const float v = f.rgb[i];
        if (std::isnan(v)) {
            EXPECT_TRUE(h.isNan()) << i;
            continue;
        }
        const half expected(std::isfinite(v) ? std::clamp(v, -65504.0f, 65504.0f) : v);
        EXPECT_EQ(h.bits(), expected.bits()) << "value " << v;
    }
    load_rgb(f);
    for (std::size_t i = 0; i < f.rgb.size(); ++i) {
        half h;
        std::memcpy(&h, f.pixels.data() + i * 2, 2);
        if (h.isNan()) EXPECT_TRUE(std::isnan(f.rgb[i])) << i;
        else EXPECT_EQ(f.rgb[i], static_cast<float>(h)) << i;
    }
}

// A released RGB-only frame stored in its working buffer's own memory holds what store_rgb() writes, for
// every type whose pixel is at most 12 bytes.
TEST(Frame, StoreInPlaceEqualsStore) {
    for (PixelType type : {PixelType::half, PixelType::float32, PixelType::uint8, PixelType::uint16}) {
        Frame f;
        f.spec = ImageSpec(61, 53, 3, type);  // 3233 pixels: more than one block, the last one short
        f.pixels = PixelBuffer(f.spec.image_bytes());
        for (std::size_t i = 0; i < f.pixels.size(); ++i) f.pixels.data()[i] = static_cast<std::byte>((i * 37) % 251);
        find_rgb_channels(f);
        load_rgb(f);
        for (std::size_t i = 0; i < f.rgb.size(); ++i) f.rgb[i] = f.rgb[i] * 0.5f + 0.25f * static_cast<float>(i % 7);
        Frame expected = f;
        store_rgb(expected);
        ASSERT_TRUE(release_rgb_pixels(f));
        store_rgb_and_drop(f);
        EXPECT_TRUE(f.rgb.empty());
        ASSERT_EQ(f.pixels.size(), expected.pixels.size());
        EXPECT_EQ(std::memcmp(f.pixels.data(), expected.pixels.data(), f.pixels.size()), 0) << "type " << static_cast<int>(type);
        const PixelBuffer copy = f.pixels;  // an adopted buffer copies like any other
        EXPECT_EQ(std::memcmp(copy.data(), expected.pixels.data(), copy.size()), 0);
    }
}

// A luminance-only frame: Y (with A) stands in for R, G, B; stored back as the Rec. 709 weighted sum;
// Y beside R or chroma RY/BY is not luminance-only.
TEST(Frame, LuminanceOnlyLoadsGreyAndStoresLuminance) {
    Frame f;
    f.spec = ImageSpec(2, 1, 2, PixelType::float32);
    f.spec.channelnames = {"A", "Y"};
    f.pixels = PixelBuffer(f.spec.image_bytes());
    const float px[4] = {0.5f, 2.0f, 1.0f, 4.0f};
    std::memcpy(f.pixels.data(), px, sizeof px);
    find_rgb_channels(f);
    ASSERT_TRUE(f.luminance_only());
    load_rgb(f);
    EXPECT_EQ(f.rgb, (std::vector<float>{2.0f, 2.0f, 2.0f, 4.0f, 4.0f, 4.0f}));
    store_rgb(f);  // grey in, the same grey out, bit for bit
    EXPECT_EQ(std::memcmp(f.pixels.data(), px, sizeof px), 0);
    f.rgb = {1.0f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f};
    store_rgb(f);
    float out[4];
    std::memcpy(out, f.pixels.data(), sizeof out);
    EXPECT_EQ(out[0], 0.5f);  // A untouched
    EXPECT_NEAR(out[1], 0.2126f, 1e-6f);
    EXPECT_NEAR(out[3], 0.0722f, 1e-6f);
    for (const auto& names : {std::vector<std::string>{"Y", "RY"}, std::vector<std::string>{"R", "Y"}}) {
        f.spec.channelnames = names;
        find_rgb_channels(f);
        EXPECT_FALSE(f.has_rgb());
    }
}
