// `lensfx -i IN -o OUT --dof`: the stage through the program on small synthetic EXRs with Z.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <set>
#include <string>

#include "../filter/filter_test_util.h"
#include "exr_rgbz.h"

namespace lensfx::dof::test {
namespace {

constexpr int kSize = 48;

// A black plane at 2 m with a bright 4 x 4 square of energy 1000 in the middle.
std::string point_exr(const std::filesystem::path& dir, bool with_z) {
    std::vector<float> rgb(kSize * kSize, 0.0f), z(kSize * kSize, 2.0f);
    for (int y = kSize / 2 - 2; y < kSize / 2 + 2; ++y)
        for (int x = kSize / 2 - 2; x < kSize / 2 + 2; ++x) rgb[static_cast<std::size_t>(y * kSize + x)] = 1000.0f / 16.0f;
    const std::string path = (dir / (with_z ? "point.exr" : "flat.exr")).string();
    if (with_z) write_exr(path, kSize, kSize, {"R", "G", "B", "Z"}, {rgb, rgb, rgb, z});
    else write_exr(path, kSize, kSize, {"R", "G", "B"}, {rgb, rgb, rgb});
    return path;
}

TEST(DofFilter, BlursAPointBehindTheFocusAndKeepsItsEnergy) {
    const auto dir = lensfx::test::scratch_dir("dof_point");
    const std::string in = point_exr(dir, true), out = (dir / "out.exr").string();
    const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out +
                                     " --dof --dof-only --lens mld-double-gauss --fstop 4 --focus 1 --sensor 6 --dof-rays 256");
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    int w = 0, h = 0;
    const std::vector<float> g = read_channel(out, "G", w, h);
    ASSERT_EQ(w, kSize);
    const double sum = std::accumulate(g.begin(), g.end(), 0.0);
    EXPECT_LT(g[kSize / 2 * kSize + kSize / 2], 1000.0f / 16.0f / 4.0f) << "spread over many pixels";
    // focused at 1 m the lens images 2 m 1.096 times larger than the plate's own scale (focus breathing,
    // DofReference.DefocusedPoint...): 1000 x 1.096^2, within the noise of 256 rays per pixel
    EXPECT_NEAR(sum / (1000.0 * 1.096 * 1.096), 1.0, 0.03);
    const std::vector<float> z = read_channel(out, "Z", w, h);
    EXPECT_FLOAT_EQ(z[0], 2.0f) << "other channels pass through";
}

// With the flare: the light is found on the sharp plate, and its flare lands on the blurred plate.
TEST(DofFilter, FlareIsAddedAfterTheBlur) {
    const auto dir = lensfx::test::scratch_dir("dof_flare");
    const std::string in = point_exr(dir, true), blur = (dir / "blur.exr").string(), both = (dir / "both.exr").string();
    const std::string common = " --dof --lens mld-double-gauss --fstop 4 --focus 1 --sensor 6 --dof-rays 16";
    auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + blur + common + " --dof-only");
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + both + common);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    int w = 0, h = 0;
    const std::vector<float> a = read_channel(blur, "G", w, h), b = read_channel(both, "G", w, h);
    double added = 0.0, below = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        added += double{b[i]} - double{a[i]};
        below = std::min(below, double{b[i]} - double{a[i]});
    }
    EXPECT_GT(added, 0.0) << "the flare adds light";
    EXPECT_GT(below, -1e-3) << "and takes none away from the blurred plate";
}

// A rendered foreground element (premultiplied white square, alpha 1, at 0.5 m over alpha 0 with no depth),
// focus at 2 m: the output's A blurs with its colour.
TEST(DofFilter, AlphaBlursWithTheColour) {
    const auto dir = lensfx::test::scratch_dir("dof_alpha");
    std::vector<float> rgb(kSize * kSize, 0.0f), z(kSize * kSize, 0.0f);
    for (int y = 12; y < 36; ++y)
        for (int x = 12; x < 36; ++x) rgb[static_cast<std::size_t>(y * kSize + x)] = 1.0f, z[static_cast<std::size_t>(y * kSize + x)] = 0.5f;
    const std::string in = (dir / "element.exr").string(), out = (dir / "out.exr").string();
    write_exr(in, kSize, kSize, {"R", "G", "B", "A", "Z"}, {rgb, rgb, rgb, rgb, z});
    const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out +
                                     " --dof --dof-only --lens mld-double-gauss --fstop 2.8 --focus 2 --sensor 36 --dof-rays 16 --cache-dir none");
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    int w = 0, h = 0;
    const std::vector<float> a = read_channel(out, "A", w, h), g = read_channel(out, "G", w, h);
    const auto soft = std::count_if(a.begin(), a.end(), [](float v) { return v > 0.05f && v < 0.95f; });
    EXPECT_GT(soft, 4 * 24) << "a soft rim all round the square, not its hard edge";
    double differ = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) differ = std::max(differ, double{std::abs(a[i] - g[i])});
    EXPECT_LT(differ, 1e-3) << "premultiplied white: the colour is the alpha";
}

// The ray tables are written to --cache-dir by the first run and read by the next: the same output.
TEST(DofFilter, SecondRunReadsTheCachedRayTable) {
    const auto dir = lensfx::test::scratch_dir("dof_cache");
    const std::string in = point_exr(dir, true), cache = (dir / "cache").string();
    const std::string common = " --dof --dof-only --lens mld-double-gauss --fstop 4 --focus 1 --sensor 6 --dof-rays 16 --cache-dir " + cache;
    for (const char* out : {"cold.exr", "warm.exr"}) {
        const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + (dir / out).string() + common);
        ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    }
    std::size_t tables = 0;
    for (const auto& e : std::filesystem::directory_iterator(cache)) tables += e.path().filename().string().starts_with("dof-rays-") ? 1 : 0;
    EXPECT_EQ(tables, 2u) << "the blur's table and the bokeh table of its highlight (the bright square)";
    int w = 0, h = 0;
    EXPECT_EQ(read_channel((dir / "cold.exr").string(), "G", w, h), read_channel((dir / "warm.exr").string(), "G", w, h));
}

// The kinds of cache file (bounds, direct, starburst, dof-rays) found in a folder; empty when it is missing.
std::set<std::string> cache_kinds(const std::filesystem::path& dir) {
    std::set<std::string> kinds;
    if (!std::filesystem::exists(dir)) return kinds;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
        const std::string name = e.path().filename().string();
        kinds.insert(name.substr(0, name.rfind('-')));
    }
    return kinds;
}

// --cache-dir steers every disk cache (bounds tables, direct-power tables, starburst textures, the ray
// table) over $LENSFX_CACHE_DIR; `none` keeps them all in memory; without it the environment's folder holds them.
// The Cooke triplet (7 surfaces, 15 ghosts): each run computes every table, a third of the double Gauss's time.
TEST(DofFilter, CacheDirSteersEveryCache) {
    const auto dir = lensfx::test::scratch_dir("dof_cache_dir");
    const std::string in = point_exr(dir, true), out = (dir / "out.exr").string();
    const std::string args = " -i " + in + " -o " + out + " --dof --lens cooke-triplet --fstop 5.6 --focus 1 --sensor 6 --dof-rays 16";
    const std::set<std::string> every{"bounds", "direct", "starburst", "dof-rays"};
    auto run_with = [&](const std::string& env, const std::string& option) {
        const auto r = lensfx::test::run("LENSFX_CACHE_DIR=" + (dir / env).string() + " " + lensfx::test::lensfx_cmd() + args + option);
        ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    };
    run_with("env1", " --cache-dir " + (dir / "given").string());
    EXPECT_EQ(cache_kinds(dir / "given"), every);
    EXPECT_TRUE(cache_kinds(dir / "env1").empty());
    run_with("env2", " --cache-dir none");
    EXPECT_TRUE(cache_kinds(dir / "env2").empty());
    run_with("env3", "");
    EXPECT_EQ(cache_kinds(dir / "env3"), every);
}

// --bands mixes each band's blur into the working space's R, G, B (as the flare's bands): the same pixels
// tagged ACEScg (AP1 primaries, the working space) and untagged (Rec. 709) blur differently through the
// Cooke triplet's dispersion, while each channel keeps its energy (each channel's weights sum to 1).
TEST(DofFilter, SpectralBandsMixIntoTheWorkingSpacesPrimaries) {
    const auto dir = lensfx::test::scratch_dir("dof_bands_space");
    std::vector<float> rgb(kSize * kSize, 0.0f), z(kSize * kSize, 2.0f);
    rgb[static_cast<std::size_t>(kSize / 2 * kSize + kSize / 2)] = 1000.0f;
    const Imf::Chromaticities ap1({0.713f, 0.293f}, {0.165f, 0.830f}, {0.128f, 0.044f}, {0.32168f, 0.33767f});
    const std::string rec709 = (dir / "rec709.exr").string(), acescg = (dir / "acescg.exr").string();
    write_exr(rec709, kSize, kSize, {"R", "G", "B", "Z"}, {rgb, rgb, rgb, z});
    write_exr(acescg, kSize, kSize, {"R", "G", "B", "Z"}, {rgb, rgb, rgb, z}, &ap1);
    const std::string common = " --dof --dof-only --lens cooke-triplet --fstop 5.6 --focus 1 --sensor 6 --dof-rays 64 --cache-dir none";
    // largest difference between the two outputs, over the peak; each channel's energy ratio within 3 % (the
    // bands' energies differ a little: each wavelength's own focus breathing and vignetting)
    const auto compare = [&](const std::string& options) {
        for (const std::string& in : {rec709, acescg}) {
            const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + in + ".out.exr" + common + options);
            EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
        }
        double most = 0.0, peak = 0.0;
        for (const char* c : {"R", "G", "B"}) {
            int w = 0, h = 0;
            const std::vector<float> a = read_channel(rec709 + ".out.exr", c, w, h), b = read_channel(acescg + ".out.exr", c, w, h);
            for (std::size_t i = 0; i < a.size(); ++i) most = std::max(most, double{std::abs(a[i] - b[i])}), peak = std::max(peak, double{a[i]});
            EXPECT_NEAR(std::accumulate(b.begin(), b.end(), 0.0) / std::accumulate(a.begin(), a.end(), 0.0), 1.0, 0.03) << c << options;
        }
        return most / peak;
    };
    // one blur for all channels: the working space (each file's own) changes nothing
    EXPECT_LT(compare(" --no-chromatic-blur"), 1e-5);
    EXPECT_GT(compare(" --bands 7"), 1e-3) << "the working space's primaries weigh the bands";
}

// The blur's lens is the flare's (realize_lens): --blades shapes its iris, under the same rule.
TEST(DofFilter, BladesShapeTheBlurAsTheyDoTheFlare) {
    const auto dir = lensfx::test::scratch_dir("dof_blades");
    const std::string in = point_exr(dir, true);
    const std::string dof = " --dof --dof-only --lens cooke-triplet --fstop 5.6 --focus 1 --sensor 6 --dof-rays 16 --cache-dir none";
    const auto blur = [&](const std::string& blades, const std::string& name) {
        const std::string out = (dir / name).string();
        const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out + dof + blades);
        EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
        int w = 0, h = 0;
        return read_channel(out, "G", w, h);
    };
    const std::vector<float> round = blur(" --blades 0", "round.exr"), five = blur(" --blades 5", "five.exr");
    ASSERT_EQ(round.size(), five.size());
    double total = 0.0, moved = 0.0;
    for (std::size_t i = 0; i < round.size(); ++i) total += double{round[i]}, moved += std::abs(double{round[i]} - double{five[i]});
    EXPECT_GT(moved / total, 0.05) << moved / total << ": a pentagonal iris spreads the point differently from a round one";
    const auto refused = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + (dir / "two.exr").string() + dof + " --blades 2");
    EXPECT_NE(refused.exit_code, 0);
    EXPECT_NE(refused.stderr_text.find("--blades 2: 0 (round) or 3 to 64"), std::string::npos) << refused.stderr_text;
}

TEST(DofFilter, MissingDepthIsAOneLineError) {
    const auto dir = lensfx::test::scratch_dir("dof_nodepth");
    const std::string in = point_exr(dir, false);
    const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + (dir / "out.exr").string() +
                                     " --dof --dof-only --lens mld-double-gauss --focus 1");
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("no depth channel \"Z\""), std::string::npos) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find("flat.exr"), std::string::npos) << r.stderr_text;
    EXPECT_EQ(std::count(r.stderr_text.begin(), r.stderr_text.end(), '\n'), 1) << r.stderr_text;
}

// --deep inputs that are not regular files are refused in one line, before anything opens them (a named pipe
// with no writer would block the open for ever); a damaged header is refused before OpenEXR reads it.
TEST(DofFilter, DeepInputThatIsNoRegularFileOrHasADamagedHeaderIsAOneLineError) {
    const auto dir = lensfx::test::scratch_dir("dof_deep_special");
    const std::string in = point_exr(dir, true), out = (dir / "out.exr").string();
    const std::string fifo = (dir / "pipe.exr").string();
    std::filesystem::remove(fifo);
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    const std::string chunks = std::string(LENSFX_SOURCE_DIR) + "/fuzz/corpus/exr_reader/finding-chunk-count.exr";
    const std::pair<std::string, std::string> cases[] = {
        {fifo, "a named pipe, not a regular file"}, {dir.string(), "a directory, not a regular file"}, {chunks, "header attribute \"chunkCount\" declares"}};
    for (const auto& [deep, expected] : cases) {
        const auto r = lensfx::test::run("timeout 60 " + lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out +
                                         " --dof --dof-only --lens mld-double-gauss --focus 1 --deep " + deep);
        EXPECT_EQ(r.exit_code, 1) << deep << ": " << r.stderr_text;
        EXPECT_NE(r.stderr_text.find("--deep " + deep + ": " + expected), std::string::npos) << r.stderr_text;
        EXPECT_EQ(std::count(r.stderr_text.begin(), r.stderr_text.end(), '\n'), 1) << r.stderr_text;
    }
    std::filesystem::remove(fifo);
}

// Deep samples that do not fit the frame are refused in one line, not drawn as black: a flat file given as --deep,
// and a deep file over another display window. So is a display window whose blur would not fit --memory-limit,
// before anything of its size is made.
TEST(DofFilter, DeepFilesThatDoNotFitAndHugeWindowsAreRefused) {
    const auto dir = lensfx::test::scratch_dir("dof_deep_misfit");
    const std::string in = point_exr(dir, true), out = (dir / "out.exr").string(), deep = (dir / "small_deep.exr").string();
    write_small_deep(deep);
    const std::string dof = " --dof --dof-only --lens mld-double-gauss --focus 1 ";
    auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out + dof + "--deep " + deep);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.stderr_text.find("--deep " + deep + ": its display window is 3x2 at (0, 0), the frame's 48x48 at (0, 0)"), std::string::npos)
        << r.stderr_text;
    r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out + dof + "--deep " + in);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.stderr_text.find("--deep " + in + ": not a deep EXR"), std::string::npos) << r.stderr_text;
    EXPECT_FALSE(std::filesystem::exists(out));
    // 48 x 48 pixels of data in a 20000 x 20000 display window: about 100 GB of lens blur.
    const std::string wide = (dir / "wide.exr").string();
    write_exr(wide, kSize, kSize, {"R", "G", "B", "Z"},
              {std::vector<float>(kSize * kSize, 1.0f), std::vector<float>(kSize * kSize, 1.0f), std::vector<float>(kSize * kSize, 1.0f),
               std::vector<float>(kSize * kSize, 2.0f)});
    r = lensfx::test::run("oiiotool " + wide + " --fullsize 20000x20000 -o " + wide);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + wide + " -o " + out + dof + "--memory-limit 1G");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.stderr_text.find("the lens blur over the 20000x20000 display window needs"), std::string::npos) << r.stderr_text;
    EXPECT_EQ(std::count(r.stderr_text.begin(), r.stderr_text.end(), '\n'), 1) << r.stderr_text;
    EXPECT_FALSE(std::filesystem::exists(out));
}

// Focus points alone make the focal surface (their mean inverse distance stands for --focus).
TEST(DofFilter, FocusPointsNeedNoFocus) {
    const auto dir = lensfx::test::scratch_dir("dof_points_only");
    const std::string in = point_exr(dir, true), out = (dir / "out.exr").string();
    const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out +
                                     " --dof --dof-only --lens mld-double-gauss --focus-point 5,5,2 --focus-point 40,40,2");
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    int w = 0, h = 0;
    const std::vector<float> g = read_channel(out, "G", w, h);
    EXPECT_NEAR(g[static_cast<std::size_t>(kSize / 2 * kSize + kSize / 2)], 1000.0f / 16.0f, 1.0f) << "the plane at 2 m is sharp";
}

TEST(DofFilter, NeedsALensAndAFocus) {
    const auto dir = lensfx::test::scratch_dir("dof_args");
    const std::string in = point_exr(dir, true), out = (dir / "out.exr").string();
    const auto no_lens = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out + " --dof --focus 1");
    EXPECT_EQ(no_lens.exit_code, 2) << "a usage error";
    EXPECT_NE(no_lens.stderr_text.find("--dof needs --lens"), std::string::npos) << no_lens.stderr_text;
    const auto no_focus = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out + " --dof --lens mld-double-gauss");
    EXPECT_EQ(no_focus.exit_code, 2);
    EXPECT_NE(no_focus.stderr_text.find("--focus"), std::string::npos) << no_focus.stderr_text;
    const std::string dof = " --dof --dof-only --lens mld-double-gauss --focus 1";
    // a malformed --focus-point or --tilt is a usage error: exit 2, before any frame is read
    for (const char* bad : {" --focus-point 10,20", " --focus-point 10,20,0", " --focus-point 1,2,nan", " --tilt 5"}) {
        const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + (dir / "missing.exr").string() + " -o " + out + dof + bad);
        EXPECT_EQ(r.exit_code, 2) << bad << ": " << r.stderr_text;
        EXPECT_EQ(r.stderr_text.rfind("lensfx: ", 0), 0u) << r.stderr_text;
        EXPECT_NE(r.stderr_text.find(std::string(bad).substr(1, std::string(bad).find(' ', 1) - 1) + ": must be "), std::string::npos) << r.stderr_text;
        EXPECT_EQ(std::count(r.stderr_text.begin(), r.stderr_text.end(), '\n'), 1) << r.stderr_text;
    }
    const auto bad_point = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out + dof + " --focus-point 10,20");
    EXPECT_EQ(bad_point.exit_code, 2);
    EXPECT_NE(bad_point.stderr_text.find("X,Y,METRES"), std::string::npos) << bad_point.stderr_text;
    const auto bad_bands = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out + dof + " --bands 5");
    EXPECT_EQ(bad_bands.exit_code, 2) << "a usage error, found before any frame is read";
    EXPECT_NE(bad_bands.stderr_text.find("--bands: give 0 (RGB, three wavelengths) or 7..81 spectral bands, not 5"), std::string::npos) << bad_bands.stderr_text;
    for (const auto* r : {&bad_point, &bad_bands}) EXPECT_EQ(std::count(r->stderr_text.begin(), r->stderr_text.end(), '\n'), 1) << r->stderr_text;
}

// Bokeh of a small bright light (issue 18, highlights): a 3 x 3 light of 200 at 10 m over a dim plate, far out
// of focus (1 m; a bokeh about 40 px across), fills an even disc instead of the gather's lattice of dots (one
// ray hit per ~10 output pixels), and keeps its energy; focused at 10 m it stays where it was.
TEST(DofFilter, SmallHotLightBecomesAnEvenlyFilledDisc) {
    constexpr int n = 96, c = n / 2;
    const auto dir = lensfx::test::scratch_dir("dof_bokeh");
    std::vector<float> rgb(n * n, 0.02f), z(n * n, 10.0f);
    for (int y = c - 1; y <= c + 1; ++y)
        for (int x = c - 1; x <= c + 1; ++x) rgb[static_cast<std::size_t>(y * n + x)] = 200.0f;
    const std::string in = (dir / "light.exr").string();
    write_exr(in, n, n, {"R", "G", "B", "Z"}, {rgb, rgb, rgb, z});
    const double energy = std::accumulate(rgb.begin(), rgb.end(), 0.0);
    const auto blur = [&](const char* focus) {
        const std::string out = (dir / (std::string("out") + focus + ".exr")).string();
        const auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + out +
                                         " --dof --dof-only --lens mld-double-gauss --sensor 12 --cache-dir none --focus " + focus);
        EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
        int w = 0, h = 0;
        return read_channel(out, "G", w, h);
    };
    const std::vector<float> far = blur("1");
    ASSERT_EQ(far.size(), rgb.size());
    // the disc's inside (radius 10 px of about 20): the light's share of each pixel, its mean and spread
    double sum = 0.0, sum2 = 0.0, count = 0.0;
    for (int y = c - 10; y <= c + 10; ++y)
        for (int x = c - 10; x <= c + 10; ++x) {
            if (std::hypot(x - c, y - c) > 10.0) continue;
            const double v = double{far[static_cast<std::size_t>(y * n + x)]} - 0.02;
            sum += v, sum2 += v * v, count += 1.0;
        }
    const double mean = sum / count, spread = std::sqrt(std::max(0.0, sum2 / count - mean * mean));
    EXPECT_GT(mean, 0.5) << "the light spreads over the disc";
    EXPECT_LT(spread / mean, 0.05) << "an even disc, not dots: std / mean " << spread / mean;
    std::printf("disc inside: mean %.4f, std / mean %.4f\n", mean, spread / mean);
    // the light's energy (the plate keeps its 0.02): focused at 1 m the lens images 10 m 1 / 0.912 times
    // larger than the plate's scale (focus breathing, as DofFilter.BlursAPointBehindTheFocus...), 1.202 x
    const double plate = 0.02 * (n * n - 9), light = energy - plate;
    EXPECT_NEAR((std::accumulate(far.begin(), far.end(), 0.0) - plate) / (light * 1.202), 1.0, 0.01) << "energy";
    const std::vector<float> sharp = blur("10");
    double kept = 0.0;
    for (int y = c - 2; y <= c + 2; ++y)
        for (int x = c - 2; x <= c + 2; ++x) kept += double{sharp[static_cast<std::size_t>(y * n + x)]};
    EXPECT_GT(kept / (9 * 200.0), 0.95) << "in focus the light stays within 5 x 5 px";
}

}  // namespace
}  // namespace lensfx::dof::test
