// Hostile inputs and resource bounds (issue 14), end to end: each class of input that once crashed, hung,
// made a NaN frame, succeeded silently or overwrote an input now gives one `lensfx:` line and a non-zero
// exit, or a correct result. Small synthetic frames; the flare cases render on llvmpipe in a second or so.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <fmt/core.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include "filter_test_util.h"

namespace fs = std::filesystem;
using namespace lensfx::test;

// A 4 GB address-space limit on the program where it holds (AddressSanitizer reserves terabytes of
// shadow address space at start, so under it the run is bounded by the test's time instead).
#if defined(__SANITIZE_ADDRESS__)
constexpr const char* kAddressLimit = "";
#else
constexpr const char* kAddressLimit = "ulimit -v 4000000; ";
#endif

namespace {

// A width x height float image of the given channels, dim grey with one bright disc at (cx, cy); with
// `noise`, grey noise instead (which no format compresses much).
void write_image(const fs::path& path, std::vector<std::string> channels, OIIO::TypeDesc type = OIIO::TypeFloat,
                 int width = 64, int height = 48, double cx = 20.0, double cy = 16.0, bool noise = false) {
    OIIO::ImageSpec spec(width, height, static_cast<int>(channels.size()), type);
    spec.channelnames = std::move(channels);
    std::vector<float> px(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * spec.channelnames.size());
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> random(0.0f, 1.0f);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            for (std::size_t c = 0; c < spec.channelnames.size(); ++c)
                px[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * spec.channelnames.size() + c] =
                    noise ? random(rng) : std::hypot(x + 0.5 - cx, y + 0.5 - cy) < 2.5 ? 5000.0f : 0.05f;
    auto out = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(out && out->open(path.string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeFloat, px.data()));
    ASSERT_TRUE(out->close());
}

void write_rgb(const fs::path& path) { write_image(path, {"R", "G", "B"}); }

// A 160x100 R, G, B frame, dim grey with one uniform disc (an extended light when its radius is many pixels).
void write_disc(const fs::path& path, double cx, double cy, double radius, float value) {
    const int width = 160, height = 100;
    OIIO::ImageSpec spec(width, height, 3, OIIO::TypeFloat);
    std::vector<float> px(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            for (std::size_t c = 0; c < 3; ++c)
                px[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 3 + c] =
                    std::hypot(x + 0.5 - cx, y + 0.5 - cy) < radius ? value : 0.05f;
    auto out = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(out && out->open(path.string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeFloat, px.data()));
    ASSERT_TRUE(out->close());
}

// The failure contract: a non-zero exit and exactly one line on stderr, starting "lensfx: ".
void expect_one_line_refusal(const RunResult& r, const std::string& mentions) {
    EXPECT_NE(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(r.stderr_text.rfind("lensfx: ", 0), 0u) << r.stderr_text;
    EXPECT_EQ(std::count(r.stderr_text.begin(), r.stderr_text.end(), '\n'), 1) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find(mentions), std::string::npos) << "expected \"" << mentions << "\" in: " << r.stderr_text;
}

// A refusal by the command-line parser (CLI11 formats those; issue 21 makes them one line): non-zero,
// naming what is wrong.
void expect_refusal(const RunResult& r, const std::string& mentions) {
    EXPECT_NE(r.exit_code, 0) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find(mentions), std::string::npos) << "expected \"" << mentions << "\" in: " << r.stderr_text;
}

// Every pixel of every channel finite.
bool all_finite(const fs::path& path) {
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) return false;
    const OIIO::ImageSpec& s = in->spec();
    std::vector<float> px(s.image_pixels() * static_cast<std::size_t>(s.nchannels));
    if (!in->read_image(0, 0, 0, s.nchannels, OIIO::TypeFloat, px.data())) return false;
    return std::all_of(px.begin(), px.end(), [](float v) { return std::isfinite(v); });
}

// lensfx with its caches in the scratch directory, never the user's.
std::string lensfx_in(const fs::path& dir) { return fmt::format("LENSFX_CACHE_DIR={}/cache {}", dir.string(), lensfx_cmd()); }

const std::string kLens = " --lens brendel-tessar --fstop 4 --grid 8 --threshold 100 -q";

std::string slurp(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

}  // namespace

// Class 1: track files. A light far outside the frame, a huge footprint cell, a flux of 1e300, frame
// numbers beyond 32 bits or fractional: refused on load, naming the file, track, key and field.
TEST(Hostile, TrackFilesAreValidatedOnLoad) {
    const auto dir = scratch_dir("hostile-tracks");
    write_rgb(dir / "in.exr");
    auto track = [&](const std::string& key) {
        std::ofstream(dir / "t.json") << R"({"format": "lensfx-tracks", "version": 1, "width": 64, "height": 48, "tracks": [)"
                                      << R"({"id": 7, "keys": [)" << key << "]}]}";
        return run(lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/out.exr --tracks {0}/t.json", dir.string()) + kLens);
    };
    expect_one_line_refusal(track(R"({"frame": 1, "position": [3e9, 10], "flux": [1, 1, 1]})"), "position[0]");
    expect_one_line_refusal(track(R"({"frame": 1, "position": [3e9, 10], "flux": [1, 1, 1]})"), "t.json: track id 7 key 0");
    expect_one_line_refusal(track(R"({"frame": 1, "position": [10, 10], "flux": [1e300, 1, 1]})"), "flux[0]");
    expect_one_line_refusal(track(R"({"frame": 4294967297, "position": [10, 10], "flux": [1, 1, 1]}, {"frame": 1.5, "position": [10, 10], "flux": [1, 1, 1]})"),
                            "\"frame\" 1.5 is not a whole number");
    expect_one_line_refusal(track(R"({"frame": 1, "position": [10, 10], "flux": [1, 1, 1], "shape": {"size": [1, 1], "cell": 1e30, "origin": [0, 0], "weights": [1]}})"),
                            "cell");
    std::ofstream(dir / "t.json") << "{\"tracks\": [";
    expect_one_line_refusal(run(lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/out.exr --tracks {0}/t.json", dir.string()) + kLens),
                            (dir / "t.json").string() + ": not valid JSON");
    EXPECT_FALSE(fs::exists(dir / "out.exr"));

    // A key at 2^32 + 1 is frame 4294967297, not frame 1: nothing is drawn on frame 1.
    std::ofstream(dir / "t.json") << R"({"tracks": [{"id": 1, "keys": [{"frame": 4294967297, "position": [20, 16], "flux": [1e4, 1e4, 1e4]}]}]})";
    const auto r = run(lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/out.exr --tracks {0}/t.json --flare-only", dir.string()) + kLens);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    auto in = OIIO::ImageInput::open((dir / "out.exr").string());
    ASSERT_TRUE(in);
    std::vector<float> px(in->spec().image_pixels() * 3);
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeFloat, px.data()));
    EXPECT_TRUE(std::all_of(px.begin(), px.end(), [](float v) { return v == 0.0f; }));
    fs::remove_all(dir);
}

// Class 1: --max-lights applies to the lights of a track file too.
TEST(Hostile, MaxLightsBoundsTrackedLights) {
    const auto dir = scratch_dir("hostile-maxlights");
    write_rgb(dir / "in.exr");
    std::string tracks = R"({"tracks": [)";
    for (int i = 0; i < 200; ++i)
        tracks += fmt::format(R"({}{{"id": {}, "keys": [{{"frame": 1, "position": [{}, {}], "flux": [{}, {}, {}]}}]}})", i ? "," : "", i,
                              5 + i % 50, 5 + i / 50 * 8, 100 + i, 100 + i, 100 + i);
    std::ofstream(dir / "t.json") << tracks << "]}";
    const std::string base = lensfx_in(dir) + fmt::format(" -i {0}/in.exr --tracks {0}/t.json --flare-only --parts starburst", dir.string()) + kLens;
    ASSERT_EQ(run(base + fmt::format(" -o {}/one.exr --max-lights 1", dir.string())).exit_code, 0);
    // The brightest light alone: the same image as a track file holding only it.
    std::ofstream(dir / "t1.json") << R"({"tracks": [{"id": 199, "keys": [{"frame": 1, "position": [54, 29], "flux": [299, 299, 299]}]}]})";
    ASSERT_EQ(run(lensfx_in(dir) + fmt::format(" -i {0}/in.exr --tracks {0}/t1.json --flare-only --parts starburst -o {0}/ref.exr", dir.string()) + kLens).exit_code, 0);
    EXPECT_EQ(compare_images((dir / "ref.exr").string(), (dir / "one.exr").string(), false), "");
    fs::remove_all(dir);
}

// Class 2: gains and exposure. Non-finite values are refused; a gain beyond float range saturates the
// flare instead of making the frame NaN.
TEST(Hostile, GainsAndExposureAreFiniteAndCannotOverflow) {
    const auto dir = scratch_dir("hostile-gains");
    write_rgb(dir / "in.exr");
    const std::string io = fmt::format(" -i {0}/in.exr -o {0}/out.exr", dir.string());
    for (const std::string opt : {"--gain nan", "--source-gain inf", "--min-light nan", "--fov nan", "--starburst-gain inf", "--starburst-scale nan"})
        expect_refusal(run(lensfx_in(dir) + io + kLens + " " + opt), opt.substr(0, opt.find(' ')));
    expect_refusal(run(lensfx_in(dir) + io + " --exposure nan"), "finite");
    EXPECT_NE(run(lensfx_in(dir) + io + " --exposure 1e30").exit_code, 0);
    EXPECT_FALSE(fs::exists(dir / "out.exr"));
    for (const char* gain : {"1e20", "1e39", "1e300"}) {
        const auto r = run(lensfx_in(dir) + io + kLens + " --gain " + gain);
        ASSERT_EQ(r.exit_code, 0) << gain << ": " << r.stderr_text;
        EXPECT_TRUE(all_finite(dir / "out.exr")) << "--gain " << gain;
    }
    std::ofstream(dir / "look.toml") << "[[ghost]]\nsurfaces = [2, 1]\ngain = 1e39\n";
    expect_one_line_refusal(run(lensfx_in(dir) + io + kLens + fmt::format(" --flare-look {}/look.toml", dir.string())), "gain");
    ASSERT_EQ(run(lensfx_in(dir) + io + " --exposure 64").exit_code, 0);
    EXPECT_TRUE(all_finite(dir / "out.exr"));
    fs::remove_all(dir);
}

// Class 3: frame ranges are read lazily: a range near 2^63 or of two billion frames fails at its first
// missing file at once instead of looping or listing the range in memory.
TEST(Hostile, HugeFrameRangesAreNotListed) {
    const auto dir = scratch_dir("hostile-ranges");
    const auto t0 = std::chrono::steady_clock::now();
    for (const char* frames : {"1-2147483647", "9223372036854775800-9223372036854775807", "-9223372036854775808--9223372036854775800"}) {
        const auto r = run(fmt::format("{}{} -i {}/s.#.exr -o {}/o.#.exr --frames={}", kAddressLimit, lensfx_cmd(), dir.string(), dir.string(), frames));
        expect_one_line_refusal(r, "does not exist");
        const auto t = run(fmt::format("{}{} track -i {}/s.#.exr --tracks-out {}/t.json --frames={}", kAddressLimit, lensfx_cmd(), dir.string(), dir.string(), frames));
        expect_one_line_refusal(t, "does not exist");
    }
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 30.0);
    // With --skip-bad-frames every missing frame is skipped in turn: the skipped list printed is bounded.
    write_rgb(dir / "s.0001.exr");
    const auto r = run(fmt::format("{0} -i {1}/s.#.exr -o {1}/o.#.exr --frames=1-60 --skip-bad-frames", lensfx_cmd(), dir.string()));
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find("1 frames written, 59 skipped (frames 2, 3,"), std::string::npos) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find(", ...)"), std::string::npos) << r.stderr_text;
    // Past the first RunReport::kListedSkips skipped frames, the rest are counted, not kept: memory stays bounded
    // over a range of a billion missing files (it grew by about 17 MB/s).
    const auto many = run(fmt::format("{0} -i {1}/s.#.exr -o {1}/o.#.exr --frames=1-3000 --skip-bad-frames --report {1}/r.json", lensfx_cmd(), dir.string()));
    EXPECT_EQ(many.exit_code, 0) << many.stderr_text;
    EXPECT_NE(many.stderr_text.find("1 frames written, 2999 skipped"), std::string::npos) << many.stderr_text;
    EXPECT_NE(many.stderr_text.find("counted, not listed past the first 1000"), std::string::npos) << many.stderr_text;
    EXPECT_LT(std::count(many.stderr_text.begin(), many.stderr_text.end(), '\n'), 1010) << many.stderr_text.size();
    const nlohmann::json report = nlohmann::json::parse(std::ifstream(dir / "r.json"));
    EXPECT_EQ(report["frames_skipped"], 2999);
    EXPECT_EQ(report["frames_skipped_unlisted"], 1999);
    EXPECT_EQ(report["frames"].size(), 1001u);
    fs::remove_all(dir);
}

// Class 5 (nothing lost on failure): a run that fails leaves the outputs that were there as they were. A stream of
// two frames into one file once replaced it with frame 1 before failing on frame 2; a frame list naming a
// missing file once failed there after the frames before it had replaced theirs.
TEST(Hostile, FailedRunsLeaveExistingOutputs) {
    const auto dir = scratch_dir("hostile-keep");
    const std::string d = dir.string();
    std::ofstream(dir / "single.exr") << "keep";
    const std::string pfm = "{ printf 'PF\\n4 2\\n-1.0\\n'; head -c 96 /dev/zero; }";
    const RunResult two = run(fmt::format("{{ {0}; {0}; }} | {1} -i - -o {2}/single.exr -q", pfm, lensfx_cmd(), d));
    expect_one_line_refusal(two, "frame 2: the output has no frame-number token");
    EXPECT_EQ(slurp(dir / "single.exr"), "keep");
    const RunResult one = run(fmt::format("{} | {} -i - -o {}/single.exr -q", pfm, lensfx_cmd(), d));
    EXPECT_EQ(one.exit_code, 0) << one.stderr_text;
    EXPECT_NE(slurp(dir / "single.exr"), "keep");  // a stream of one frame still writes it
    write_rgb(dir / "s.0001.exr");
    write_rgb(dir / "s.0002.exr");
    std::ofstream(dir / "o.0001.exr") << "keep";
    const RunResult gap = run(fmt::format("{0} -i {1}/s.#.exr -o {1}/o.#.exr --frames 1-3 -q", lensfx_cmd(), d));
    expect_one_line_refusal(gap, "s.0003.exr: frame 3: file does not exist");
    EXPECT_EQ(slurp(dir / "o.0001.exr"), "keep");
    EXPECT_FALSE(fs::exists(dir / "o.0002.exr"));
    for (const auto& e : fs::directory_iterator(dir)) EXPECT_NE(e.path().filename().string()[0], '.') << e.path();  // no temporaries left
    fs::remove_all(dir);
}

// Class 5: failed writes. On a full disk every output format fails in one line, non-zero, and leaves
// neither a truncated file nor a temporary. A 64 KiB tmpfs (root only; skipped otherwise) and /dev/full.
TEST(Hostile, FullDiskFailsCleanly) {
    const auto dir = scratch_dir("hostile-full");
    write_image(dir / "in.exr", {"R", "G", "B"}, OIIO::TypeFloat, 256, 256, 0.0, 0.0, true);
    const fs::path full = dir / "full";
    fs::create_directories(full);
    if (run(fmt::format("mount -t tmpfs -o size=64k tmpfs {} 2>/dev/null", full.string())).exit_code != 0) {
        fs::remove_all(dir);
        GTEST_SKIP() << "cannot mount a small tmpfs (not root?)";
    }
    // 256 x 256 noise: every format's file is larger than the 64 KiB disk, whose header fits.
    for (const char* name : {"o.png", "o.jpg", "o.exr", "o.pfm", "o.tif", "o.hdr"}) {
        const auto r = run(fmt::format("{} -i {}/in.exr -o {}/{}", lensfx_cmd(), dir.string(), full.string(), name));
        expect_one_line_refusal(r, name);
        EXPECT_FALSE(fs::exists(full / name)) << name;
        EXPECT_EQ(file_count(full), 0u) << name << ": a temporary was left";
        for (const auto& e : fs::directory_iterator(full)) fs::remove(e.path());
    }
    run(fmt::format("umount {}", full.string()));
    // Side outputs and stdout: the report, lens convert, a PFM stream, all to /dev/full.
    expect_one_line_refusal(run(lensfx_cmd() + " lens convert brendel-tessar -o - > /dev/full"), "stdout");
    expect_one_line_refusal(run(fmt::format("{} -i {}/in.exr -o - > /dev/full", lensfx_cmd(), dir.string())), "stdout");
    fs::remove_all(dir);
}

// Class 6: no side output (--report, --tracks-out, lens convert -o) may overwrite an input or the output.
TEST(Hostile, SideOutputsNeverOverwriteInputs) {
    const auto dir = scratch_dir("hostile-side");
    write_rgb(dir / "s.0001.exr");
    write_rgb(dir / "s.0002.exr");
    const std::string before = slurp(dir / "s.0001.exr");
    const std::string d = dir.string();
    expect_one_line_refusal(run(fmt::format("{0} -i {1}/s.####.exr -o {1}/o.####.exr --report {1}/s.0001.exr", lensfx_cmd(), d)), "--report");
    expect_one_line_refusal(run(fmt::format("{0} -i {1}/s.####.exr -o {1}/o.####.exr --report {1}/./s.0002.exr", lensfx_cmd(), d)), "input");
    expect_one_line_refusal(run(fmt::format("{0} -i {1}/s.0001.exr -o {1}/o.exr --report {1}/o.exr", lensfx_cmd(), d)), "output");
    expect_one_line_refusal(run(fmt::format("{0} -i {1}/s.####.exr -o {1}/o.####.exr --report {1}/o.0002.exr", lensfx_cmd(), d)), "output");
    expect_one_line_refusal(run(fmt::format("{0} track -i {1}/s.####.exr --tracks-out {1}/s.0002.exr", lensfx_cmd(), d)), "--tracks-out");
    fs::create_symlink(dir / "s.0001.exr", dir / "link.exr");
    expect_one_line_refusal(run(fmt::format("{0} track -i {1}/s.####.exr --tracks-out {1}/link.exr", lensfx_cmd(), d)), "--tracks-out");
    ASSERT_EQ(run(fmt::format("{} lens convert brendel-tessar -o {}/lens.toml", lensfx_cmd(), d)).exit_code, 0);
    const std::string lens_before = slurp(dir / "lens.toml");
    expect_one_line_refusal(run(fmt::format("{0} lens convert {1}/lens.toml -o {1}/lens.toml", lensfx_cmd(), d)), "-o");
    EXPECT_EQ(slurp(dir / "lens.toml"), lens_before);
    EXPECT_EQ(slurp(dir / "s.0001.exr"), before);
    EXPECT_FALSE(fs::exists(dir / "o.0001.exr"));
    // A report beside the outputs is fine.
    ASSERT_EQ(run(fmt::format("{0} -i {1}/s.####.exr -o {1}/o.####.exr --report {1}/report.json", lensfx_cmd(), d)).exit_code, 0);
    fs::remove_all(dir);
}

// Class 6: a side output into a folder that does not exist is refused before the work, not at its end.
TEST(Hostile, SideOutputsIntoMissingFoldersRefusedFirst) {
    const auto dir = scratch_dir("hostile-side-dir");
    write_rgb(dir / "s.0001.exr");
    const std::string d = dir.string();
    expect_one_line_refusal(run(fmt::format("{0} track -i {1}/s.####.exr --tracks-out {1}/none/t.json", lensfx_cmd(), d)), "does not exist");
    expect_one_line_refusal(run(fmt::format("{0} -i {1}/s.0001.exr -o {1}/o.exr --report {1}/none/r.json", lensfx_cmd(), d)), "does not exist");
    expect_one_line_refusal(run(fmt::format("{0} -i {1}/s.0001.exr -o {1}/none/o.exr", lensfx_cmd(), d)), "does not exist");
    EXPECT_FALSE(fs::exists(dir / "o.exr"));
    fs::remove_all(dir);
}

// Class 7: SIGTERM or SIGINT in the middle of a sequence leaves no temporary; a later run removes those
// of processes that no longer exist (and keeps those of live ones).
TEST(Hostile, SignalsLeaveNoTemporaries) {
    const auto dir = scratch_dir("hostile-signal");
    // Noise compresses slowly: most of a run's time is spent writing a temporary (before the fix, about
    // half of these runs left one).
    write_image(dir / "s.0001.exr", {"R", "G", "B"}, OIIO::TypeFloat, 1024, 1024, 0.0, 0.0, true);
    for (int f = 2; f <= 60; ++f) fs::create_hard_link(dir / "s.0001.exr", dir / fmt::format("s.{:04}.exr", f));
    const fs::path out = dir / "out";
    fs::create_directories(out);
    auto temporaries = [&] {
        int n = 0;
        for (const auto& e : fs::directory_iterator(out)) n += e.path().filename().string().find(".lensfx-") != std::string::npos;
        return n;
    };
    for (int sig : {SIGTERM, SIGINT}) {
        for (int delay_ms : {210, 330, 470, 610, 770, 950}) {
            const pid_t pid = ::fork();
            ASSERT_GE(pid, 0);
            if (pid == 0) {
                ::execl(LENSFX_BINARY, LENSFX_BINARY, "-i", (dir / "s.####.exr").c_str(), "-o", (out / "o.####.exr").c_str(),
                        "--compression", "zip", "-q", static_cast<char*>(nullptr));
                ::_exit(127);
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
            ::kill(pid, sig);
            int status = 0;
            ::waitpid(pid, &status, 0);
            EXPECT_TRUE(WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status) != 0)) << "signal " << sig;
            EXPECT_EQ(temporaries(), 0) << "signal " << sig << " after " << delay_ms << " ms";
            for (const auto& e : fs::directory_iterator(out)) fs::remove(e.path());
        }
    }
    // Stale temporaries: one of a process that is gone (a child that has exited), one of this live process.
    const pid_t gone = ::fork();
    if (gone == 0) ::_exit(0);
    ::waitpid(gone, nullptr, 0);
    std::ofstream(out / fmt::format(".o.0001.lensfx-{}.tif", gone)) << "stale";
    std::ofstream(out / fmt::format(".o.0002.lensfx-{}.tif", ::getpid())) << "live";
    ASSERT_EQ(run(fmt::format("{} -i {}/s.0001.exr -o {}/one.exr", lensfx_cmd(), dir.string(), out.string())).exit_code, 0);
    EXPECT_FALSE(fs::exists(out / fmt::format(".o.0001.lensfx-{}.tif", gone)));
    EXPECT_TRUE(fs::exists(out / fmt::format(".o.0002.lensfx-{}.tif", ::getpid())));
    fs::remove_all(dir);
}

// A 400-frame sequence of 512x512 frames in `dir` (hard links of one), for runs to stop midway.
void write_long_sequence(const fs::path& dir) {
    write_image(dir / "s.0001.exr", {"R", "G", "B"}, OIIO::TypeFloat, 512, 512, 0.0, 0.0, true);
    for (int f = 2; f <= 400; ++f) fs::create_hard_link(dir / "s.0001.exr", dir / fmt::format("s.{:04}.exr", f));
}

// lensfx started on that sequence into `out` (stderr to `err`), `sig` sent `delay` after its first frame is written;
// its wait status.
int stopped_run(const fs::path& dir, const fs::path& out, const fs::path& err, int sig, std::chrono::milliseconds delay) {
    const pid_t pid = ::fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        const int fd = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd < 0 || ::dup2(fd, STDERR_FILENO) < 0) ::_exit(126);
        for (int s : {SIGINT, SIGQUIT}) std::signal(s, SIG_DFL);  // as a terminal's foreground job has them
        ::execl(LENSFX_BINARY, LENSFX_BINARY, "-i", (dir / "s.####.exr").c_str(), "-o", (out / "o.####.exr").c_str(), "-q",
                static_cast<char*>(nullptr));
        ::_exit(127);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!fs::exists(out / "o.0001.exr") && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    std::this_thread::sleep_for(delay);
    ::kill(pid, sig);
    int status = 0;
    ::waitpid(pid, &status, 0);
    return status;
}

// The temporaries (".NAME.lensfx-PID.EXT") in `dir`.
std::vector<std::string> temporaries_in(const fs::path& dir) {
    std::vector<std::string> found;
    for (const auto& e : fs::directory_iterator(dir))
        if (e.path().filename().string().find(".lensfx-") != std::string::npos) found.push_back(e.path().filename().string());
    return found;
}

// Whether files can be made unnamed (O_TMPFILE) in `dir`: then a stopped run leaves no temporary at all.
bool writes_unnamed(const fs::path& dir) {
    const int fd = ::open(dir.c_str(), O_TMPFILE | O_WRONLY, 0600);
    if (fd < 0) return false;
    ::close(fd);
    return true;
}

// Class 7: a stopping signal says so in one line (on stderr, however the frame was being made), and the program
// still ends killed by that signal, so that a shell loop running it stops too. Sent once the first frame is
// written, while the sequence is being worked through; no temporary is left.
TEST(Hostile, StoppingSignalsSayOneLine) {
    const auto dir = scratch_dir("hostile-signal-line");
    write_long_sequence(dir);
    const fs::path out = dir / "out";
    for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) {
        fs::remove_all(out);
        fs::create_directories(out);
        const fs::path err = dir / "stderr.txt";
        const int status = stopped_run(dir, out, err, sig, std::chrono::milliseconds(0));
        ASSERT_TRUE(fs::exists(out / "o.0001.exr")) << "no frame written within a minute";
        ASSERT_TRUE(WIFSIGNALED(status)) << "signal " << sig << ": exit status " << status;
        EXPECT_EQ(WTERMSIG(status), sig);
        const std::string said = slurp(err);
        EXPECT_EQ(std::count(said.begin(), said.end(), '\n'), 1) << said;
        EXPECT_EQ(said.rfind(fmt::format("lensfx: stopped by SIG{} ", sigabbrev_np(sig)), 0), 0u) << said;
        EXPECT_FALSE(fs::exists(out / "o.0400.exr")) << "the sequence ran to its end: the signal came too late to test";
        // Files written unnamed leave nothing. Named temporaries (a file system without O_TMPFILE) can leave one that
        // the next frame's writer made after the handler's unlink; the next run in that folder removes it.
        if (writes_unnamed(out)) {
            EXPECT_TRUE(temporaries_in(out).empty()) << temporaries_in(out).front();
        }
        ASSERT_EQ(run(fmt::format("{} -i {}/s.0001.exr -o {}/again.exr -q", lensfx_cmd(), dir.string(), out.string())).exit_code, 0);
        EXPECT_TRUE(temporaries_in(out).empty()) << temporaries_in(out).front();
    }
    fs::remove_all(dir);
}

// SIGKILL (the OOM killer, scancel --signal=KILL) cannot be handled: where the output's file system takes unnamed
// files, it still leaves no temporary, at any moment of the writes; the frames written before are whole.
TEST(Hostile, KilledRunsLeaveNoTemporary) {
    const auto dir = scratch_dir("hostile-sigkill");
    const fs::path out = dir / "out";
    fs::create_directories(out);
    if (!writes_unnamed(out)) {
        fs::remove_all(dir);
        GTEST_SKIP() << "the scratch folder's file system has no O_TMPFILE";
    }
    write_long_sequence(dir);
    for (int delay_ms : {0, 13, 29, 41, 57, 71}) {
        fs::remove_all(out);
        fs::create_directories(out);
        const int status = stopped_run(dir, out, dir / "stderr.txt", SIGKILL, std::chrono::milliseconds(delay_ms));
        ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "exit status " << status;
        EXPECT_TRUE(temporaries_in(out).empty()) << "killed " << delay_ms << " ms after frame 1: " << temporaries_in(out).front();
        EXPECT_FALSE(fs::exists(out / "o.0400.exr")) << "the sequence ran to its end: the kill came too late to test";
        for (const auto& e : fs::directory_iterator(out)) EXPECT_TRUE(all_finite(e.path())) << e.path() << ": not whole";
    }
    fs::remove_all(dir);
}

// Class 8: an empty stream (a failed upstream program) is an error unless --allow-empty.
TEST(Hostile, EmptyStreamsAreErrors) {
    const auto dir = scratch_dir("hostile-empty");
    expect_one_line_refusal(run(lensfx_cmd() + " -i - -o - < /dev/null > /dev/null"), "no frames read");
    expect_one_line_refusal(run(fmt::format("{} track -i - --tracks-out {}/t.json < /dev/null", lensfx_cmd(), dir.string())), "no frames read");
    EXPECT_FALSE(fs::exists(dir / "t.json"));
    EXPECT_EQ(run(lensfx_cmd() + " -i - -o - --allow-empty < /dev/null > /dev/null").exit_code, 0);
    EXPECT_EQ(run(fmt::format("{} track -i - --tracks-out {}/t.json --allow-empty -q < /dev/null", lensfx_cmd(), dir.string())).exit_code, 0);
    EXPECT_TRUE(fs::exists(dir / "t.json"));
    fs::remove_all(dir);
}

// A frame stream on a terminal is refused (script(1) gives the program a terminal): binary EXR bytes on a user's
// screen, or a read that waits for typing.
TEST(Hostile, StreamsOnATerminalAreRefused) {
    if (run("command -v script").exit_code != 0) GTEST_SKIP() << "no script(1) to run lensfx on a terminal";
    const auto dir = scratch_dir("hostile-tty");
    write_rgb(dir / "in.exr");
    auto r = run(fmt::format("script -qec '{} -i {}/in.exr -o -' /dev/null 1>&2", lensfx_cmd(), dir.string()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("lensfx: -o -: stdout is a terminal"), std::string::npos) << r.stderr_text;
    EXPECT_EQ(r.stderr_text.find("channels"), std::string::npos) << "no frame bytes on the terminal";
    r = run(fmt::format("script -qec '{} -i - -o {}/out.exr' /dev/null < /dev/null 1>&2", lensfx_cmd(), dir.string()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("lensfx: -i -: stdin is a terminal"), std::string::npos) << r.stderr_text;
    fs::remove_all(dir);
}

// Class 9: devices and named pipes where a file is needed are refused at once (they used to hang).
TEST(Hostile, SpecialFilesAreRefused) {
    const auto dir = scratch_dir("hostile-special");
    write_rgb(dir / "in.exr");
    ASSERT_EQ(::mkfifo((dir / "fifo.exr").c_str(), 0600), 0);
    const std::string d = dir.string();
    const std::string t = "timeout 20 env ";
    expect_one_line_refusal(run(t + lensfx_cmd() + fmt::format(" -i /dev/zero -o {}/o.exr", d)), "a device, not a regular file");
    expect_one_line_refusal(run(t + lensfx_cmd() + fmt::format(" -i {0}/fifo.exr -o {0}/o.exr", d)), "a named pipe, not a regular file");
    expect_one_line_refusal(run(t + lensfx_cmd() + fmt::format(" -i {0} -o {0}/o.exr", d)), "a directory");
    expect_one_line_refusal(run(t + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr --aperture-image /dev/zero", d) + kLens), "/dev/zero");
    expect_one_line_refusal(run(t + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr --tracks {0}/fifo.exr", d) + kLens), "--tracks");
    expect_one_line_refusal(run(t + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr --flare-look /dev/zero", d) + kLens), "--flare-look");
    expect_one_line_refusal(run(t + lensfx_cmd() + fmt::format(" track -i {0}/fifo.exr --tracks-out {0}/t.json", d)), "named pipe");
    expect_one_line_refusal(run(t + lensfx_cmd() + fmt::format(" lens info {}/fifo.exr", d)), "fifo.exr");  // not read: no hang
    expect_one_line_refusal(run(t + lensfx_cmd() + " flare --lens brendel-tessar --angle 5,0 --size 32x24 --flare-look /dev/zero -o " + d + "/f.exr"),
                            "/dev/zero: not a regular file");
    fs::remove_all(dir);
}

// Class 9 (outputs): a named pipe or a device (a node made here, standing in for /dev/null) under an output's
// name is refused before anything is written, and left as it is: a file renamed onto it would replace it (as
// root, /dev/null itself). A symbolic link is written through: the link stays, the file it names is replaced.
TEST(Hostile, SpecialOutputsAreRefusedAndLinksWrittenThrough) {
    const auto dir = scratch_dir("hostile-special-out");
    write_rgb(dir / "in.exr");
    ASSERT_EQ(::mkfifo((dir / "fifo.exr").c_str(), 0600), 0);
    const bool made_device = ::mknod((dir / "null.exr").c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0;  // root only
    const std::string d = dir.string(), t = "timeout 60 env ";
    expect_one_line_refusal(run(t + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/fifo.exr", d) + kLens), "-o " + d + "/fifo.exr: a named pipe");
    expect_one_line_refusal(run(t + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr --report {0}/fifo.exr", d) + kLens), "--report");
    expect_one_line_refusal(run(t + lensfx_cmd() + fmt::format(" track -i {0}/in.exr --tracks-out {0}/fifo.exr", d)), "--tracks-out");
    expect_one_line_refusal(run(t + lensfx_cmd() + fmt::format(" lens convert brendel-tessar -o {0}/fifo.exr", d)), "a named pipe");
    EXPECT_TRUE(fs::is_fifo(dir / "fifo.exr"));
    EXPECT_FALSE(fs::exists(dir / "o.exr"));
    if (made_device) {
        expect_one_line_refusal(run(t + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/null.exr", d) + kLens), "a device");
        fs::create_symlink(dir / "null.exr", dir / "to-null.exr");
        expect_one_line_refusal(run(t + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/to-null.exr", d) + kLens), "a device");
        EXPECT_TRUE(fs::is_character_file(dir / "null.exr"));
    }
    // A link to a file: written through.
    write_rgb(dir / "target.exr");
    const auto before = fs::file_size(dir / "target.exr");
    fs::create_symlink("target.exr", dir / "link.exr");
    const RunResult r = run(t + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/link.exr", d) + kLens);
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_TRUE(fs::is_symlink(dir / "link.exr"));
    EXPECT_NE(fs::file_size(dir / "target.exr"), before);
    // A link to a file not made yet: written through, the file made. A loop of links: refused before rendering.
    fs::create_symlink("later.exr", dir / "to-later.exr");
    const RunResult later = run(t + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/to-later.exr", d) + kLens);
    EXPECT_EQ(later.exit_code, 0) << later.stderr_text;
    EXPECT_TRUE(fs::is_symlink(dir / "to-later.exr"));
    EXPECT_TRUE(fs::is_regular_file(dir / "later.exr"));
    fs::create_symlink("loop-b.exr", dir / "loop-a.exr");
    fs::create_symlink("loop-a.exr", dir / "loop-b.exr");
    expect_one_line_refusal(run(t + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/loop-a.exr", d) + kLens), "a link that leads to no file (a loop)");
    fs::remove_all(dir);
}

// Class 9 (outputs that are directories): a directory named like an image under an output's name is refused
// before anything is rendered or read, naming the option: `lensfx flare` (-o, --preview) and the filter
// reading a stream (of zeros here, no image: a refusal after the first read would name the stream instead).
TEST(Hostile, DirectoryOutputsAreRefusedBeforeRendering) {
    const auto dir = scratch_dir("hostile-dir-out");
    const std::string d = dir.string(), t = "timeout 20 env ";
    for (const char* name : {"out.exr", "preview.png", "seq.0001.exr"}) fs::create_directory(dir / name);
    const std::string flare = lensfx_in(dir) + " flare --lens brendel-tessar --angle 5,0 --size 32x24";
    expect_one_line_refusal(run(t + flare + fmt::format(" -o {}/out.exr", d)), "-o " + d + "/out.exr: a directory");
    expect_one_line_refusal(run(t + flare + fmt::format(" -o {0}/f.exr --preview {0}/preview.png", d)), "--preview " + d + "/preview.png: a directory");
    EXPECT_FALSE(fs::exists(dir / "f.exr"));
    // The preview under the EXR's own name would replace the physical image with the tone-mapped one.
    expect_one_line_refusal(run(t + flare + fmt::format(" -o {0}/f.exr --preview {0}/f.exr", d)), "--preview " + d + "/f.exr: refusing to overwrite the output");
    EXPECT_FALSE(fs::exists(dir / "f.exr"));
    const RunResult single = run("cat /dev/zero | " + t + lensfx_in(dir) + fmt::format(" -i - -o {}/out.exr", d) + kLens);
    expect_one_line_refusal(single, "-o " + d + "/out.exr: a directory");
    EXPECT_EQ(single.exit_code, 1);
    expect_one_line_refusal(run("cat /dev/zero | " + t + lensfx_in(dir) + fmt::format(" -i - -o {}/seq.####.exr", d) + kLens),
                            "-o " + d + "/seq.0001.exr: a directory");
    EXPECT_TRUE(fs::is_directory(dir / "out.exr"));
    fs::remove_all(dir);
}

// Class 10 (option values): a bad value of a numeric option is a usage error, exit 2, one line naming the
// option, found before any input is read; these once exited 1 (some only after reading the first frame, one,
// --ghost-threshold nan, not at all).
TEST(Hostile, BadOptionValuesAreUsageErrors) {
    const auto dir = scratch_dir("hostile-usage");
    write_rgb(dir / "in.exr");
    const std::string d = dir.string();
    const std::string filter = lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr --lens brendel-tessar -q", d);
    const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
        {"--threshold", {"0", "-1", "nan", "inf"}},         {"--sensor", {"0", "-1", "nan", "inf", "36x-1", "1e308", "1001", "0.09", "36x1e308"}},
        {"--zoom", {"-1", "nan", "inf", "1e308", "2", ""}},       {"--memory-limit", {"-1", "nan", "1e308", "1e-310", "", "0G"}},
        {"--dirt-seed", {"-1", "1.5", "nan", "99999999999999999999", "", "12abc", "1e3"}},
        {"--scratch-angle", {"", "1e-310", "12abc"}},         {"--queue-depth", {"99999999999", "0"}},
        {"--fstop", {"1e308", "1001"}},                       {"--bands", {"3", "82", "1e308"}},
        {"--focus", {"nan", "inf"}},                          {"--depth-scale", {"nan"}},
        {"--bits", {""}},                                     {"--threads", {"", "-1", "1e3"}},
        {"--dust", {"nan"}},                                  {"--dust-size", {"nan"}},
        {"--dust-opacity", {"nan"}},                          {"--scratch-length", {"nan"}},
        {"--scratch-width", {"nan"}},                         {"--scratch-angle", {"nan", "inf"}},
        {"--scratch-spread", {"nan"}},                        {"--ghost-threshold", {"nan"}},
        {"--layer", {"''"}}};
    for (const auto& [option, values] : cases)
        for (const std::string& value : values) {
            const RunResult r = run(filter + " " + option + " " + value);
            expect_one_line_refusal(r, option);
            EXPECT_EQ(r.exit_code, 2) << option << " " << value << ": " << r.stderr_text;
        }
    for (const char* size : {"0x0", "-5x3", "nanx2", "0"}) {
        const RunResult raw = run(fmt::format("{} -i - -o {}/o.exr --pix-fmt gbrpf32le --size {} < /dev/null", lensfx_cmd(), d, size));
        expect_one_line_refusal(raw, "--size");
        EXPECT_EQ(raw.exit_code, 2) << size << ": " << raw.stderr_text;
        const RunResult flare = run(fmt::format("{} flare --lens brendel-tessar --angle 3,3 --size {} -o {}/f.exr", lensfx_cmd(), size, d));
        expect_one_line_refusal(flare, "--size");
        EXPECT_EQ(flare.exit_code, 2) << size << ": " << flare.stderr_text;
    }
    const RunResult track = run(fmt::format("{0} track -i {1}/in.exr --tracks-out {1}/t.json --threshold 0", lensfx_cmd(), d));
    expect_one_line_refusal(track, "--threshold");
    EXPECT_EQ(track.exit_code, 2);
    EXPECT_FALSE(fs::exists(dir / "o.exr"));
    // --layer on a PFM stream in and out: the layer's channels have nowhere to go (they were dropped, and with them the
    // flare); refused once the stream's first bytes say PFM, before a frame is read.
    const RunResult layer = run(fmt::format("{{ printf 'PF\\n4 2\\n-1.0\\n'; head -c 96 /dev/zero; }} | {} -i - -o - --layer flare --lens brendel-tessar > {}/o.pfm",
                                            lensfx_cmd(), d));
    expect_one_line_refusal(layer, "--layer flare adds channels, which a pfm stream cannot carry");
    EXPECT_EQ(layer.exit_code, 1);
    // 0 is --memory-limit's documented "no limit" (as `none`), and is kept.
    EXPECT_EQ(run(filter + " --memory-limit 0").exit_code, 0);
    fs::remove_all(dir);
}

// Class 10 (silent no-ops): an option that means something only with another, or for another kind of output, is a
// usage error naming it; each was accepted and did nothing. Where it does apply, it is accepted.
TEST(Hostile, OptionsThatWouldDoNothingAreRefused) {
    const auto dir = scratch_dir("hostile-idle");
    write_rgb(dir / "in.exr");
    const std::string d = dir.string();
    const std::string run_to = lensfx_in(dir) + fmt::format(" -i {0}/in.exr --lens brendel-tessar --threshold 1e9 -q -o {0}/", d);
    const std::vector<std::pair<std::string, std::string>> idle = {
        {"o.exr --focus 2", "--focus"},          {"o.exr --tilt 5,0", "--tilt"},
        {"o.exr --focus-point 1,1,2", "--focus-point"}, {"o.exr --dof-rays 8", "--dof-rays"},
        {"o.exr --depth-scale 2", "--depth-scale"},     {"o.exr --dof-only", "--dof-only"},
        {"o.exr --dither ordered", "--dither"},         {"o.pfm --compression zip", "--compression"},
        {"o.png --compression zip", "--compression"},   {"o.exr --pfm-order top", "--pfm-order"},
        {"o.exr --dof --focus 2 --tilt nan,0", "--tilt"}, {"o.exr --dof --focus 2 --tilt 89,0", "--tilt"}};
    for (const auto& [args, option] : idle) {
        const RunResult r = run(run_to + args);
        expect_one_line_refusal(r, option);
        EXPECT_EQ(r.exit_code, 2) << args << ": " << r.stderr_text;
    }
    for (const char* args : {"o.exr --compression zip", "o.png --dither ordered", "o.exr --dither none", "o.pfm --pfm-order top"}) {
        const RunResult r = run(run_to + args);
        EXPECT_EQ(r.exit_code, 0) << args << ": " << r.stderr_text;
    }
    fs::remove_all(dir);
}

// Class 10 (option values, every command): what CLI11's own conversion lets through (an empty value read as 0,
// NaN past its range checks, "-1" wrapped to the largest unsigned, 99999999999999999999 saturated) and the
// sizes past what the code can hold are usage errors in every command (exit 2, one line naming the option),
// before any lens, light or file is looked at. `lensfx flare --sensor 1e308` once crashed in the starburst,
// --sensor 1x1e308 never ended.
TEST(Hostile, EveryCommandRefusesHostileNumbers) {
    const auto dir = scratch_dir("hostile-numbers");
    const std::string d = dir.string(), t = "timeout 20 env " + lensfx_in(dir);
    const std::string flare = fmt::format(" flare --lens brendel-tessar --angle 5,0 -o {}/f.exr", d);
    const std::string track = fmt::format(" track -i {0}/missing.exr --tracks-out {0}/t.json", d);
    const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
        {flare + " --sensor", {"1e308", "1e-10", "1x1e308", "1e308x1"}},
        {" flare --lens brendel-tessar -o f.exr --angle", {"1e308,0", "0,90", "-90,0", "nan,0"}},
        {flare + " --seed", {"-1", "99999999999999999999", ""}},
        {flare + " --dirt-seed", {"-1", "0.5"}},
        {flare + " --exposure", {"1e308", "nan"}},
        {flare + " --rays", {"99999999", "0"}},
        {flare + " --grid", {"100000000", "-5"}},
        {flare + " --bands", {"100000", "-3", "5"}},
        {flare + " --starburst-scale", {"inf", "nan"}},
        {flare + " --iso", {"nan"}},
        {track + " --hysteresis", {"nan", "inf"}},
        {track + " --gate", {"nan", ""}},
        {track + " --visibility", {"nan"}},
        {track + " --max-lights", {"2000000000", "-1"}},
        {" lens info brendel-tessar --fstop", {"1e308", "inf"}},
        {" lens info brendel-tessar --sensor", {"1e308x24", "36x0"}},
        {" lens trace brendel-tessar --angle 1 --height", {"nan", "inf", ""}},
        {fmt::format(" farm -i {0}/s.####.exr -o {0}/o.####.exr --engine local --retries", d), {"2000000000", "-1"}},
        {" bench time-vs-error --quick --rays", {"99999999", ""}}};
    for (const auto& [command, values] : cases)
        for (const std::string& value : values) {
            const RunResult r = run(fmt::format("{}{} '{}'", t, command, value));
            const std::string option = command.substr(command.rfind(' ') + 1);
            expect_one_line_refusal(r, option);
            EXPECT_EQ(r.exit_code, 2) << command << " " << value << ": " << r.stderr_text;
        }
    // "010" is ten, not octal eight: the seed a script zero-pads is the seed it means.
    const std::string dirt = " flare --lens brendel-tessar --angle 5,0 --size 64x48 --dust 200 --parts starburst --dirt-seed ";
    ASSERT_EQ(run(t + dirt + "010 -o " + d + "/a.exr").exit_code, 0);
    ASSERT_EQ(run(t + dirt + "10 -o " + d + "/b.exr").exit_code, 0);
    ASSERT_EQ(run(t + dirt + "8 -o " + d + "/c.exr").exit_code, 0);
    EXPECT_TRUE(slurp(dir / "a.exr") == slurp(dir / "b.exr"));
    EXPECT_FALSE(slurp(dir / "a.exr") == slurp(dir / "c.exr"));
    fs::remove_all(dir);
}

// Class 9 (full and odd outputs, red-team pass): /dev/full as -o names the device (it once said "unknown output
// format"); `track --tracks-out -` writes to stdout, as --report - does (it wrote a file named "-" and said
// nothing of a full stdout); --help and --version to a full stdout fail in one line (they exited 0); a misspelt
// key in a --config shot file is a usage error (it was ignored).
TEST(Hostile, FullOutputsAndShotFileTyposAreOneLine) {
    const auto dir = scratch_dir("hostile-full");
    write_rgb(dir / "in.exr");
    const std::string d = dir.string();
    if (fs::exists("/dev/full")) {
        expect_one_line_refusal(run(lensfx_cmd() + fmt::format(" -i {}/in.exr -o /dev/full", d)), "-o /dev/full: a device");
        expect_one_line_refusal(run(fmt::format("cd {} && {} track -i in.exr --tracks-out - > /dev/full", d, lensfx_cmd())), "stdout: write failed");
        for (const char* printing : {" --help", " --version", " flare --help"}) {
            const RunResult r = run(lensfx_cmd() + printing + " > /dev/full");
            expect_one_line_refusal(r, "stdout: write failed");
            EXPECT_EQ(r.exit_code, 1) << printing;
        }
    }
    const RunResult tracks = run(fmt::format("cd {0} && {1} track -i in.exr --tracks-out - -q > {0}/piped.json", d, lensfx_cmd()));
    EXPECT_EQ(tracks.exit_code, 0) << tracks.stderr_text;
    EXPECT_NE(slurp(dir / "piped.json").find("\"lensfx-tracks\""), std::string::npos) << slurp(dir / "piped.json");
    EXPECT_FALSE(fs::exists(dir / "-"));
    std::ofstream(dir / "shot.toml") << "input = \"" << d << "/in.exr\"\noutput = \"" << d << "/o.exr\"\nexposre = 2\n";
    const RunResult shot = run(fmt::format("{} --config {}/shot.toml", lensfx_cmd(), d));
    expect_one_line_refusal(shot, "exposre");
    EXPECT_EQ(shot.exit_code, 2);
    EXPECT_FALSE(fs::exists(dir / "o.exr"));
    // A subcommand's section: its keys are that command's options, a typo among them refused too.
    const std::string section = fmt::format("[flare]\nlens = \"brendel-tessar\"\nangle = \"5,0\"\nsize = \"32x24\"\noutput = \"{}/f.exr\"\n", d);
    std::ofstream(dir / "flare.toml") << section;
    std::ofstream(dir / "typo.toml") << section << "gian = 2\n";
    const RunResult typo = run(fmt::format("{} --config {}/typo.toml flare", lensfx_in(dir), d));
    expect_one_line_refusal(typo, "gian");
    EXPECT_EQ(typo.exit_code, 2);
    EXPECT_FALSE(fs::exists(dir / "f.exr"));
    const RunResult good = run(fmt::format("{} --config {}/flare.toml flare", lensfx_in(dir), d));
    EXPECT_EQ(good.exit_code, 0) << good.stderr_text;
    EXPECT_TRUE(fs::exists(dir / "f.exr"));
    fs::remove_all(dir);
}

// Class 9 (unreadable files, red-team pass): an input or lens file the user may not read says so; the input's
// once said "is not an OpenEXR file". Root reads everything, so as root the runs drop to nobody (setpriv).
// Whether every folder above `path` lets other users through (nobody can reach the path).
bool reachable_by_others(const fs::path& path) {
    for (fs::path up = fs::absolute(path).parent_path(); up != up.root_path(); up = up.parent_path())
        if ((fs::status(up).permissions() & fs::perms::others_exec) == fs::perms::none) return false;
    return true;
}

TEST(Hostile, UnreadableFilesSayPermissionDenied) {
    const bool root = ::geteuid() == 0;
    if (root && run("command -v setpriv").exit_code != 0) GTEST_SKIP() << "root without setpriv: every file is readable";
    // A build inside a private folder (a clone in `mktemp -d`, mode 0700) cannot be run as nobody.
    if (root && !reachable_by_others(LENSFX_BINARY)) GTEST_SKIP() << LENSFX_BINARY << " is not reachable by nobody";
    const auto dir = scratch_dir("hostile-unreadable");
    write_rgb(dir / "in.exr");
    fs::copy_file(dir / "in.exr", dir / "secret.exr");
    std::ofstream(dir / "secret.toml") << "not read\n";
    fs::permissions(dir / "secret.exr", fs::perms::owner_read | fs::perms::owner_write);
    fs::permissions(dir / "secret.toml", fs::perms::owner_read | fs::perms::owner_write);
    fs::permissions(dir, fs::perms::all);
    ASSERT_TRUE(!root || reachable_by_others(dir)) << dir << " is closed to nobody";
    const std::string as_user = root ? "setpriv --reuid=65534 --regid=65534 --clear-groups env " : "env ";
    const std::string d = dir.string(), lensfx = as_user + "LENSFX_CACHE_DIR=none " + lensfx_cmd();
    expect_one_line_refusal(run(lensfx + fmt::format(" -i {0}/secret.exr -o {0}/o.exr", d)), "secret.exr: frame 1: cannot read: Permission denied");
    expect_one_line_refusal(run(lensfx + fmt::format(" -i {0}/in.exr -o {0}/o.exr --lens {0}/secret.toml", d)),
                            "secret.toml: cannot open the lens file: Permission denied");
    EXPECT_FALSE(fs::exists(dir / "o.exr"));
    fs::remove_all(dir);
}

// Class 11 (address space): under a low `ulimit -v` a render is refused at once in one line naming the limit,
// where llvmpipe's JIT aborted ("LLVM ERROR: Unable to allocate section memory"), crashed, or failed in three
// lines, and a run that ran out in the GL driver left a wrong ghost bounds table in the cache (CandleGlass.exr:
// 104 ghosts drawn instead of 85 by every later run). What renders nothing (lens info) still runs.
TEST(Hostile, ALowAddressSpaceLimitIsOneLine) {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space at start";
#endif
    const auto dir = scratch_dir("hostile-ulimit");
    write_rgb(dir / "in.exr");
    const std::string d = dir.string();
    for (const char* limit : {"ulimit -v 262144; ", "ulimit -v 450000; "}) {
        const RunResult filter = run(limit + lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr", d) + kLens);
        expect_one_line_refusal(filter, "ulimit -v");
        EXPECT_EQ(filter.exit_code, 1);
        const RunResult flare = run(limit + lensfx_in(dir) + fmt::format(" flare --lens brendel-tessar --angle 5,0 --size 64x48 --parts starburst -o {}/f.exr", d));
        expect_one_line_refusal(flare, "ulimit -v");
    }
    EXPECT_FALSE(fs::exists(dir / "o.exr"));
    EXPECT_FALSE(fs::exists(dir / "f.exr"));
    EXPECT_FALSE(fs::exists(dir / "cache") && !fs::is_empty(dir / "cache")) << "nothing was computed, so nothing was cached";
    const RunResult info = run("ulimit -v 262144; " + lensfx_cmd() + " lens info brendel-tessar");
    EXPECT_EQ(info.exit_code, 0) << info.stderr_text;
    fs::remove_all(dir);
}

// Class 10 (silent no-ops): requests that are legal but add no flare exit 0 and say so: --gain 0 (a warning
// before the run), lights beyond the field the lens images (--fov 179: the run's summary), an --add-light
// disc too dim to become a light (the summary).
TEST(Hostile, NoFlareAddedIsSaid) {
    const auto dir = scratch_dir("hostile-no-flare");
    write_rgb(dir / "in.exr");
    const std::string d = dir.string();
    const std::string filter = lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr --lens brendel-tessar --fstop 4 --grid 8 --threshold 100", d);
    const auto said = [&](const std::string& options, const std::string& text) {
        const RunResult r = run(filter + options);
        EXPECT_EQ(r.exit_code, 0) << options << ": " << r.stderr_text;
        EXPECT_NE(r.stderr_text.find(text), std::string::npos) << options << ": expected \"" << text << "\" in: " << r.stderr_text;
    };
    said(" --gain 0", "lensfx: warning: --gain 0: no flare is added");
    said(" --parts ghosts --ghost-gain 0", "lensfx: warning: every part drawn has a gain of 0");
    said(" --fov 179", "no flare was added: every light lies outside the field the lens images");
    said(" --add-light 40,30,50", "--add-light 40,30,50 is below the threshold 100 and adds no light");
    const RunResult plain = run(filter);  // a flare added: none of it said
    EXPECT_EQ(plain.stderr_text.find("no flare"), std::string::npos) << plain.stderr_text;
    EXPECT_EQ(plain.stderr_text.find("outside the field"), std::string::npos) << plain.stderr_text;
    fs::remove_all(dir);
}

// Class 10 (messages that say what is true): a raw stream that ends inside a frame is told in the frame's
// bytes (once the row's: "200 of 400" for 7000 of 12000), and a subnormal --add-light value is a number (it
// was refused as not finite).
TEST(Hostile, MessagesSayWhatIsTrue) {
    const auto dir = scratch_dir("hostile-true");
    write_rgb(dir / "in.exr");
    const std::string d = dir.string();
    const auto raw = [&](int bytes) {
        return run(fmt::format("head -c {} /dev/zero | {} -i - -o - --pix-fmt gbrpf32le --size 100x10 > /dev/null", bytes, lensfx_cmd()));
    };
    expect_one_line_refusal(raw(7000), "frame 1: stream ended inside a 100x10 gbrpf32le frame (7000 of 12000 bytes)");
    expect_one_line_refusal(raw(12000 + 300), "frame 2: stream ended inside a 100x10 gbrpf32le frame (300 of 12000 bytes)");
    const RunResult tiny = run(lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr --add-light 10,10,1e-310", d) + kLens);
    EXPECT_EQ(tiny.exit_code, 0) << tiny.stderr_text;
    fs::remove_all(dir);
}

// Class 9 (standard streams): started with stderr closed, a failure is still a non-zero exit, not an abort,
// and no file the run opens takes stderr's number (a message would land inside it).
TEST(Hostile, AClosedStderrIsNoAbort) {
    const auto dir = scratch_dir("hostile-closed-stderr");
    write_rgb(dir / "in.exr");
    const std::string d = dir.string();
    EXPECT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/missing.exr -o {0}/o.exr 2>&-", d)).exit_code, 1);
    const RunResult ok = run(lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr", d) + kLens + " 2>&-");
    EXPECT_EQ(ok.exit_code, 0);
    EXPECT_TRUE(all_finite(dir / "o.exr"));
    fs::remove_all(dir);
}

// Class 9 (closed output pipe): a reader that closes stdout (`| head -c 1`; here `| true`, closed before the
// first write) fails the run with one line saying so, exit 1, not a silent death by SIGPIPE (141); the
// frames written to files before it stay.
TEST(Hostile, AClosedOutputPipeIsOneLine) {
    const auto dir = scratch_dir("hostile-closed-pipe");
    write_rgb(dir / "in.exr");
    const std::string d = dir.string();
    const std::string closed = "the output pipe was closed by its reader";
    const RunResult raw = run(lensfx_in(dir) + fmt::format(" -i {}/in.exr -o - --pix-fmt gbrapf32le", d) + kLens + " | true");
    expect_one_line_refusal(raw, closed);
    EXPECT_EQ(raw.exit_code, 1) << raw.stderr_text;
    const RunResult report = run(lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr --report -", d) + kLens + " | true");
    expect_one_line_refusal(report, closed);
    EXPECT_EQ(report.exit_code, 1) << report.stderr_text;
    EXPECT_TRUE(all_finite(dir / "o.exr"));
    expect_one_line_refusal(run(lensfx_cmd() + " lens list | true"), closed);
    fs::remove_all(dir);
}

// Class 9 (cache folder): a named pipe under a cache file's name is read as a miss, not opened (opening it
// waited for a writer for ever). Two runs fill the cache (flare with a point and an extended light: bounds,
// direct power, starburst, ghost imaging; the lens blur: its ray table), every file is swapped for a pipe,
// and the same runs must finish, under a timeout, and leave real cache files in the pipes' places.
TEST(Hostile, PipesInTheCacheFolderAreMisses) {
    const auto dir = scratch_dir("hostile-cache-fifo");
    const fs::path cache = dir / "cache";
    write_image(dir / "in.exr", {"R", "G", "B", "Z"}, OIIO::TypeFloat, 96, 64);
    write_disc(dir / "disc.exr", 60.3, 40.6, 12.0, 200.0);
    const std::string d = dir.string(), t = "timeout 60 env ";
    const std::string flare = lensfx_in(dir) + fmt::format(" -i {0}/disc.exr -o {0}/f.exr", d) + kLens;
    const std::string point = lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/p.exr", d) + kLens;
    const std::string dof = lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/d.exr --dof --dof-only --lens brendel-tessar --focus 1 -q", d);
    for (const std::string& c : {flare, point, dof}) ASSERT_EQ(run(t + c).exit_code, 0) << c;
    std::vector<fs::path> files;
    for (const auto& f : fs::directory_iterator(cache)) files.push_back(f.path());
    for (const char* kind : {"bounds-", "direct-", "starburst-", "imaging-", "dof-rays-"})
        EXPECT_TRUE(std::any_of(files.begin(), files.end(), [&](const fs::path& f) { return f.filename().string().rfind(kind, 0) == 0; }))
            << "no " << kind << " file: the test no longer covers that cache";
    for (const fs::path& f : files) {
        fs::remove(f);
        ASSERT_EQ(::mkfifo(f.c_str(), 0600), 0) << f;
    }
    for (const std::string& c : {flare, point, dof}) {
        const RunResult r = run(t + c);
        EXPECT_EQ(r.exit_code, 0) << c << ": " << r.stderr_text;  // 124: a reader blocked on a pipe
    }
    for (const fs::path& f : files) EXPECT_TRUE(fs::is_regular_file(f)) << f << ": the cache file was not made again";
    fs::remove_all(dir);
}

// Class 10: the smaller ones.
TEST(Hostile, SmallerOnes) {
    const auto dir = scratch_dir("hostile-small");
    const std::string d = dir.string();
    write_rgb(dir / "in.exr");
    const std::string io = fmt::format(" -i {0}/in.exr -o {0}/out.exr", d);
    // A frame without R, G, B (nor Y: test_luminance_e2e.cpp) says what the flare needs and what the frame has.
    write_image(dir / "rg.exr", {"R", "G", "A"});
    expect_one_line_refusal(run(lensfx_in(dir) + fmt::format(" -i {0}/rg.exr -o {0}/out.exr", d) + kLens), "this frame has");
    // uint32 R, G, B (an id pass as colour) are not colour: the flare says so instead of skipping.
    write_image(dir / "u.exr", {"R", "G", "B"}, OIIO::TypeUInt32);
    expect_one_line_refusal(run(lensfx_in(dir) + fmt::format(" -i {0}/u.exr -o {0}/out.exr", d) + kLens), "uint32");
    // --layer names EXR cannot hold; --blades no iris has; absurd thread counts and wavelengths.
    expect_one_line_refusal(run(lensfx_in(dir) + io + kLens + " --layer " + std::string(300, 'x')), "--layer");
    for (const char* blades : {"1", "2"}) expect_one_line_refusal(run(lensfx_in(dir) + io + kLens + " --blades " + blades), "--blades");
    EXPECT_NE(run(lensfx_cmd() + io + " --threads 1000000").exit_code, 0);
    EXPECT_NE(run(lensfx_cmd() + fmt::format(" flare --lens brendel-tessar --angle 5,0 --size 32x24 --wavelength 1e9 -o {}/f.exr", d)).exit_code, 0);
    EXPECT_FALSE(fs::exists(dir / "out.exr"));
    // Duplicate ghost entries in a look are refused rather than multiplied.
    std::ofstream(dir / "look.toml") << "[[ghost]]\nsurfaces = [3, 1]\ngain = 2\n[[ghost]]\nsurfaces = [1, 3]\ngain = 2\n";
    expect_one_line_refusal(run(lensfx_in(dir) + io + kLens + fmt::format(" --flare-look {}/look.toml", d)), "already styled");
    // A gap in an auto-detected sequence is warned about.
    for (int f : {1, 2, 5}) fs::copy_file(dir / "in.exr", dir / fmt::format("s.{:04}.exr", f));
    const auto gap = run(fmt::format("{0} -i {1}/s.####.exr -o {1}/o.####.exr", lensfx_cmd(), d));
    EXPECT_EQ(gap.exit_code, 0) << gap.stderr_text;
    EXPECT_NE(gap.stderr_text.find("frames 3-4 are missing"), std::string::npos) << gap.stderr_text;
    // An unusable cache folder is warned about once at most.
    std::ofstream(dir / "notadir") << "x";
    const auto cache = run(fmt::format("LENSFX_CACHE_DIR={0}/notadir/cache {1} -i {0}/in.exr -o {0}/out.exr --lens brendel-tessar --fstop 4 --grid 8 --threshold 100",
                                       d, lensfx_cmd()));
    EXPECT_EQ(cache.exit_code, 0) << cache.stderr_text;
    // One warning about the cache (the run's one-line summary of its lights follows it).
    std::size_t cache_lines = 0;
    for (std::size_t at = 0; (at = cache.stderr_text.find("cache", at)) != std::string::npos; at = cache.stderr_text.find('\n', at)) ++cache_lines;
    EXPECT_EQ(cache_lines, 1u) << cache.stderr_text;
    fs::remove_all(dir);
}

// The newer options under the same classes: absurd, non-finite and far-away values of --add-light,
// --focus-point and --coating-spread are usage errors (exit 2) or one-line refusals, never a crash or a
// frame-sized allocation; an output naming the --matte file is refused and leaves it unchanged.
TEST(Hostile, NewerOptionsRefuseHostileValues) {
    const auto dir = scratch_dir("hostile-newer");
    write_rgb(dir / "in.exr");  // 64 x 48
    write_image(dir / "inz.exr", {"R", "G", "B", "Z"});
    const std::string d = dir.string();
    const std::string flare = fmt::format("{} -i {}/in.exr -o {}/o.exr --lens brendel-tessar", lensfx_cmd(), d, d);
    for (const char* light : {"3e9,3e9,100", "nan,10,100", "10,10,inf", "10,10,1e300", "10,10,100,2,5"}) {
        const auto r = run(fmt::format("{}{} --add-light {}", kAddressLimit, flare, light));
        expect_one_line_refusal(r, "--add-light");
        EXPECT_EQ(r.exit_code, 2) << light << ": " << r.stderr_text;
    }
    expect_one_line_refusal(run(fmt::format("{}{} --add-light 5000,10,100", kAddressLimit, flare)), "display window");
    const auto spread = run(flare + " --coating-spread nan");
    expect_one_line_refusal(spread, "--coating-spread");
    EXPECT_EQ(spread.exit_code, 2);

    const std::string dof = fmt::format("{} -i {}/inz.exr -o {}/o.exr --lens brendel-tessar --dof --focus 2 --dof-only", lensfx_cmd(), d, d);
    const auto near = run(dof + " --focus-point 10,10,1e-300");  // once an exception escaping a ray thread
    expect_one_line_refusal(near, "--focus-point 10,10,1e-300");
    EXPECT_EQ(near.exit_code, 1);
    for (const char* point : {"1e30,10,2", "10,10,nan", "10,10,1e300", "10,10"}) {
        const auto r = run(fmt::format("{} --focus-point {}", dof, point));
        expect_one_line_refusal(r, "--focus-point");
        EXPECT_EQ(r.exit_code, 2) << point << ": " << r.stderr_text;
    }

    write_image(dir / "matte.exr", {"R", "G", "B"});
    const std::string matte_before = slurp(dir / "matte.exr");
    expect_one_line_refusal(run(fmt::format("{} -i {}/in.exr -o {}/matte.exr --lens brendel-tessar --matte {}/matte.exr", lensfx_cmd(), d, d, d)),
                            "--matte");
    expect_one_line_refusal(run(fmt::format("{} -i {}/in.exr -o {}/./matte.exr --lens brendel-tessar --matte {}/matte.exr", lensfx_cmd(), d, d, d)),
                            "--matte");
    EXPECT_EQ(slurp(dir / "matte.exr"), matte_before);
    fs::remove_all(dir);
}

// The thirty-fourth stop's red team: R, G or B named as the depth or matte channel of an RGB frame (whose
// pixels the stages hold only as R, G, B) and depths of 1e-10 m (a blur reach past any int) crashed; a light
// outside the display window, which the lens cannot image, added nothing and said nothing.
TEST(Hostile, ColourChannelsAsDepthOrMatteAndTinyDepths) {
    const auto dir = scratch_dir("hostile-channels");
    write_rgb(dir / "in.exr");
    const std::string d = dir.string();
    const std::string dof = lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/d.exr --dof --dof-only --lens brendel-tessar --focus 3 -q", d);
    for (const char* c : {"R", "G", "B"}) {
        const RunResult r = run(dof + " --depth-channel " + c);
        EXPECT_EQ(r.exit_code, 0) << c << ": " << r.stderr_text;
        EXPECT_TRUE(all_finite(dir / "d.exr")) << c;
    }
    const RunResult matte = run(lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/m.exr --matte-channel R", d) + kLens);
    EXPECT_EQ(matte.exit_code, 0) << matte.stderr_text;
    {  // Z of 1e-10 m everywhere
        OIIO::ImageSpec spec(64, 48, 4, OIIO::TypeFloat);
        spec.channelnames = {"R", "G", "B", "Z"};
        std::vector<float> px(64 * 48 * 4, 0.5f);
        for (std::size_t i = 3; i < px.size(); i += 4) px[i] = 1e-10f;
        auto out = OIIO::ImageOutput::create((dir / "z.exr").string());
        ASSERT_TRUE(out && out->open((dir / "z.exr").string(), spec) && out->write_image(OIIO::TypeFloat, px.data()) && out->close());
    }
    const RunResult tiny = run(lensfx_in(dir) + fmt::format(" -i {0}/z.exr -o {0}/dz.exr --dof --dof-only --lens brendel-tessar --focus 3 -q", d));
    EXPECT_EQ(tiny.exit_code, 0) << tiny.stderr_text;
    EXPECT_TRUE(all_finite(dir / "dz.exr"));
    {  // the light at (20, 16) of a 64 x 48 data window whose display window is its first pixel
        OIIO::ImageSpec spec(64, 48, 3, OIIO::TypeFloat);
        spec.full_width = spec.full_height = 1;
        std::vector<float> px(64 * 48 * 3, 0.05f);
        for (int c = 0; c < 3; ++c) px[(16 * 64 + 20) * 3 + static_cast<std::size_t>(c)] = 5000.0f;
        auto out = OIIO::ImageOutput::create((dir / "window.exr").string());
        ASSERT_TRUE(out && out->open((dir / "window.exr").string(), spec) && out->write_image(OIIO::TypeFloat, px.data()) && out->close());
    }
    const RunResult outside = run(lensfx_in(dir) + fmt::format(" -i {0}/window.exr -o {0}/w.exr --lens brendel-tessar --threshold 100", d));
    EXPECT_EQ(outside.exit_code, 0) << outside.stderr_text;
    EXPECT_NE(outside.stderr_text.find("no flare was added: every light lies outside the field"), std::string::npos) << outside.stderr_text;
    fs::remove_all(dir);
}

// Files that cost unbounded memory or that a run only found unwritable at its end: a shot file nested 100,000
// levels deep (24 GB before the kernel stopped it) or of binary bytes, an aperture image 20000 x 1 (padded to a
// square of 1.6 GB whatever --memory-limit said), a --report that cannot be written (the frames were written
// first, replacing an output, and then the run failed), a refused sequence (a warning about its gap came first).
TEST(Hostile, UnboundedFilesAndLateFailuresAreRefusedFirst) {
    const auto dir = scratch_dir("hostile-late");
    write_rgb(dir / "in.exr");
    const std::string d = dir.string();
    std::ofstream(dir / "deep.toml") << "[" << [] { std::string s; for (int i = 0; i < 100000; ++i) s += "a."; return s; }() << "b]\n";
    const RunResult deep = run(fmt::format("{}{} --config {}/deep.toml", kAddressLimit, lensfx_cmd(), d));
    expect_one_line_refusal(deep, "levels deep");
    EXPECT_EQ(deep.exit_code, 2);
    std::ofstream(dir / "binary.toml") << std::string("input = \"a\"\n\x01\x02\x7f\n", 16);
    expect_one_line_refusal(run(fmt::format("{} --config {}/binary.toml", lensfx_cmd(), d)), "line 2: not a text file");
    {  // 20000 x 1, clear
        OIIO::ImageSpec spec(20000, 1, 1, OIIO::TypeUInt8);
        std::vector<unsigned char> px(20000, 255);
        auto out = OIIO::ImageOutput::create((dir / "wide.png").string());
        ASSERT_TRUE(out && out->open((dir / "wide.png").string(), spec) && out->write_image(OIIO::TypeUInt8, px.data()) && out->close());
    }
    const RunResult wide = run(fmt::format("{}{} -i {}/in.exr -o {}/a.exr --aperture-image {}/wide.png", kAddressLimit, lensfx_in(dir), d, d, d) + kLens);
    EXPECT_EQ(wide.exit_code, 0) << wide.stderr_text;
    std::ofstream(dir / "o.exr") << "precious";
    expect_one_line_refusal(run(lensfx_in(dir) + fmt::format(" -i {0}/in.exr -o {0}/o.exr --report /proc/version", d) + kLens), "cannot write a file there");
    EXPECT_EQ(slurp(dir / "o.exr"), "precious");
    for (int f : {1, 2, 5}) fs::copy_file(dir / "in.exr", dir / fmt::format("s.{:04}.exr", f));
    expect_one_line_refusal(run(fmt::format("{0} -i {1}/s.####.exr -o {1}/one.exr", lensfx_cmd(), d)), "no frame-number token");
    fs::remove_all(dir);
}
