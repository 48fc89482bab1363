// Stereo EXR through the lensfx program: each view is flared from its own pixels (its lamp sits elsewhere
// by the disparity), --views picks views, and a view not picked passes bit for bit.
#include <gtest/gtest.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringVectorAttribute.h>
#include <fmt/core.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "filter_test_util.h"

namespace {

namespace fs = std::filesystem;
using lensfx::test::lensfx_cmd;
using lensfx::test::run;

constexpr int W = 96, H = 48;
constexpr int kRightLampX = 66, kLeftLampX = 30, kLampY = 24;  // right is the default view

// A float RGB plane on a dim background with a 3x3 lamp of 5000 around (x, kLampY).
std::vector<float> plane(int lamp_x, int c) {
    std::vector<float> px(W * H, 0.01f * static_cast<float>(c + 1));
    for (int y = kLampY - 1; y <= kLampY + 1; ++y)
        for (int x = lamp_x - 1; x <= lamp_x + 1; ++x) px[static_cast<std::size_t>(y * W + x)] = 5000.0f;
    return px;
}

// Views right (default: R, G, B) and left (left.R, left.G, left.B), as the multiView attribute names them;
// over the whole W x H display window, or only the central half of it (`inner`).
void write_stereo(const fs::path& path, bool inner = false) {
    const Imath::Box2i display({0, 0}, {W - 1, H - 1});
    const Imath::Box2i data = inner ? Imath::Box2i({W / 4, H / 4}, {3 * W / 4 - 1, 3 * H / 4 - 1}) : display;
    Imf::Header header(display, data);
    header.insert("multiView", Imf::StringVectorAttribute({"right", "left"}));
    std::vector<std::vector<float>> planes;
    planes.reserve(6);  // the slices point into them
    Imf::FrameBuffer fb;
    const char* names[] = {"R", "G", "B"};
    for (const auto& [prefix, lamp] : {std::pair<std::string, int>{"", kRightLampX}, {"left.", kLeftLampX}})
        for (int c = 0; c < 3; ++c) {
            const std::string name = prefix + names[c];
            header.channels().insert(name, Imf::Channel(Imf::FLOAT));
            planes.push_back(plane(lamp, c));
            fb.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(planes.back().data()), sizeof(float), sizeof(float) * W));
        }
    Imf::OutputFile out(path.c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(data.max.y - data.min.y + 1);
}

// A channel over the W x H display window: -1 where the file has no such channel, 0 outside its data window.
std::vector<float> read_channel(const fs::path& path, const std::string& name) {
    std::vector<float> px(W * H, 0.0f);
    Imf::InputFile in(path.c_str());
    const Imath::Box2i data = in.header().dataWindow();
    Imf::FrameBuffer fb;
    fb.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(px.data()), sizeof(float), sizeof(float) * W, 1, 1, -1.0));
    in.setFrameBuffer(fb);
    in.readPixels(data.min.y, data.max.y);
    return px;
}

// The x of the centroid of what the flare added to a channel (away from the lamp's own pixels).
double added_centroid_x(const std::vector<float>& before, const std::vector<float>& after, double& total) {
    double sum = 0, sum_x = 0;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const std::size_t i = static_cast<std::size_t>(y * W + x);
            if (before[i] > 100.0f) continue;
            const double d = static_cast<double>(after[i] - before[i]);
            sum += d;
            sum_x += d * x;
        }
    total = sum;
    return sum > 0 ? sum_x / sum : -1.0;
}

TEST(Views, EachViewIsFlaredFromItsOwnLamp) {
    const fs::path dir = lensfx::test::scratch_dir("views");
    write_stereo(dir / "stereo.exr");
    const std::string flare = " -q --lens cooke-triplet --threshold 1000 --parts starburst --starburst-scale 4 --gain 50";
    auto r = run(lensfx_cmd() + fmt::format(" -i {0}/stereo.exr -o {0}/both.exr", dir.string()) + flare);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    for (const auto& [view, lamp] : {std::pair<std::string, int>{"", kRightLampX}, {"left.", kLeftLampX}}) {
        double total = 0;
        const double cx = added_centroid_x(read_channel(dir / "stereo.exr", view + "G"), read_channel(dir / "both.exr", view + "G"), total);
        EXPECT_GT(total, 0.0) << view;
        EXPECT_NEAR(cx, lamp, 3.0) << "view " << (view.empty() ? "right" : view);
    }
    // Only the left view: the right view's pixels pass bit for bit.
    r = run(lensfx_cmd() + fmt::format(" -i {0}/stereo.exr -o {0}/left.exr --views left", dir.string()) + flare);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    for (const char* c : {"R", "G", "B"}) EXPECT_EQ(read_channel(dir / "left.exr", c), read_channel(dir / "stereo.exr", c)) << c;
    EXPECT_NE(read_channel(dir / "left.exr", "left.G"), read_channel(dir / "stereo.exr", "left.G"));
    EXPECT_EQ(read_channel(dir / "left.exr", "left.G"), read_channel(dir / "both.exr", "left.G"));
    // A view the file does not have.
    r = run(lensfx_cmd() + fmt::format(" -i {0}/stereo.exr -o {0}/x.exr --views centre", dir.string()) + flare);
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("no view \"centre\" (its views: right, left)"), std::string::npos) << r.stderr_text;
    fs::remove_all(dir);
}

// A data window inside the display window: the flare of the view picked grows it (every view's channels with
// it), and the default view, not picked, passes as it was, 0 where the window grew (a failure before: the default
// view's working buffer kept the old window's size).
TEST(Views, AViewPickedAloneMayGrowTheDataWindow) {
    const fs::path dir = lensfx::test::scratch_dir("views-window");
    write_stereo(dir / "inner.exr", true);
    const std::string flare = " -q --lens cooke-triplet --threshold 1000 --parts starburst --starburst-scale 4 --gain 50";
    const auto r = run(lensfx_cmd() + fmt::format(" -i {0}/inner.exr -o {0}/left.exr --views left", dir.string()) + flare);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    const Imath::Box2i grown = Imf::InputFile((dir / "left.exr").c_str()).header().dataWindow();
    EXPECT_LT(grown.min.x, W / 4);  // the starburst reaches beyond the input's window
    for (const char* c : {"R", "G", "B"}) EXPECT_EQ(read_channel(dir / "left.exr", c), read_channel(dir / "inner.exr", c)) << c;
    double total = 0;
    const double cx = added_centroid_x(read_channel(dir / "inner.exr", "left.G"), read_channel(dir / "left.exr", "left.G"), total);
    EXPECT_GT(total, 0.0);
    EXPECT_NEAR(cx, kLeftLampX, 3.0);
    fs::remove_all(dir);
}

}  // namespace
