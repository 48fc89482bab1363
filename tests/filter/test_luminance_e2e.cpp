// Luminance-only inputs (issue 14): an EXR of Y (or Y and A) is flared as a grey R = G = B image and
// written back as Y, the luminance of the coloured result; luminance/chroma and odd channel sets are
// refused in one line. End to end through the program on small synthetic frames (llvmpipe, a second each).
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <OpenEXR/ImfRgbaFile.h>
#include <OpenImageIO/imageio.h>
#include <fmt/core.h>
#include <gtest/gtest.h>

#include "filter_test_util.h"

namespace fs = std::filesystem;
using namespace lensfx::test;

namespace {

constexpr int kWidth = 96, kHeight = 64;

// A grey scene of kWidth x kHeight: dim, with a bright disc at (30, 20); a few pixels NaN/Inf with `bad`.
std::vector<float> scene(bool bad = false) {
    std::vector<float> v(static_cast<std::size_t>(kWidth) * kHeight);
    for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x)
            v[static_cast<std::size_t>(y) * kWidth + static_cast<std::size_t>(x)] = std::hypot(x + 0.5 - 30.0, y + 0.5 - 20.0) < 2.5 ? 5000.0f : 0.05f;
    if (bad) {
        v[5] = std::numeric_limits<float>::quiet_NaN();
        v[700] = std::numeric_limits<float>::infinity();
        v[1500] = -std::numeric_limits<float>::infinity();
    }
    return v;
}

// Writes the scene with the named channels, each holding `fill(c)` (c: the channel's index) per pixel.
void write_exr(const fs::path& path, const std::vector<std::string>& names, const std::vector<float>& grey,
               const std::vector<float>& constant_of_channel = {}) {
    OIIO::ImageSpec spec(kWidth, kHeight, static_cast<int>(names.size()), OIIO::TypeHalf);
    spec.channelnames = names;
    std::vector<float> px(grey.size() * names.size());
    for (std::size_t i = 0; i < grey.size(); ++i)
        for (std::size_t c = 0; c < names.size(); ++c)
            px[i * names.size() + c] = c < constant_of_channel.size() && !std::isnan(constant_of_channel[c]) ? constant_of_channel[c] : grey[i];
    auto out = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(out && out->open(path.string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeFloat, px.data()));
    ASSERT_TRUE(out->close());
}

struct Image {
    std::vector<std::string> names;
    std::vector<float> px;  // interleaved
    int width = 0, height = 0;
    double at(int channel, std::size_t i) const { return px[i * names.size() + static_cast<std::size_t>(channel)]; }
};

Image read(const fs::path& path) {
    Image img;
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) return img;
    const OIIO::ImageSpec& s = in->spec();
    img.names = s.channelnames;
    img.width = s.width;
    img.height = s.height;
    img.px.resize(s.image_pixels() * static_cast<std::size_t>(s.nchannels));
    if (!in->read_image(0, 0, 0, s.nchannels, OIIO::TypeFloat, img.px.data())) img.px.clear();
    return img;
}

std::string lensfx_in(const fs::path& dir) { return fmt::format("LENSFX_CACHE_DIR={}/cache {}", dir.string(), lensfx_cmd()); }

const std::string kLens = " --lens brendel-tessar --fstop 4 --grid 8 --threshold 100 -q";

void expect_one_line_refusal(const RunResult& r, const std::string& mentions) {
    EXPECT_NE(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(r.stderr_text.rfind("lensfx: ", 0), 0u) << r.stderr_text;
    EXPECT_EQ(std::count(r.stderr_text.begin(), r.stderr_text.end(), '\n'), 1) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find(mentions), std::string::npos) << "expected \"" << mentions << "\" in: " << r.stderr_text;
}

}  // namespace

// A Y-only frame gets the flare's luminance: the same as flaring the grey RGB frame and taking the
// Rec. 709 luminance of the result (to half precision), and the output stays one channel Y.
TEST(Luminance, YOnlyGetsTheLuminanceOfTheColouredFlare) {
    const auto dir = scratch_dir("luminance-y");
    const std::string d = dir.string();
    write_exr(dir / "y.exr", {"Y"}, scene());
    write_exr(dir / "rgb.exr", {"R", "G", "B"}, scene());
    const auto y = run(lensfx_in(dir) + fmt::format(" -i {0}/y.exr -o {0}/y_out.exr", d) + kLens);
    ASSERT_EQ(y.exit_code, 0) << y.stderr_text;
    const auto rgb = run(lensfx_in(dir) + fmt::format(" -i {0}/rgb.exr -o {0}/rgb_out.exr", d) + kLens);
    ASSERT_EQ(rgb.exit_code, 0) << rgb.stderr_text;
    const Image yo = read(dir / "y_out.exr"), co = read(dir / "rgb_out.exr");
    ASSERT_EQ(yo.names, std::vector<std::string>{"Y"});
    ASSERT_EQ(co.names.size(), 3u);
    ASSERT_EQ(yo.px.size() * 3, co.px.size());
    double added = 0.0, colour_spread = 0.0;
    for (std::size_t i = 0; i < yo.px.size(); ++i) {
        const double lum = 0.2126 * co.at(0, i) + 0.7152 * co.at(1, i) + 0.0722 * co.at(2, i);
        ASSERT_NEAR(yo.at(0, i), lum, 2e-3 * std::abs(lum) + 1e-6) << "pixel " << i;
        added += yo.at(0, i) - 0.05;
        colour_spread = std::max(colour_spread, std::abs(co.at(0, i) - co.at(2, i)));
    }
    EXPECT_GT(colour_spread, 1e-4) << "the flare of the RGB run should be coloured";
    EXPECT_GT(added, 0.0) << "the flare should add light";
    // Away from the light the flare is there: pixels left of and below it differ from the plate's 0.05.
    std::size_t changed = 0;
    for (std::size_t i = 0; i < yo.px.size(); ++i) changed += std::abs(yo.px[i] - 0.05f) > 1e-4f && yo.px[i] < 1000.0f;
    EXPECT_GT(changed, 100u);
    fs::remove_all(dir);
}

// Y with A: A passes through bit for bit; NaN and Inf pixels in Y make no new NaN.
TEST(Luminance, YAKeepsAlphaAndNonFinitePixelsStayPut) {
    const auto dir = scratch_dir("luminance-ya");
    const std::string d = dir.string();
    write_exr(dir / "ya.exr", {"Y", "A"}, scene(true), {std::nanf(""), 0.5f});
    const auto r = run(lensfx_in(dir) + fmt::format(" -i {0}/ya.exr -o {0}/out.exr", d) + kLens);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    const Image in = read(dir / "ya.exr"), out = read(dir / "out.exr");
    ASSERT_EQ(out.names, in.names);
    const int y = in.names[0] == "Y" ? 0 : 1, a = 1 - y;
    std::size_t nan_in = 0, nan_out = 0, changed = 0;
    for (std::size_t i = 0; i < static_cast<std::size_t>(kWidth) * kHeight; ++i) {
        EXPECT_EQ(out.at(a, i), in.at(a, i));
        nan_in += std::isnan(in.at(y, i));
        nan_out += std::isnan(out.at(y, i));
        changed += out.at(y, i) != in.at(y, i);
    }
    EXPECT_EQ(nan_out, nan_in);
    EXPECT_GT(changed, 100u);
    fs::remove_all(dir);
}

// Greyscale PFM (one channel, read as Y): flared and written back as greyscale PFM.
TEST(Luminance, GreyscalePfmStaysGreyscale) {
    const auto dir = scratch_dir("luminance-pfm");
    const std::string d = dir.string();
    write_exr(dir / "y.exr", {"Y"}, scene());
    ASSERT_EQ(run(fmt::format("{0} -i {1}/y.exr -o {1}/y.pfm", lensfx_cmd(), d)).exit_code, 0);
    const auto r = run(lensfx_in(dir) + fmt::format(" -i {0}/y.pfm -o {0}/out.pfm", d) + kLens);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    const Image out = read(dir / "out.pfm");
    ASSERT_EQ(out.names.size(), 1u);
    ASSERT_EQ(out.px.size(), static_cast<std::size_t>(kWidth) * kHeight);
    std::size_t changed = 0;
    for (float v : out.px) changed += std::abs(v - 0.05f) > 1e-4f && v < 1000.0f;
    EXPECT_GT(changed, 100u);
    fs::remove_all(dir);
}

// What is not luminance alone is refused in one line naming the channels: luminance/chroma (Y, RY, BY,
// whole or subsampled as OpenEXR's RGBA interface writes it), a lower-case "y", R and G without B.
TEST(Luminance, ChromaAndOddChannelSetsAreRefusedInOneLine) {
    const auto dir = scratch_dir("luminance-refused");
    const std::string d = dir.string();
    write_exr(dir / "yc.exr", {"Y", "RY", "BY"}, scene(), {std::nanf(""), 0.0f, 0.0f});
    expect_one_line_refusal(run(lensfx_in(dir) + fmt::format(" -i {0}/yc.exr -o {0}/out.exr", d) + kLens), "RY");
    {
        Imf::RgbaOutputFile file((dir / "sub.exr").c_str(), kWidth, kHeight, Imf::WRITE_YC);
        std::vector<Imf::Rgba> px(static_cast<std::size_t>(kWidth) * kHeight, Imf::Rgba(0.2f, 0.1f, 0.05f, 1.0f));
        file.setFrameBuffer(px.data(), 1, kWidth);
        file.writePixels(kHeight);
    }
    expect_one_line_refusal(run(lensfx_in(dir) + fmt::format(" -i {0}/sub.exr -o {0}/out.exr", d) + kLens), "luminance/chroma");
    write_exr(dir / "lower.exr", {"y"}, scene());
    expect_one_line_refusal(run(lensfx_in(dir) + fmt::format(" -i {0}/lower.exr -o {0}/out.exr", d) + kLens),
                            "this frame has y (to flare one channel, copy it to R, G, B: oiiotool IN --ch R=y,G=y,B=y -o OUT)");
    write_exr(dir / "rg.exr", {"R", "G"}, scene());
    expect_one_line_refusal(run(lensfx_in(dir) + fmt::format(" -i {0}/rg.exr -o {0}/out.exr", d) + kLens), "this frame has");
    EXPECT_FALSE(fs::exists(dir / "out.exr"));
    fs::remove_all(dir);
}

// Tiny and huge windows of Y: a 1 x 1 frame runs; 8 x 8 of data in a 30000 x 30000 display window is
// refused by the memory budget in one line (or passed through without materialising it); a memory limit
// too small for anything refuses in one line and writes nothing.
TEST(Luminance, TinyHugeAndStarvedYFrames) {
    const auto dir = scratch_dir("luminance-windows");
    const std::string d = dir.string();
    {
        OIIO::ImageSpec spec(1, 1, 1, OIIO::TypeHalf);
        spec.channelnames = {"Y"};
        const float v = 5000.0f;
        auto out = OIIO::ImageOutput::create((dir / "one.exr").string());
        ASSERT_TRUE(out && out->open((dir / "one.exr").string(), spec) && out->write_image(OIIO::TypeFloat, &v) && out->close());
    }
    const auto one = run(lensfx_in(dir) + fmt::format(" -i {0}/one.exr -o {0}/one_out.exr", d) + kLens);
    EXPECT_EQ(one.exit_code, 0) << one.stderr_text;
    {
        OIIO::ImageSpec spec(8, 8, 1, OIIO::TypeHalf);
        spec.channelnames = {"Y"};
        spec.x = spec.y = 4;
        spec.full_width = spec.full_height = 30000;
        std::vector<float> v(64, 5000.0f);
        auto out = OIIO::ImageOutput::create((dir / "huge.exr").string());
        ASSERT_TRUE(out && out->open((dir / "huge.exr").string(), spec) && out->write_image(OIIO::TypeFloat, v.data()) && out->close());
    }
    expect_one_line_refusal(run(lensfx_in(dir) + fmt::format(" -i {0}/huge.exr -o {0}/out.exr --memory-limit 2G", d) + kLens),
                            "memory limit");
    const auto pass = run(fmt::format("{0} -i {1}/huge.exr -o {1}/pass.exr --memory-limit 2G", lensfx_cmd(), d));
    EXPECT_EQ(pass.exit_code, 0) << pass.stderr_text;
    write_exr(dir / "y.exr", {"Y"}, scene());
    expect_one_line_refusal(run(lensfx_in(dir) + fmt::format(" -i {0}/y.exr -o {0}/out.exr --memory-limit 1K", d) + kLens),
                            "memory limit");
    EXPECT_FALSE(fs::exists(dir / "out.exr"));
    fs::remove_all(dir);
}
