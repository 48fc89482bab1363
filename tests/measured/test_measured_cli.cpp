// `lensfx lens fit`, `lensfx predict` and a measured lens in `lensfx flare` and the filter, end to end:
// their outputs and their one-line failures (usage errors exit 2, run failures 1).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <fmt/core.h>

#include <nlohmann/json.hpp>

#include <measured/model.h>
#include <measured/model_file.h>

#include "../filter/filter_test_util.h"

namespace lensfx::measured {
namespace {

using lensfx::test::lensfx_cmd;
using lensfx::test::run;

// A measured lens file with one disc ghost over 0..20 degrees, in `dir`.
std::string disc_lens_file(const std::filesystem::path& dir) {
    MeasuredLens lens;
    lens.name = "disc";
    lens.focal_length_mm = 50.0;
    MeasuredGhost g;
    g.angle_min_deg = 0.0, g.angle_max_deg = 20.0;
    const GhostParams p = disc_ghost(0.0, 2.0, {1e-3, 1e-3, 1e-3});
    for (int k = 0; k < kParamCount; ++k) g.poly[static_cast<std::size_t>(k)] = {p[k], 0.0, 0.0};
    g.poly[kPosition] = {0.0, -0.5, 0.0};
    g.poly[kBorderR] = {1e-3, 1e-4, 0.0};  // brighter with the angle
    g.poly[kInsideR] = {1e-3, 1e-4, 0.0};
    lens.ghosts.push_back(g);
    const std::string path = (dir / "disc.toml").string();
    std::ofstream(path) << write_measured_toml(lens);
    return path;
}

bool one_line(const std::string& text) { return text.rfind("lensfx: ", 0) == 0 && text.find('\n') == text.size() - 1; }

namespace fs = std::filesystem;

std::string slurp(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

TEST(MeasuredCli, PredictJsonListsTheEstimatorsPerAngle) {
    const auto dir = lensfx::test::scratch_dir("measured_cli_predict");
    const std::string lens = disc_lens_file(dir), json = (dir / "p.json").string();
    const auto r = run(lensfx_cmd() + " predict --lens " + lens + " --angles 2:10:4 --size 96x64 --json --map " + (dir / "map.png").string() + " > " + json);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    std::ifstream in(json);
    const nlohmann::json list = nlohmann::json::parse(in);
    ASSERT_EQ(list.size(), 3u);
    for (const char* key : {"angle_deg", "peak", "total", "glare", "contrast"}) EXPECT_TRUE(list[0].contains(key)) << key;
    EXPECT_DOUBLE_EQ(list[2]["angle_deg"].get<double>(), 10.0);
    EXPECT_GT(list[2]["total"].get<double>(), list[0]["total"].get<double>());  // the ghost brightens with the angle
    EXPECT_TRUE(std::filesystem::exists(dir / "map.png"));
}

TEST(MeasuredCli, FlareAndFilterTakeAMeasuredLens) {
    const auto dir = lensfx::test::scratch_dir("measured_cli_flare");
    const std::string lens = disc_lens_file(dir);
    auto r = run(lensfx_cmd() + " flare --lens " + lens + " --angle 6,3 --size 96x64 -o " + (dir / "f.exr").string());
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
    r = run(lensfx_cmd() + " -i " + LENSFX_SOURCE_DIR "/samples/pan/pan.0001.exr -o " + (dir / "out.exr").string() + " --lens " + lens);
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
}

TEST(MeasuredCli, FailuresAreOneLine) {
    const auto dir = lensfx::test::scratch_dir("measured_cli_errors");
    const std::string lens = disc_lens_file(dir), sweep = std::string(LENSFX_SOURCE_DIR) + "/samples/sweep/sweep.####.exr";
    const struct {
        std::string args;
        int code;
        std::string says;
    } cases[] = {
        {"lens fit " + sweep + " --angles 0:10:2 --focal-length 100 -o " + (dir / "m.toml").string(), 2, "gives 6 angles"},
        {"lens fit " + sweep + " --angles 0:16:2 -o " + (dir / "m.toml").string(), 2, "--focal-length"},
        {"lens fit " + (dir / "none.####.exr").string() + " --angles 0:16:2 --focal-length 100 -o " + (dir / "m.toml").string(), 1, "no frames"},
        {"predict --lens " + lens + " --angles 0:5:0", 2, "STEP > 0"},
        {"predict --lens " + lens + " --angles 0:x:1", 2, "START:END:STEP"},
        {"flare --lens petzval-kodak --angle 1,0 --iso 200 -o " + (dir / "f.exr").string(), 2, "measured lenses only"},
    };
    for (const auto& c : cases) {
        const auto r = run(lensfx_cmd() + " " + c.args);
        EXPECT_EQ(r.exit_code, c.code) << c.args << ": " << r.stderr_text;
        EXPECT_TRUE(one_line(r.stderr_text)) << r.stderr_text;
        EXPECT_NE(r.stderr_text.find(c.says), std::string::npos) << r.stderr_text;
    }
    // The report overwrites neither a frame of the sweep (through a link too) nor the fitted preset, and a place it
    // cannot be written fails the fit before it starts: refused first, the files as they were.
    const std::string frames = (dir / "sweep.####.exr").string();
    for (int f = 0; f <= 8; ++f)  // the sample sweep's frames 0-8
        fs::copy_file(fmt::format("{}/samples/sweep/sweep.{:04}.exr", LENSFX_SOURCE_DIR, f), dir / fmt::format("sweep.{:04}.exr", f),
                      fs::copy_options::overwrite_existing);
    const std::string frame_text = slurp(dir / "sweep.0001.exr");
    fs::create_symlink(dir / "sweep.0003.exr", dir / "link.json");
    std::ofstream(dir / "kept.toml") << "kept\n";
    const std::string fit = " lens fit " + frames + " --angles 0:16:2 --focal-length 24 --key-iterations 5 ";
    for (const auto& [args, says] : std::vector<std::pair<std::string, std::string>>{
             {"-o " + (dir / "m.toml").string() + " --report " + (dir / "sweep.0001.exr").string(), "refusing to overwrite an input file"},
             {"-o " + (dir / "m.toml").string() + " --report " + (dir / "link.json").string(), "refusing to overwrite an input file"},
             {"-o " + (dir / "kept.toml").string() + " --report " + (dir / "kept.toml").string(), "refusing to overwrite the output"},
             {"-o " + (dir / "m.toml").string() + " --report /proc/version", "cannot write a file there"}}) {
        const auto r = run(lensfx_cmd() + fit + args);
        EXPECT_EQ(r.exit_code, 1) << args << ": " << r.stderr_text;
        EXPECT_TRUE(one_line(r.stderr_text)) << r.stderr_text;
        EXPECT_NE(r.stderr_text.find(says), std::string::npos) << r.stderr_text;
    }
    EXPECT_EQ(slurp(dir / "sweep.0001.exr"), frame_text);
    EXPECT_EQ(slurp(dir / "kept.toml"), "kept\n");
    EXPECT_FALSE(fs::exists(dir / "m.toml"));
    std::ofstream(dir / "bad.toml") << "kind = \"measured\"\nfocal_length = 50\nsensor = [36, 24]\n[[ghost]]\nangles = [1, 95]\n";
    const auto r = run(lensfx_cmd() + " flare --lens " + (dir / "bad.toml").string() + " --angle 1,0 -o " + (dir / "f.exr").string());
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_TRUE(one_line(r.stderr_text)) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find("bad.toml"), std::string::npos) << r.stderr_text;
}

}  // namespace
}  // namespace lensfx::measured
