// End to end: the lensfx program tone maps files as the README says, and its outputs agree with the colour
// module (itself checked against OCIO in test_colour.cpp). The README's ffmpeg pipelines are run by
// tests/filter/test_readme_pipes.cpp.
#include <filter/colour.h>
#include <gpu/context.h>

#include <gtest/gtest.h>

#include "run_lensfx.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace {

using namespace lensfx::colour;
namespace fs = std::filesystem;

constexpr int W = 64, H = 32;

using Result = lensfx::test::ProgramRun;  // the status, and what it wrote (its errors) in `output`

class ColourEndToEnd : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("lensfx_colour_e2e_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    // Left half `left`, right half `right` (RGB), as a half-float EXR; with chromaticities when given.
    void write_exr(const std::string& name, std::array<float, 3> left, std::array<float, 3> right,
                   const std::optional<std::array<float, 8>>& chroma = std::nullopt) const {
        std::vector<float> px(W * H * 3);
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x)
                for (int c = 0; c < 3; ++c) px[static_cast<std::size_t>((y * W + x) * 3 + c)] = (x < W / 2 ? left : right)[c];
        OIIO::ImageSpec spec(W, H, 3, OIIO::TypeHalf);
        if (chroma) spec.attribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), chroma->data());
        auto out = OIIO::ImageOutput::create(path(name));
        ASSERT_TRUE(out && out->open(path(name), spec) && out->write_image(OIIO::TypeFloat, px.data()) && out->close());
    }

    // Runs lensfx with `args` (the one helper of tests/common/run_lensfx.h).
    static Result run(const std::string& args) { return lensfx::test::run_lensfx(args); }

    fs::path dir_;
};

std::vector<float> read_pixels(const std::string& file, OIIO::ImageSpec* spec_out = nullptr) {
    auto in = OIIO::ImageInput::open(file);
    if (!in) return {};
    const OIIO::ImageSpec spec = in->spec();
    std::vector<float> px(static_cast<std::size_t>(spec.width * spec.height * spec.nchannels));
    in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeFloat, px.data());
    if (spec_out) *spec_out = spec;
    return px;
}

// Mean of channel c over one half of a W x H RGB image.
double half_mean(const std::vector<float>& px, bool right, int c, int channels = 3) {
    double sum = 0;
    for (int y = 0; y < H; ++y)
        for (int x = right ? W / 2 : 0; x < (right ? W : W / 2); ++x)
            sum += static_cast<double>(px[static_cast<std::size_t>((y * W + x) * channels + c)]);
    return sum / (W / 2 * H);
}

float expected_display(const std::string& display, std::array<float, 3> rgb, int c) {
    ColourOptions o;
    o.display = display;
    ColourPipeline p(ColourConfig::builtin_config(), o, std::nullopt);
    p.to_display().apply_rgb(rgb.data(), 1);
    return rgb[static_cast<std::size_t>(c)];
}

// ----------------------------------------------------------------------------------------------------------

TEST_F(ColourEndToEnd, PngIsToneMappedWithDitherThatKeepsTheMean) {
    write_exr("in.exr", {0.18f, 0.18f, 0.18f}, {50.f, 50.f, 50.f});
    ASSERT_EQ(run("-i " + path("in.exr") + " -o " + path("out.png")).status, 0);
    OIIO::ImageSpec spec;
    const auto px = read_pixels(path("out.png"), &spec);
    ASSERT_EQ(spec.format, OIIO::TypeUInt8);
    EXPECT_EQ(spec.get_string_attribute("oiio:ColorSpace"), "sRGB");
    const double grey = static_cast<double>(expected_display("srgb", {0.18f, 0.18f, 0.18f}, 0));
    EXPECT_NEAR(grey, 0.356, 1e-3);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(half_mean(px, false, c), grey, 0.3 / 255);  // dithered: the mean, not just the nearest code
        EXPECT_EQ(half_mean(px, true, c), 1.0);
    }
    for (std::size_t i = 0; i < px.size(); ++i) {
        if ((i / 3) % W < W / 2) {
            EXPECT_LE(std::abs(static_cast<double>(px[i]) - grey), 1.0 / 255) << i;
        }
    }

    ASSERT_EQ(run("-i " + path("in.exr") + " -o " + path("out16.png") + " --bits 16").status, 0);
    const auto px16 = read_pixels(path("out16.png"), &spec);
    ASSERT_EQ(spec.format, OIIO::TypeUInt16);
    EXPECT_NEAR(half_mean(px16, false, 1), grey, 0.3 / 65535);
}

// A PNG's alpha is straight by its specification: a premultiplied EXR pixel (0.09 at alpha 0.5, a surface
// of 0.18) is written with the surface's display value, as an opaque 0.18 is, and its alpha. Premultiplied
// display values (or OpenImageIO's division of them, in display space) would make every soft edge too dark
// (or too bright) once the PNG is composited.
TEST_F(ColourEndToEnd, PngHoldsStraightColourOfAPremultipliedInput) {
    std::vector<float> px(W * H * 4);
    for (std::size_t i = 0; i < px.size(); i += 4) px[i] = px[i + 1] = px[i + 2] = 0.09f, px[i + 3] = 0.5f;
    OIIO::ImageSpec spec(W, H, 4, OIIO::TypeHalf);
    spec.alpha_channel = 3;
    auto out = OIIO::ImageOutput::create(path("in.exr"));
    ASSERT_TRUE(out && out->open(path("in.exr"), spec) && out->write_image(OIIO::TypeFloat, px.data()) && out->close());
    ASSERT_EQ(run("-i " + path("in.exr") + " -o " + path("out.png")).status, 0);
    OIIO::ImageSpec raw_config;
    raw_config.attribute("oiio:UnassociatedAlpha", 1);  // the file's own values, not OpenImageIO's premultiplied ones
    auto in = OIIO::ImageInput::open(path("out.png"), &raw_config);
    ASSERT_TRUE(in);
    ASSERT_EQ(in->spec().nchannels, 4);
    std::vector<float> png(W * H * 4);
    ASSERT_TRUE(in->read_image(0, 0, 0, 4, OIIO::TypeFloat, png.data()));
    const double surface = static_cast<double>(expected_display("srgb", {0.18f, 0.18f, 0.18f}, 0));
    double colour = 0, alpha = 0;
    for (std::size_t i = 0; i < png.size(); i += 4) colour += static_cast<double>(png[i + 1]), alpha += static_cast<double>(png[i + 3]);
    EXPECT_NEAR(colour / (W * H), surface, 0.5 / 255);
    EXPECT_NEAR(alpha / (W * H), 0.5, 0.5 / 255);
}

TEST_F(ColourEndToEnd, SceneLinearOutputsAreUntouchedUnlessAsked) {
    write_exr("in.exr", {0.18f, 0.05f, 0.6f}, {3.f, 2.f, 1.f});
    ASSERT_EQ(run("-i " + path("in.exr") + " -o " + path("same.exr")).status, 0);
    EXPECT_EQ(read_pixels(path("same.exr")), read_pixels(path("in.exr")));

    ASSERT_EQ(run("-i " + path("in.exr") + " -o " + path("shown.exr") + " --display rec709").status, 0);
    const auto shown = read_pixels(path("shown.exr"));
    for (int c = 0; c < 3; ++c) {
        // Written as half: within half precision of the module's value.
        EXPECT_NEAR(half_mean(shown, false, c), expected_display("rec709", {0.18f, 0.05f, 0.6f}, c), 1e-3);
        EXPECT_NEAR(half_mean(shown, true, c), expected_display("rec709", {3.f, 2.f, 1.f}, c), 1e-3);
    }

    // Exposure applies to scene-linear outputs too: +1 EV doubles them.
    ASSERT_EQ(run("-i " + path("in.exr") + " -o " + path("bright.exr") + " --exposure 1").status, 0);
    EXPECT_NEAR(half_mean(read_pixels(path("bright.exr")), true, 0), 6.0, 1e-3);
}

TEST_F(ColourEndToEnd, ChromaticitiesOfTheFileChooseTheInputSpace) {
    // The same colour stored as Rec.709 and as ACES AP0 (with the EXR attribute saying so) displays the same.
    const std::array<double, 3> rec709{0.6, 0.2, 0.05};
    const auto ap0 = chromaticities(KnownPrimaries::AcesAP0);
    const Mat3 m = multiply(inverse(rgb_to_xyz(ap0)),
                            multiply(bradford(0.3127, 0.3290, ap0.wx, ap0.wy), rgb_to_xyz(chromaticities(KnownPrimaries::Rec709))));
    std::array<float, 3> in_ap0{};
    for (int i = 0; i < 3; ++i)
        in_ap0[static_cast<std::size_t>(i)] =
            static_cast<float>(m[3 * i] * rec709[0] + m[3 * i + 1] * rec709[1] + m[3 * i + 2] * rec709[2]);
    const std::array<float, 8> ap0_attr{0.7347f, 0.2653f, 0.0f, 1.0f, 0.0001f, -0.077f, 0.32168f, 0.33767f};
    write_exr("rec709.exr", {0.6f, 0.2f, 0.05f}, {0.6f, 0.2f, 0.05f});
    write_exr("ap0.exr", in_ap0, in_ap0, ap0_attr);
    ASSERT_EQ(run("-i " + path("rec709.exr") + " -o " + path("a.exr") + " --display srgb").status, 0);
    ASSERT_EQ(run("-i " + path("ap0.exr") + " -o " + path("b.exr") + " --display srgb").status, 0);
    const auto a = read_pixels(path("a.exr")), b = read_pixels(path("b.exr"));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(half_mean(a, false, c), half_mean(b, false, c), 2e-3) << c;
}

TEST_F(ColourEndToEnd, UnknownNamesFailWithTheValidOnes) {
    write_exr("in.exr", {0.18f, 0.18f, 0.18f}, {1.f, 1.f, 1.f});
    Result r = run("-i " + path("in.exr") + " -o " + path("out.png") + " --display cinema");
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.output.find("unknown display 'cinema'"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("srgb, rec709, rec2100-pq"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(path("out.png")));
    r = run("-i " + path("in.exr") + " -o " + path("out.png") + " --colorspace 'Log C'");
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.output.find("unknown colour space 'Log C'"), std::string::npos) << r.output;
    r = run("-i " + path("in.exr") + " -o " + path("out.png") + " --ocio " + path("missing.ocio"));
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.output.find(path("missing.ocio")), std::string::npos) << r.output;
}

// A studio config whose colour spaces have none of the usual names: an input without chromaticities is
// taken in its scene_linear role (as oiiotool takes an untagged image), shown on its default display and view.
TEST_F(ColourEndToEnd, StudioConfigRolesAndDefaultDisplay) {
    std::ofstream(path("studio.ocio")) << R"(ocio_profile_version: 2
roles:
  scene_linear: plate linear
  default: plate linear
file_rules:
  - !<Rule> {name: Default, colorspace: default}
displays:
  studio monitor:
    - !<View> {name: film, colorspace: monitor film}
    - !<View> {name: raw, colorspace: plate linear}
active_displays: [studio monitor]
active_views: [film, raw]
colorspaces:
  - !<ColorSpace>
    name: plate linear
    encoding: scene-linear
  - !<ColorSpace>
    name: monitor film
    from_scene_reference: !<ExponentTransform> {value: [2, 2, 2, 1], direction: inverse}
)";
    write_exr("in.exr", {0.25f, 0.25f, 0.25f}, {0.04f, 0.04f, 0.04f});
    const std::string base = "-i " + path("in.exr") + " --ocio " + path("studio.ocio") + " --dither none";
    Result r = run(base + " -o " + path("roles.png"));
    ASSERT_EQ(r.status, 0) << r.output;
    const auto px = read_pixels(path("roles.png"));
    ASSERT_EQ(px.size(), static_cast<std::size_t>(W * H * 3));
    // The film view: the square root of scene-linear.
    EXPECT_NEAR(half_mean(px, false, 0), 0.5, 0.6 / 255);
    EXPECT_NEAR(half_mean(px, true, 1), 0.2, 0.6 / 255);
    // The same as naming the colour space, the display and the view.
    r = run(base + " --colorspace 'plate linear' --display 'studio monitor' --view film -o " + path("named.png"));
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_EQ(read_pixels(path("named.png")), px);
}

// The same frame through the filter with the output transform on the GPU and on the CPU: every display
// of the built-in config, with --gpu and with a flare (whose stage makes the context the transform then
// shares), agrees within 1e-4, and NaN/Inf in the input never reach either output. About 10 s.
TEST_F(ColourEndToEnd, GpuAndCpuOutputTransformsAgree) {
    try {
        lensfx::gpu::Context probe(lensfx::gpu::Platform::Surfaceless);
    } catch (const std::exception& e) {
        GTEST_SKIP() << "no EGL/OpenGL 4.3 context: " << e.what();
    }
    // A ramp over 20 stops, a bright light for the flare stage, and NaN/Inf pixels.
    std::vector<float> px(W * H * 3);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            for (int c = 0; c < 3; ++c)
                px[static_cast<std::size_t>((y * W + x) * 3 + c)] =
                    0.18f * std::exp2(-10.0f + 20.0f * static_cast<float>(x) / W) * (1.0f - 0.3f * static_cast<float>(c) * y / H);
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    for (int c = 0; c < 3; ++c) {
        px[static_cast<std::size_t>((3 * W + 3) * 3 + c)] = nan;
        px[static_cast<std::size_t>((4 * W + 5) * 3 + c)] = inf;
        px[static_cast<std::size_t>((5 * W + 7) * 3 + c)] = -inf;
        for (int y = 20; y < 23; ++y)
            for (int x = 44; x < 47; ++x) px[static_cast<std::size_t>((y * W + x) * 3 + c)] = 5000.0f;
    }
    OIIO::ImageSpec spec(W, H, 3, OIIO::TypeFloat);
    auto out = OIIO::ImageOutput::create(path("in.exr"));
    ASSERT_TRUE(out && out->open(path("in.exr"), spec) && out->write_image(OIIO::TypeFloat, px.data()) && out->close());

    const std::string flare = " --lens cooke-triplet --threshold 1000 --grid 32 --parts ghosts,starburst";
    // Every display with --gpu; the flare's shared context with the display whose GPU/CPU gap is largest.
    for (const std::string display : {"srgb", "rec709", "rec2100-pq"}) {
        for (const std::string& extra : {std::string(" --gpu surfaceless"), flare}) {
            if (extra == flare && display != "rec709") continue;
            const std::string common = "-q -i " + path("in.exr") + " --display " + display + extra;
            ASSERT_EQ(run(common + " --colour-on cpu -o " + path("cpu.exr")).status, 0) << display << extra;
            const Result r = run(common + " -o " + path("gpu.exr"));  // auto: the run's context is there
            ASSERT_EQ(r.status, 0) << display << extra << ": " << r.output;
            OIIO::ImageSpec cpu_spec, gpu_spec;
            const auto cpu = read_pixels(path("cpu.exr"), &cpu_spec), gpu = read_pixels(path("gpu.exr"), &gpu_spec);
            EXPECT_EQ(cpu_spec.get_string_attribute("lensfx:colourTransformOn"), "cpu");
            EXPECT_EQ(gpu_spec.get_string_attribute("lensfx:colourTransformOn"), "gpu") << display << extra;
            ASSERT_EQ(cpu.size(), px.size());
            ASSERT_EQ(gpu.size(), px.size());
            float worst = 0.0f;
            for (std::size_t i = 0; i < cpu.size(); ++i) {
                ASSERT_TRUE(std::isfinite(cpu[i]) && std::isfinite(gpu[i])) << display << extra << " value " << i;
                worst = std::max(worst, std::abs(cpu[i] - gpu[i]));
            }
            std::printf("%s%s: GPU - CPU max %.3g\n", display.c_str(), extra.c_str(), static_cast<double>(worst));
            EXPECT_LT(worst, 1e-4f) << display << extra;
        }
    }
}

}  // namespace
