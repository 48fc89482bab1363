// The command line's conventions, through the lensfx program: usage errors (exit 2, one `lensfx:` line,
// "did you mean", readable numbers, `--opt=`), colour/color spellings, the same option meaning the same
// in `lensfx` and `lensfx flare`, --report -, --config shot files, --version, frames in the pattern, and
// options that cannot apply to the output.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "filter_test_util.h"

namespace {

namespace fs = std::filesystem;
using lensfx::test::lensfx_cmd;
using lensfx::test::run;
using lensfx::test::RunResult;

struct Output {
    int exit_code;
    std::string out, err;
};

// stdout and stderr of a shell command.
Output capture(const std::string& command) {
    const fs::path out = fs::temp_directory_path() / fmt::format("lensfx-cli-out-{}", ::getpid());
    const RunResult r = run(command + " > '" + out.string() + "'");
    std::ifstream in(out);
    std::stringstream ss;
    ss << in.rdbuf();
    fs::remove(out);
    return {r.exit_code, ss.str(), r.stderr_text};
}

// A 16x8 RGB float EXR of one value.
void make_exr(const fs::path& path, float value) {
    OIIO::ImageSpec spec(16, 8, 3, OIIO::TypeFloat);
    const std::vector<float> px(16 * 8 * 3, value);
    auto out = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(out && out->open(path.string(), spec) && out->write_image(OIIO::TypeFloat, px.data()) && out->close());
}

float first_value(const fs::path& path) {
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) return -1.0f;
    std::vector<float> px(static_cast<std::size_t>(in->spec().image_pixels()) * static_cast<std::size_t>(in->spec().nchannels));
    if (!in->read_image(0, 0, 0, in->spec().nchannels, OIIO::TypeFloat, px.data())) return -1.0f;
    return px[0];
}

std::size_t lines(const std::string& text) { return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')); }

class Cli : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = lensfx::test::scratch_dir(::testing::UnitTest::GetInstance()->current_test_info()->name());
        make_exr(dir_ / "in.exr", 0.25f);
    }
    void TearDown() override { fs::remove_all(dir_); }
    std::string p(const std::string& name) const { return (dir_ / name).string(); }
    Output lensfx(const std::string& args) const { return capture(lensfx_cmd() + " " + args); }
    fs::path dir_;
};

TEST_F(Cli, UsageErrorsExitTwoWithOneLine) {
    Output r = lensfx("-i " + p("in.exr") + " -o " + p("out.exr") + " --lenz cooke-triplet");
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(r.err, "lensfx: unknown option --lenz (did you mean --lens?)\n");
    r = lensfx("flare --lens cooke-triplet --angel 3,4 -o " + p("f.exr"));
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find("unknown option --angel (did you mean --angle?)"), std::string::npos) << r.err;
    r = lensfx("-i " + p("in.exr") + " -o " + p("out.exr") + " --frobnicate");
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(r.err, "lensfx: unknown option --frobnicate\n");
    // A bad value, a missing value, an out-of-range value: exit 2, one line, short numbers.
    for (const std::string args : {"--threads -1", "--bits 12", "--min-light 3", "--dust-size 9", "--gain=-1", "--queue-depth"}) {
        r = lensfx("-i " + p("in.exr") + " -o " + p("out.exr") + " " + args);
        EXPECT_EQ(r.exit_code, 2) << args << ": " << r.err;
        EXPECT_EQ(r.err.rfind("lensfx: ", 0), 0u) << args << ": " << r.err;
        EXPECT_EQ(lines(r.err), 1u) << args << ": " << r.err;
        EXPECT_LT(r.err.size(), 160u) << args << ": " << r.err;
        EXPECT_FALSE(std::regex_search(r.err, std::regex(R"(\d{12})"))) << args << ": " << r.err;
    }
    // A bound the value is refused at is strict: "0 must be above 0", not "0 must be at least 0".
    r = lensfx("-i " + p("in.exr") + " -o " + p("out.exr") + " --lens cooke-triplet --fstop 0");
    EXPECT_EQ(r.err, "lensfx: --fstop: Value 0 must be above 0\n");
    r = lensfx("-i " + p("in.exr") + " -o " + p("out.exr") + " --visibility -1");
    EXPECT_EQ(r.err, "lensfx: --visibility: Value -1 must be at least 0\n");
    // A failed run is exit 1.
    EXPECT_EQ(lensfx("-i " + p("missing.exr") + " -o " + p("out.exr")).exit_code, 1);
    EXPECT_FALSE(fs::exists(p("out.exr")));
}

TEST_F(Cli, EmptyValueDoesNotSwallowTheNextOption) {
    const Output r = lensfx("-i " + p("in.exr") + " --frames= -o " + p("out.exr"));
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(r.err, "lensfx: --frames= has no value (write --frames=VALUE or --frames VALUE)\n");
    EXPECT_FALSE(fs::exists(p("out.exr")));
}

// A shot file must be a regular file: CLI11 would read /dev/zero for ever (issue 14, class 9).
TEST_F(Cli, ConfigFromASpecialFileIsRefused) {
    for (const std::string args : {"--config /dev/zero", "--config=/dev/zero"}) {
        const Output r = lensfx(args + " -i " + p("in.exr") + " -o " + p("out.exr"));
        EXPECT_EQ(r.exit_code, 1) << args;
        EXPECT_EQ(r.err, "lensfx: --config /dev/zero: a device, not a regular file\n") << args;
    }
    EXPECT_FALSE(fs::exists(p("out.exr")));
}

TEST_F(Cli, ColourAndColorBothWork) {
    for (const std::string opt : {"--colorspace", "--colourspace"}) {
        const Output r = lensfx("-i " + p("in.exr") + " -o " + p("o.exr") + " " + opt + " ACEScg --exposure 1");
        EXPECT_EQ(r.exit_code, 0) << opt << ": " << r.err;
    }
    for (const std::string opt : {"--colour-on", "--color-on"}) {
        const Output r = lensfx("-i " + p("in.exr") + " -o " + p("o.png") + " " + opt + "=cpu");
        EXPECT_EQ(r.exit_code, 0) << opt << ": " << r.err;
    }
}

// The defaults `lensfx --help` and `lensfx flare --help` show for the options both have are the same.
TEST_F(Cli, SharedOptionsHaveTheSameDefaults) {
    const std::string filter = lensfx("--help").out, flare = lensfx("flare --help").out;
    for (const std::string name : {"--sensor", "--parts", "--threads", "--exposure", "--gpu", "--grid", "--bands", "--starburst-scale"}) {
        // The option's line: "  --name TYPE=DEFAULT  help" (an alias may come first: "--exposure,--preview-exposure").
        const std::regex line("\n *(-[-a-z]+,)*" + name + "[ ,][^\n]*");
        std::smatch a, b;
        ASSERT_TRUE(std::regex_search(filter, a, line)) << name;
        ASSERT_TRUE(std::regex_search(flare, b, line)) << name;
        const std::string la = a.str(), lb = b.str();
        std::smatch da, db;
        const std::regex default_value(R"(=(\S+))");
        const bool fa = std::regex_search(la, da, default_value), fb = std::regex_search(lb, db, default_value);
        EXPECT_EQ(fa, fb) << name << "\n" << la << "\n" << lb;
        if (fa && fb) {
            EXPECT_EQ(da[1], db[1]) << name << "\n" << la << "\n" << lb;
        }
    }
}

TEST_F(Cli, ReportOnStdoutHoldsTheOptionsAndConfigRepeatsTheRun) {
    const Output r = lensfx("-i " + p("in.exr") + " -o " + p("a.exr") + " --exposure 2 --report -");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["frames_written"], 1);
    const std::string options = j["options"];
    EXPECT_NE(options.find("exposure=2"), std::string::npos) << options;
    // The options as a shot file, with a new output: the same result.
    std::string shot = std::regex_replace(options, std::regex("a\\.exr"), "b.exr");
    shot = std::regex_replace(shot, std::regex("report=['\"]-['\"]\n"), "");
    std::ofstream(p("shot.toml")) << shot;
    ASSERT_EQ(lensfx("--config " + p("shot.toml")).exit_code, 0);
    EXPECT_FLOAT_EQ(first_value(p("b.exr")), 1.0f);  // 0.25 x 2^2
    EXPECT_FLOAT_EQ(first_value(p("a.exr")), first_value(p("b.exr")));
    // A shot file written by hand, a command-line option beside it.
    std::ofstream(p("hand.toml")) << "input = \"" << p("in.exr") << "\"\nexposure = 1\n";
    ASSERT_EQ(lensfx("--config " + p("hand.toml") + " -o " + p("c.exr")).exit_code, 0);
    EXPECT_FLOAT_EQ(first_value(p("c.exr")), 0.5f);
    EXPECT_EQ(lensfx("-i " + p("in.exr") + " -o - --report -").exit_code, 1);
}

// A shot file's mistakes name the file and the line: a key no option has (with the near one), a bad value. The
// same value given on the command line is the command line's error.
TEST_F(Cli, ConfigErrorsNameTheFileAndLine) {
    std::ofstream(p("typo.toml")) << "input = \"" << p("in.exr") << "\"\n# exposure below\ntreshold = 5\n";
    Output r = lensfx("--config " + p("typo.toml") + " -o " + p("t.exr"));
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(r.err, "lensfx: --config " + p("typo.toml") + ", line 3: unknown key treshold (did you mean threshold?)\n");
    std::ofstream(p("value.toml")) << "input = \"" << p("in.exr") << "\"\n\nexposure = \"bright\"\n";
    r = lensfx("--config " + p("value.toml") + " -o " + p("t.exr"));
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(r.err.rfind("lensfx: --config " + p("value.toml") + ", line 3: --exposure: ", 0), 0u) << r.err;
    r = lensfx("--config " + p("value.toml") + " --exposure dim -o " + p("t.exr"));
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(r.err.rfind("lensfx: --exposure: ", 0), 0u) << r.err;
    EXPECT_FALSE(fs::exists(p("t.exr")));
    std::ofstream(p("self.toml")) << "config = \"other.toml\"\n";
    EXPECT_EQ(lensfx("--config " + p("self.toml")).err, "lensfx: --config " + p("self.toml") + ", line 1: config cannot be set in a shot file\n");
    EXPECT_EQ(lensfx("--config " + p("none.toml")).err, "lensfx: --config " + p("none.toml") + ": no such file\n");
}

// Usage messages say what to do: a positional argument given as an option, an option given twice, an output folder
// that is a file.
TEST_F(Cli, UsageMessagesPointAtTheFix) {
    Output r = lensfx("lens info --lens cooke-triplet");
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(r.err, "lensfx: unknown option --lens (the lens goes without --lens: lensfx lens info LENS)\n");
    r = lensfx("-i " + p("in.exr") + " -o " + p("o.exr") + " --frames 1 --frames 1");
    EXPECT_EQ(r.err, "lensfx: --frames is given more than once (give it once)\n");
    r = lensfx("-i " + p("in.exr") + " -o " + p("in.exr") + "/o.exr");
    EXPECT_NE(r.err.find("output directory " + p("in.exr") + " is not a directory"), std::string::npos) << r.err;
}

TEST_F(Cli, VersionNamesTheBuildAndTheLibraries) {
    const auto t0 = std::chrono::steady_clock::now();
    const Output r = lensfx("--version");
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_EQ(r.exit_code, 0) << r.err;
    for (const char* part : {"lensfx ", "commit ", " build", "OpenEXR 3.", "OpenImageIO 2.", "OpenColorIO 2.", "OpenCV 4."})
        EXPECT_NE(r.out.find(part), std::string::npos) << part << " in " << r.out;
    EXPECT_EQ(r.out.find("GL renderer"), std::string::npos) << r.out;  // only with --verbose
    std::printf("lensfx --version: %.3f s\n", seconds);
    const Output v = lensfx("--version --verbose");
    ASSERT_EQ(v.exit_code, 0) << v.err;
    EXPECT_NE(v.out.find("GL renderer"), std::string::npos) << v.out;
}

TEST_F(Cli, FramesWrittenInThePattern) {
    for (int f = 1; f <= 6; ++f) fs::copy_file(p("in.exr"), p(fmt::format("pan.{:04d}.exr", f)));
    ASSERT_EQ(lensfx("-q -i " + p("pan.2-6x2#.exr") + " -o " + p("out.#.exr")).exit_code, 0);
    for (int f = 1; f <= 6; ++f) EXPECT_EQ(fs::exists(p(fmt::format("out.{:04d}.exr", f))), f % 2 == 0) << f;
    ASSERT_EQ(lensfx("-q -i " + p("pan.#.exr") + " --frames 1-6y2 -o " + p("y.#.exr")).exit_code, 0);
    for (int f = 1; f <= 6; ++f) EXPECT_EQ(fs::exists(p(fmt::format("y.{:04d}.exr", f))), f % 2 == 0) << f;
    const Output both = lensfx("-i " + p("pan.1-3#.exr") + " --frames 4-6 -o " + p("z.#.exr"));
    EXPECT_NE(both.err.find("give one"), std::string::npos) << both.err;
}

TEST_F(Cli, OptionsThatCannotApplyAreErrors) {
    Output r = lensfx("-i " + p("in.exr") + " -o " + p("o.png") + " --lens cooke-triplet --layer flare");
    EXPECT_EQ(r.exit_code, 2);  // usage errors, as every bad value
    EXPECT_NE(r.err.find("--layer flare adds channels, which PNG output cannot hold"), std::string::npos) << r.err;
    r = lensfx("-i " + p("in.exr") + " -o " + p("o.jpg") + " --lens cooke-triplet --layer flare");
    EXPECT_NE(r.err.find("JPG output cannot hold"), std::string::npos) << r.err;
    r = lensfx("-i " + p("in.exr") + " -o " + p("o.exr") + " --bits 16");
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_NE(r.err.find("--bits sets the code values of display files"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(p("o.exr")));
    r = lensfx("-i " + p("in.exr") + " -o " + p("o.jpg") + " --bits 16");
    EXPECT_EQ(r.exit_code, 2);
    EXPECT_EQ(r.err, "lensfx: --bits 16: JPG holds 8-bit code values (PNG or TIFF hold 16)\n");
    EXPECT_FALSE(fs::exists(p("o.jpg")));
    // Values refused by the parser itself, before anything runs.
    for (const char* bad : {" --parts foo", " --frames 5-a", " --frames 1-10x0", " --compression foo", " --sensor 36x0"}) {
        r = lensfx("-i " + p("in.exr") + " -o " + p("o.exr") + " --lens cooke-triplet" + bad);
        EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.err;
        EXPECT_EQ(r.err.rfind("lensfx: " + std::string(bad).substr(1, std::string(bad).find(' ', 1) - 1) + ": ", 0), 0u) << r.err;
    }
    EXPECT_EQ(lensfx("-i \"\" -o " + p("o.exr")).exit_code, 2);
    r = lensfx("-i " + p("in.exr") + " -o " + p("o.png") + " --display rec2100-pq");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("warning: PQ (rec2100-pq) in an 8-bit PNG"), std::string::npos) << r.err;
    r = lensfx("-i " + p("in.exr") + " -o " + p("o16.png") + " --display rec2100-pq --bits 16");
    EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
    r = lensfx("-i " + p("in.exr") + " -o " + p("o.exr") + " --size 64x48");
    EXPECT_NE(r.err.find("--size gives the frame size of raw input"), std::string::npos) << r.err;
}

}  // namespace
