// The flare stage: pixel -> direction mapping, the light's strength from its recorded energy, and the
// filter end to end on a synthetic frame with one light (ghost energy in a physical range, determinism,
// frames without a light left untouched).
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <gtest/gtest.h>

#include "run_lensfx.h"

#include <filter/flare_stage.h>
#include <filter/pupil_options.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/system.h>

namespace fs = std::filesystem;
using namespace lensfx;

namespace {

fs::path temp_dir(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / ("lensfx_flare_stage_" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

// A 320x200 frame, dim grey, with one small bright disc (radius 2 px, value `peak`) at (x, y).
void write_frame(const fs::path& path, double x, double y, float peak) {
    OIIO::ImageSpec spec(320, 200, 3, OIIO::TypeDesc::HALF);
    OIIO::ImageBuf buf(spec);
    const float grey[3] = {0.05f, 0.05f, 0.05f};
    OIIO::ImageBufAlgo::fill(buf, grey);
    for (int j = 0; j < 200; ++j)
        for (int i = 0; i < 320; ++i)
            if (std::hypot(i + 0.5 - x, j + 0.5 - y) <= 2.0) {
                const float v[3] = {peak, peak, peak};
                buf.setpixel(i, j, v);
            }
    ASSERT_TRUE(buf.write(path.string()));
}

std::vector<float> read_rgb(const fs::path& path) {
    OIIO::ImageBuf buf(path.string());
    EXPECT_TRUE(buf.read(0, 0, true, OIIO::TypeDesc::FLOAT)) << path;
    std::vector<float> px(static_cast<std::size_t>(buf.spec().width * buf.spec().height * 3));
    buf.get_pixels(OIIO::ROI(0, buf.spec().width, 0, buf.spec().height, 0, 1, 0, 3), OIIO::TypeDesc::FLOAT, px.data());
    return px;
}

int run(const std::string& args) {
    return lensfx::test::run_lensfx_status(args + " 2>&1");
}

}  // namespace

TEST(FlareStage, PartsParse) {
    EXPECT_TRUE(filter::parse_parts("ghosts").ghosts);
    EXPECT_FALSE(filter::parse_parts("ghosts").starburst);
    EXPECT_TRUE(filter::parse_parts("starburst,ghosts").ghosts);
    EXPECT_THROW(filter::parse_parts("ghosts,glow"), std::invalid_argument);
}

TEST(FlareStage, AddsGhostsAtPhysicalStrengthAndIsDeterministic) {
    const fs::path dir = temp_dir("e2e");
    write_frame(dir / "in.exr", 230.3, 60.6, 20000.0f);
    const std::string common = " --lens brendel-tessar --fstop 4 --threshold 100 --grid 48 -q";
    ASSERT_EQ(run("-i " + (dir / "in.exr").string() + " -o " + (dir / "a.exr").string() + " --flare-only --parts ghosts" + common), 0);
    ASSERT_EQ(run("-i " + (dir / "in.exr").string() + " -o " + (dir / "b.exr").string() + " --flare-only --parts ghosts" + common), 0);
    const std::vector<float> a = read_rgb(dir / "a.exr");
    const std::vector<float> b = read_rgb(dir / "b.exr");
    ASSERT_EQ(a, b) << "the same input and options must give the same flare";

    const std::vector<float> in = read_rgb(dir / "in.exr");
    double source = 0.0, flare = 0.0;
    for (std::size_t i = 0; i < in.size(); ++i) {
        ASSERT_TRUE(std::isfinite(a[i]));
        ASSERT_GE(a[i], 0.0f);
        if (in[i] > 1.0f) source += static_cast<double>(in[i]);
        flare += static_cast<double>(a[i]);
    }
    // Ghosts of a coated Tessar carry a small fraction of the light: each reflection of a coated
    // surface returns well under 4%, and a ghost needs two.
    EXPECT_GT(flare, 1e-6 * source);
    EXPECT_LT(flare, 1e-2 * source);
    // The ghosts lie along the line from the light through the centre: more flare in the lower left
    // half of the frame (opposite the light, which is up and right) than the light's own quadrant shows
    // away from its ghost line is not guaranteed, but the flare must not be empty on the opposite side.
    double opposite = 0.0;
    for (int y = 100; y < 200; ++y)
        for (int x = 0; x < 160; ++x) opposite += static_cast<double>(a[static_cast<std::size_t>((y * 320 + x) * 3 + 1)]);
    EXPECT_GT(opposite, 0.0);
}

TEST(FlareStage, FrameWithoutALightPassesThroughUnchanged) {
    const fs::path dir = temp_dir("dark");
    write_frame(dir / "in.exr", 100.0, 100.0, 0.5f);  // nothing near the threshold
    ASSERT_EQ(run("-i " + (dir / "in.exr").string() + " -o " + (dir / "out.exr").string() +
                  " --lens brendel-tessar --threshold 20 -q"), 0);
    EXPECT_EQ(read_rgb(dir / "in.exr"), read_rgb(dir / "out.exr"));
}

TEST(FlareStage, ApertureImageIsGreyAndPaddedToASquare) {
    const fs::path dir = temp_dir("aperture_image");
    OIIO::ImageSpec spec(6, 3, 4, OIIO::TypeDesc::FLOAT);
    spec.alpha_channel = 3;
    OIIO::ImageBuf buf(spec);
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 6; ++i) {
            const float v[4] = {0.1f * static_cast<float>(i), 0.2f, 2.0f, 0.0f};  // alpha must not count
            buf.setpixel(i, j, v);
        }
    ASSERT_TRUE(buf.write((dir / "iris.exr").string()));
    const optics::ApertureImage image = filter::read_aperture_image((dir / "iris.exr").string());
    ASSERT_EQ(image.width, 6);
    ASSERT_EQ(image.height, 6);
    for (int i = 0; i < 6; ++i) {
        EXPECT_EQ(image.value[static_cast<std::size_t>(i)], 0.0f) << "the rows added above the image are opaque";
        EXPECT_EQ(image.value[static_cast<std::size_t>(5 * 6 + i)], 0.0f);
        EXPECT_NEAR(image.value[static_cast<std::size_t>(2 * 6 + i)], std::min(1.0, (0.1 * i + 0.2 + 2.0) / 3.0), 1e-6);
    }
    try {
        filter::read_aperture_image((dir / "missing.png").string());
        FAIL() << "a missing aperture image must throw";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("missing.png"), std::string::npos) << e.what();
    }
}

TEST(FlareStage, DirtOnThePupilScattersTheStarburst) {
    const fs::path dir = temp_dir("dirt");
    write_frame(dir / "in.exr", 160.0, 100.0, 20000.0f);
    // A sensor 30x smaller than full frame (pixels of 3.75 um) so that the pattern, dirt and all, spans
    // many pixels of this small frame (--starburst-scale lengthens the edges' spikes, not the pattern).
    const std::string common = " --lens brendel-tessar --fstop 8 --threshold 100 --flare-only --parts starburst"
                               " --sensor 1.2 -q";
    ASSERT_EQ(run("-i " + (dir / "in.exr").string() + " -o " + (dir / "clean.exr").string() + common), 0);
    ASSERT_EQ(run("-i " + (dir / "in.exr").string() + " -o " + (dir / "scratched.exr").string() + common +
                  " --scratches 60 --scratch-angle 0 --scratch-spread 0"), 0);
    ASSERT_EQ(run("-i " + (dir / "in.exr").string() + " -o " + (dir / "dusty.exr").string() + common +
                  " --dust 300 --dirt-seed 7"), 0);
    const std::vector<float> clean = read_rgb(dir / "clean.exr");
    // Energy in a vertical and a horizontal band through the light, outside its core.
    const auto bands = [](const std::vector<float>& img) {
        std::array<double, 3> b{};  // vertical, horizontal, all
        for (int y = 0; y < 200; ++y)
            for (int x = 0; x < 320; ++x) {
                const double v = static_cast<double>(img[static_cast<std::size_t>((y * 320 + x) * 3 + 1)]);
                EXPECT_TRUE(std::isfinite(v));
                const bool core = std::hypot(x - 160, y - 100) < 6.0;
                if (!core && std::abs(x - 160) < 4) b[0] += v;
                if (!core && std::abs(y - 100) < 4) b[1] += v;
                b[2] += v;
            }
        return b;
    };
    const auto c = bands(clean);
    const auto s = bands(read_rgb(dir / "scratched.exr"));
    const auto d = bands(read_rgb(dir / "dusty.exr"));
    ASSERT_GT(c[0], 0.0);
    ASSERT_GT(c[1], 0.0);
    // Horizontal scratches diffract across themselves: vertical streaks.
    EXPECT_GT(s[0] - c[0], 2.0 * std::abs(s[1] - c[1])) << s[0] << " " << c[0] << " " << s[1] << " " << c[1];
    EXPECT_GT(s[0], 1.05 * c[0]);
    // Dirt scatters light out of the core the light's own pixels hold, so more is added around it, never less.
    EXPECT_GT(d[2], c[2]);
    EXPECT_GT(s[2], 0.99 * c[2]);

    EXPECT_NE(run("-i " + (dir / "in.exr").string() + " -o " + (dir / "bad.exr").string() + common +
                  " --aperture-image " + (dir / "no-such-iris.png").string()), 0);
    EXPECT_FALSE(fs::exists(dir / "bad.exr"));
}
