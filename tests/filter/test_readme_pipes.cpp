// The README's ffmpeg pipelines, run exactly as printed (read from README.md) on an RGBA EXR sequence at
// the size they name, with values in the thousands: the EXR stream into lensfx and raw float RGBA out of
// it keep every value and alpha (float bit-exact, half exact as half); the H.264 and HDR10 encodes hold
// the display code values of the colour module. Skipped without ffmpeg (or its x264/x265 encoders).
#include <filter/colour.h>
#include <filter/image_io.h>

#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>
#include <fmt/core.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "filter_test_util.h"

namespace {

namespace fs = std::filesystem;
using lensfx::test::run;

// The commands of the README's fenced block whose first line is `first_comment`: comment lines dropped,
// lines ending in a backslash joined with the next, as a shell would run them.
std::vector<std::string> readme_commands(const std::string& first_comment) {
    std::ifstream in(std::string(LENSFX_SOURCE_DIR) + "/README.md");
    std::vector<std::string> commands;
    std::string line, current;
    bool in_block = false, found = false;
    while (std::getline(in, line)) {
        if (!in_block && line.rfind("```", 0) == 0) {
            in_block = true;
            std::getline(in, line);
            found = line == first_comment;
            if (!found) continue;
        } else if (in_block && line.rfind("```", 0) == 0) {
            in_block = false;
            if (found) break;
            continue;
        }
        if (!in_block || !found || line.empty() || line[0] == '#') continue;
        const bool continues = !line.empty() && line.back() == '\\';
        current += continues ? line.substr(0, line.size() - 1) : line;
        if (!continues) {
            commands.push_back(current);
            current.clear();
        }
    }
    return commands;
}

// The WxH a command gives ffmpeg's rawvideo input (-s WxH).
std::pair<int, int> raw_size(const std::string& command) {
    std::smatch m;
    if (!std::regex_search(command, m, std::regex(R"(-s (\d+)x(\d+))"))) return {0, 0};
    return {std::stoi(m[1]), std::stoi(m[2])};
}

constexpr float kShadow = 0.18f, kHighlight = 50.0f;

// R, G, B, A of the test frames: a shadow quarter, a highlight quarter, values up to ~7000 between
// them, alpha running from 0 to 1 across the frame; different in each frame.
std::vector<float> frame_pixels(int w, int h, int frame) {
    std::vector<float> px(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 4);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float* p = px.data() + (static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) * 4;
            const float grey = x < w / 4 ? kShadow : x >= 3 * w / 4 ? kHighlight
                                                                    : 1.0f + static_cast<float>((x * 131 + y * 71 + frame * 17) % 7001) * 0.999f;
            for (int c = 0; c < 3; ++c) p[c] = grey * (1.0f + 0.01f * static_cast<float>(c));
            p[3] = static_cast<float>(x) / static_cast<float>(w - 1);
        }
    return px;
}

void write_rgba_exr(const fs::path& path, int w, int h, int frame, OIIO::TypeDesc type) {
    OIIO::ImageSpec spec(w, h, 4, type);
    spec.attribute("compression", "zip");
    auto out = OIIO::ImageOutput::create(path.string());
    const std::vector<float> px = frame_pixels(w, h, frame);
    ASSERT_TRUE(out && out->open(path.string(), spec) && out->write_image(OIIO::TypeFloat, px.data()) && out->close());
}

// R, G, B, A of an image as float (channels found by name, whatever their order in the file).
std::vector<float> rgba(const fs::path& path) {
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) return {};
    const OIIO::ImageSpec& s = in->spec();
    std::vector<float> all(static_cast<std::size_t>(s.width) * static_cast<std::size_t>(s.height) * static_cast<std::size_t>(s.nchannels));
    if (!in->read_image(0, 0, 0, s.nchannels, OIIO::TypeFloat, all.data())) return {};
    std::vector<float> out(static_cast<std::size_t>(s.width) * static_cast<std::size_t>(s.height) * 4);
    const char* names[] = {"R", "G", "B", "A"};
    for (int c = 0; c < 4; ++c) {
        const int from = s.channelindex(names[c]);
        if (from < 0) return {};
        for (std::size_t i = 0; i < out.size() / 4; ++i) out[i * 4 + static_cast<std::size_t>(c)] = all[i * static_cast<std::size_t>(s.nchannels) + static_cast<std::size_t>(from)];
    }
    return out;
}

float display_value(const std::string& display, float grey, int c) {
    using namespace lensfx::colour;
    ColourOptions o;
    o.display = display;
    ColourPipeline p(ColourConfig::builtin_config(), o, std::nullopt);
    std::array<float, 3> rgb{grey, grey * 1.01f, grey * 1.02f};
    p.to_display().apply_rgb(rgb.data(), 1);
    return rgb[static_cast<std::size_t>(c)];
}

bool have(const std::string& check) { return std::system((check + " > /dev/null 2>&1").c_str()) == 0; }

std::string slurp(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

class ReadmePipes : public ::testing::TestWithParam<const char*> {
protected:
    void SetUp() override {
        if (!have("command -v ffmpeg")) GTEST_SKIP() << "ffmpeg is not installed: the README's pipelines are not tested";
        commands_ = readme_commands("# HDR and alpha through ffmpeg: EXR images into lensfx, raw float RGBA out of it");
        ASSERT_EQ(commands_.size(), 4u) << "the README's pipeline block changed";
        std::tie(w_, h_) = raw_size(commands_[1]);
        ASSERT_GT(w_, 0);
        dir_ = lensfx::test::scratch_dir(std::string("readme-") + GetParam());
        // `lensfx` on the PATH is the program under test, so the commands run as printed.
        fs::create_directories(dir_ / "bin");
        fs::create_symlink(LENSFX_BINARY, dir_ / "bin" / "lensfx");
        for (int f : {1, 2}) write_rgba_exr(dir_ / fmt::format("shot.{:04d}.exr", f), w_, h_, f, OIIO::TypeDesc(GetParam()));
    }
    void TearDown() override {
        if (!dir_.empty()) fs::remove_all(dir_);
    }
    lensfx::test::RunResult run_readme(std::size_t i) const {
        // ffmpeg reads keys from stdin unless it is /dev/null.
        return run(fmt::format("cd '{0}' && export PATH='{0}/bin':\"$PATH\" && ( {1} ) < /dev/null", dir_.string(), commands_[i]));
    }
    std::vector<std::string> commands_;
    int w_ = 0, h_ = 0;
    fs::path dir_;
};

TEST_P(ReadmePipes, EveryValueAndAlphaSurviveBothWays) {
    for (std::size_t i : {0u, 1u}) {
        const auto r = run_readme(i);
        ASSERT_EQ(r.exit_code, 0) << commands_[i] << "\n" << r.stderr_text;
    }
    for (int f : {1, 2}) {
        const std::vector<float> in = rgba(dir_ / fmt::format("shot.{:04d}.exr", f));
        float peak = 0;
        for (std::size_t i = 0; i < in.size(); ++i) peak = std::max(peak, in[i]);
        EXPECT_GT(peak, 5000.0f);  // HDR: what a clamp to [0, 1] would lose
        for (const char* name : {"same", "back"}) {
            const std::vector<float> out = rgba(dir_ / fmt::format("{}.{:04d}.exr", name, f));
            ASSERT_EQ(out.size(), in.size()) << name << " " << f;
            std::size_t differ = 0;
            for (std::size_t i = 0; i < in.size(); ++i) differ += out[i] != in[i];  // half values are exact in float
            EXPECT_EQ(differ, 0u) << name << " frame " << f;
        }
    }
}

TEST_P(ReadmePipes, H264Rec709HoldsTheDisplayCodeValues) {
    if (std::string(GetParam()) != "float") GTEST_SKIP() << "the encodes are tested on the float sequence";
    if (!have("ffmpeg -hide_banner -h encoder=libx264 | grep -q yuv420p")) GTEST_SKIP() << "this ffmpeg has no libx264";
    const auto r = run_readme(2);
    ASSERT_EQ(r.exit_code, 0) << commands_[2] << "\n" << r.stderr_text;
    ASSERT_EQ(run(fmt::format("ffmpeg -v error -i '{0}/shot.mp4' -vf scale=in_color_matrix=bt709:in_range=tv -f rawvideo -pix_fmt rgb24 '{0}/back.rgb'",
                              dir_.string())).exit_code, 0);
    const std::string bytes = slurp(dir_ / "back.rgb");
    ASSERT_EQ(bytes.size(), static_cast<std::size_t>(2 * w_ * h_ * 3));
    auto code = [&](int x, int c) { return static_cast<unsigned char>(bytes[(static_cast<std::size_t>(h_ / 2 * w_ + x) * 3) + static_cast<std::size_t>(c)]); };
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(code(w_ / 8, c), display_value("rec709", kShadow, c) * 255.0f, 2.5) << c;
        EXPECT_NEAR(code(7 * w_ / 8, c), display_value("rec709", kHighlight, c) * 255.0f, 2.5) << c;
    }
}

TEST_P(ReadmePipes, Hdr10HoldsThePqCodeValues) {
    if (std::string(GetParam()) != "float") GTEST_SKIP() << "the encodes are tested on the float sequence";
    if (!have("ffmpeg -hide_banner -h encoder=libx265 | grep -q yuv420p10le")) GTEST_SKIP() << "this ffmpeg has no 10-bit libx265";
    const auto r = run_readme(3);
    ASSERT_EQ(r.exit_code, 0) << commands_[3] << "\n" << r.stderr_text;
    ASSERT_EQ(run(fmt::format("ffprobe -v error -show_streams '{0}/shot_hdr10.mp4' > '{0}/probe.txt'", dir_.string())).exit_code, 0);
    const std::string info = slurp(dir_ / "probe.txt");
    EXPECT_NE(info.find("color_transfer=smpte2084"), std::string::npos) << info;
    EXPECT_NE(info.find("color_primaries=bt2020"), std::string::npos) << info;
    EXPECT_NE(info.find("pix_fmt=yuv420p10le"), std::string::npos) << info;
    ASSERT_EQ(run(fmt::format("ffmpeg -v error -i '{0}/shot_hdr10.mp4' -frames:v 1 -vf scale=in_color_matrix=bt2020:in_range=tv -f rawvideo -pix_fmt rgb48le '{0}/back.rgb'",
                              dir_.string())).exit_code, 0);
    const std::string bytes = slurp(dir_ / "back.rgb");
    ASSERT_EQ(bytes.size(), static_cast<std::size_t>(w_ * h_ * 3 * 2));
    auto value = [&](int x, int c) {
        const std::size_t i = (static_cast<std::size_t>(h_ / 2 * w_ + x) * 3 + static_cast<std::size_t>(c)) * 2;
        return (static_cast<unsigned char>(bytes[i]) | (static_cast<unsigned char>(bytes[i + 1]) << 8)) / 65535.0;
    };
    // PQ code values of the ACES 1000-nit output; 10-bit video range is about 0.001 per code.
    EXPECT_NEAR(value(w_ / 8, 1), static_cast<double>(display_value("rec2100-pq", kShadow, 1)), 3e-3);
    EXPECT_NEAR(value(7 * w_ / 8, 1), static_cast<double>(display_value("rec2100-pq", kHighlight, 1)), 3e-3);
}

// A float and a half sequence: both must come back exactly.
INSTANTIATE_TEST_SUITE_P(Types, ReadmePipes, ::testing::Values("float", "half"));

}  // namespace
