// The compositor's controls end to end (llvmpipe): --ghost-gain, --starburst-gain (one meaning in `lensfx`
// and `lensfx flare`), --extended-gain, --matte / --matte-channel, --add-light, per-track gain and exclude,
// gains composed in double, and what the run says about the lights it found (stderr, --report).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <gtest/gtest.h>

#include "run_lensfx.h"
#include <nlohmann/json.hpp>

#include <filter/flare_stage.h>
#include <flare/direct_power.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace fs = std::filesystem;
using namespace lensfx;

namespace {

fs::path temp_dir(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / ("lensfx_flare_controls_" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

struct Disc {
    double x, y, radius, value;
};

// A 320x200 half-float frame, `base` everywhere, with flat-topped discs; `alpha`: an A channel of that value.
void write_frame(const fs::path& path, const std::vector<Disc>& discs, float base = 0.05f, std::optional<float> alpha = {}) {
    const int channels = alpha ? 4 : 3;
    OIIO::ImageSpec spec(320, 200, channels, OIIO::TypeDesc::HALF);
    OIIO::ImageBuf buf(spec);
    for (int j = 0; j < 200; ++j)
        for (int i = 0; i < 320; ++i) {
            double v = base;
            for (const Disc& d : discs) v += d.value * std::exp(-std::pow(std::hypot(i + 0.5 - d.x, j + 0.5 - d.y) / d.radius, 8.0));
            const float px[4] = {static_cast<float>(v), static_cast<float>(v), static_cast<float>(v), alpha.value_or(0.0f)};
            buf.setpixel(i, j, px);
        }
    ASSERT_TRUE(buf.write(path.string()));
}

// A one-channel 320x200 matte of `value`.
void write_matte(const fs::path& path, float value) {
    OIIO::ImageSpec spec(320, 200, 1, OIIO::TypeDesc::HALF);
    spec.channelnames = {"Y"};
    OIIO::ImageBuf buf(spec);
    const float v[1] = {value};
    OIIO::ImageBufAlgo::fill(buf, v);
    ASSERT_TRUE(buf.write(path.string()));
}

struct Image {
    int width = 0, height = 0, channels = 0;
    std::vector<float> px;  // data window, every channel
    double sum(int c) const {
        double s = 0.0;
        for (std::size_t i = static_cast<std::size_t>(c); i < px.size(); i += static_cast<std::size_t>(channels)) s += static_cast<double>(px[i]);
        return s;
    }
};

Image read(const fs::path& path) {
    OIIO::ImageBuf buf(path.string());
    EXPECT_TRUE(buf.read(0, 0, true, OIIO::TypeDesc::FLOAT)) << path;
    Image im{buf.spec().width, buf.spec().height, buf.spec().nchannels, {}};
    im.px.resize(static_cast<std::size_t>(im.width * im.height * im.channels));
    buf.get_pixels(buf.roi(), OIIO::TypeDesc::FLOAT, im.px.data());
    return im;
}

struct Result {
    int status = 0;
    std::string output;  // stdout and stderr
};

// Runs lensfx with its caches in a scratch directory, never the user's.
Result run(const std::string& args) {
    const std::string cache = (fs::temp_directory_path() / "lensfx_flare_controls_cache").string();
    const lensfx::test::ProgramRun p = lensfx::test::run_lensfx(args, cache);
    return {p.status, p.output};
}

// Runs the filter on IN -> OUT in `dir` with the options; expects success.
Image run_filter(const fs::path& dir, const std::string& in, const std::string& out, const std::string& options) {
    const Result r = run("-i " + (dir / in).string() + " -o " + (dir / out).string() + options);
    EXPECT_EQ(r.status, 0) << r.output;
    return read(dir / out);
}

const std::string kLens = " --lens brendel-tessar --fstop 4 --grid 32 --threshold 100 -q";
const Disc kLamp{230.3, 60.6, 2.0, 20000.0};

// A 320x200 track file with the given tracks (JSON objects).
void write_tracks(const fs::path& path, const std::string& tracks) {
    std::ofstream(path) << R"({"width": 320, "height": 200, "tracks": [)" << tracks << "]}";
}

}  // namespace

TEST(FlareControls, GhostGainZeroEqualsTheStarburstAlone) {
    const fs::path dir = temp_dir("ghost_gain");
    write_frame(dir / "in.exr", {kLamp});
    const Image off = run_filter(dir, "in.exr", "off.exr", kLens + " --ghost-gain 0 --starburst-scale 20");
    const Image sb = run_filter(dir, "in.exr", "sb.exr", kLens + " --parts starburst --starburst-scale 20");
    EXPECT_EQ(off.px, sb.px) << "--ghost-gain 0 must be --parts starburst, bit for bit";
    const Image both = run_filter(dir, "in.exr", "both.exr", kLens + " --starburst-scale 20");
    EXPECT_NE(both.px, sb.px) << "the ghosts show at --ghost-gain 1";

    const Image one = run_filter(dir, "in.exr", "g1.exr", kLens + " --parts ghosts --flare-only");
    const Image three = run_filter(dir, "in.exr", "g3.exr", kLens + " --parts ghosts --flare-only --ghost-gain 3 --starburst-gain 0");
    ASSERT_GT(one.sum(1), 0.0);
    EXPECT_NEAR(three.sum(1) / one.sum(1), 3.0, 3e-6);
}

TEST(FlareControls, StarburstGainMeansTheSameInTheFilterAndInLensfxFlare) {
    // In both commands 1 is the light's own energy through the lens: the flare command's light of
    // irradiance 1 delivers direct_power to the sensor, and its starburst carries that times the gain.
    const fs::path dir = temp_dir("starburst_gain");
    const std::string flare = "flare --lens brendel-tessar --fstop 8 --angle 0,0 --size 960x640 --parts starburst -o ";
    ASSERT_EQ(run(flare + (dir / "f1.exr").string()).status, 0);
    ASSERT_EQ(run(flare + (dir / "f4.exr").string() + " --starburst-gain 0.25").status, 0);
    const Image f1 = read(dir / "f1.exr"), f4 = read(dir / "f4.exr");
    const double pixel_area = (36.0 / 960.0) * (24.0 / 640.0);
    const optics::System system = optics::realize(optics::load_lens("brendel-tessar"), 0.0, 8.0);
    const auto direct = flare::direct_power(system, 0.0, 0.0);
    EXPECT_NEAR(f1.sum(1) * pixel_area / direct[1], 1.0, 0.02) << "starburst-gain 1: the light's energy through the lens";
    EXPECT_NEAR(f4.sum(1) / f1.sum(1), 0.25, 1e-5);

    write_frame(dir / "in.exr", {kLamp});
    const std::string opts = kLens + " --parts starburst --flare-only --starburst-scale 20";
    const Image s1 = run_filter(dir, "in.exr", "s1.exr", opts);
    const Image s4 = run_filter(dir, "in.exr", "s4.exr", opts + " --starburst-gain 0.25");
    ASSERT_GT(s1.sum(1), 0.0);
    EXPECT_NEAR(s4.sum(1) / s1.sum(1), 0.25, 1e-5);
}

TEST(FlareControls, ExtendedGainScalesOnlyExtendedSources) {
    const fs::path dir = temp_dir("extended_gain");
    const Disc window{90.3, 120.6, 20.0, 200.0};  // wider than 16 px: an extended source with a shape
    write_frame(dir / "both.exr", {kLamp, window});
    write_frame(dir / "lamp.exr", {kLamp});
    const std::string opts = kLens + " --flare-only --min-light 0 --starburst-scale 20";
    const Image a = run_filter(dir, "both.exr", "a.exr", opts);
    const Image off = run_filter(dir, "both.exr", "off.exr", opts + " --extended-gain 0");
    const Image fifth = run_filter(dir, "both.exr", "fifth.exr", opts + " --extended-gain 0.2");
    const Image lamp = run_filter(dir, "lamp.exr", "lamp_out.exr", opts);
    EXPECT_EQ(off.px, lamp.px) << "--extended-gain 0 leaves the window's flare out, the lamp's as it was";
    const double window_flare = a.sum(1) - lamp.sum(1);
    ASSERT_GT(window_flare, 0.0);
    // Within 1%: the outputs are half floats, and a fifth of the window's faint veil loses more to half's
    // smallest steps than the whole.
    EXPECT_NEAR((fifth.sum(1) - lamp.sum(1)) / window_flare, 0.2, 2e-3);
}

TEST(FlareControls, MatteOverTheWholeFrameIsAPassThrough) {
    const fs::path dir = temp_dir("matte");
    write_frame(dir / "in.exr", {kLamp, {80.2, 150.4, 2.0, 20000.0}});
    write_matte(dir / "white.exr", 1.0f);
    const Image in = read(dir / "in.exr");
    const Image matted = run_filter(dir, "in.exr", "matted.exr", kLens + " --matte " + (dir / "white.exr").string());
    EXPECT_EQ(matted.px, in.px) << "a white matte over the whole frame: no light, the plate bit for bit";

    write_frame(dir / "alpha.exr", {kLamp}, 0.05f, 1.0f);
    const Image alpha_in = read(dir / "alpha.exr");
    EXPECT_EQ(run_filter(dir, "alpha.exr", "alpha_out.exr", kLens + " --matte-channel A").px, alpha_in.px);
    EXPECT_NE(run_filter(dir, "alpha.exr", "lit.exr", kLens).px, alpha_in.px) << "without the matte the lamp flares";

    // A matte over one of two lights: the report counts one light, the summary line says so.
    OIIO::ImageBuf half(OIIO::ImageSpec(320, 200, 1, OIIO::TypeDesc::HALF));
    const float white[1] = {1.0f};
    OIIO::ImageBufAlgo::fill(half, white, OIIO::ROI(0, 160, 0, 200));
    ASSERT_TRUE(half.write((dir / "left.exr").string()));
    const std::string common = " --lens brendel-tessar --fstop 4 --grid 32 --threshold 100 --report ";
    const Result r = run("-i " + (dir / "in.exr").string() + " -o " + (dir / "one.exr").string() + common +
                         (dir / "one.json").string() + " --matte " + (dir / "left.exr").string());
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("lensfx: 1 frame, lights per frame min 1, median 1, max 1"), std::string::npos) << r.output;
    const auto report = nlohmann::json::parse(std::ifstream(dir / "one.json"));
    EXPECT_EQ(report.at("frames").at(0).at("figures").at("flare.lights").get<double>(), 1.0);
    EXPECT_EQ(report.at("frames").at(0).at("figures").at("flare.sources").get<double>(), 1.0);
}

TEST(FlareControls, MatteSequenceIsReadFrameByFrame) {
    const fs::path dir = temp_dir("matte_sequence");
    for (const char* n : {"0001", "0002"}) write_frame(dir / (std::string("in.") + n + ".exr"), {kLamp});
    write_matte(dir / "roto.0001.exr", 1.0f);
    write_matte(dir / "roto.0002.exr", 0.0f);
    const Result r = run("-i " + (dir / "in.####.exr").string() + " -o " + (dir / "out.####.exr").string() + kLens +
                         " --matte " + (dir / "roto.####.exr").string() + " --report " + (dir / "r.json").string());
    ASSERT_EQ(r.status, 0) << r.output;
    const auto report = nlohmann::json::parse(std::ifstream(dir / "r.json"));
    EXPECT_EQ(report.at("frames").at(0).at("figures").at("flare.lights").get<double>(), 0.0) << "frame 1: matted";
    EXPECT_EQ(report.at("frames").at(1).at("figures").at("flare.lights").get<double>(), 1.0) << "frame 2: not";
    const Result missing = run("-i " + (dir / "in.####.exr").string() + " -o " + (dir / "out.####.exr").string() + kLens +
                               " --matte " + (dir / "nothing.####.exr").string());
    EXPECT_NE(missing.status, 0);
    EXPECT_NE(missing.output.find("--matte " + (dir / "nothing.0001.exr").string()), std::string::npos) << missing.output;
}

TEST(FlareControls, AddedLightFlaresABlackFrameAndLeavesThePlate) {
    const fs::path dir = temp_dir("add_light");
    write_frame(dir / "black.exr", {}, 0.0f);
    const Image nothing = run_filter(dir, "black.exr", "nothing.exr", kLens);
    for (float v : nothing.px) ASSERT_EQ(v, 0.0f);
    // With --layer the flare goes beside R, G, B: they stay the black plate, the disc is not painted in.
    const Image lit = run_filter(dir, "black.exr", "lit.exr", kLens + " --add-light 230.3,60.6,20000,2 --layer flare");
    ASSERT_EQ(lit.channels, 6);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(lit.sum(c), 0.0) << "channel " << c;
    EXPECT_GT(lit.sum(4), 0.0) << "the added light flares";
    // The flare of the added light is that of the same disc on the plate, less the disc itself.
    write_frame(dir / "lamp.exr", {{230.3, 60.6, 2.0, 20000.0}}, 0.0f);
    const Image plate = run_filter(dir, "lamp.exr", "plate.exr", kLens + " --flare-only --parts ghosts");
    const Image added = run_filter(dir, "black.exr", "added.exr", kLens + " --flare-only --parts ghosts --add-light 230.3,60.6,20000,1.9");
    EXPECT_NEAR(added.sum(1) / plate.sum(1), 1.0, 0.1);
}

namespace {

// Green at (x, y) of a one-frame result, bilinear between pixel centres (0 outside).
double green_at(const Image& im, double x, double y) {
    const double px = x - 0.5, py = y - 0.5;
    const int x0 = static_cast<int>(std::floor(px)), y0 = static_cast<int>(std::floor(py));
    double v = 0.0;
    for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
            const int xx = x0 + dx, yy = y0 + dy;
            if (xx < 0 || yy < 0 || xx >= im.width || yy >= im.height) continue;
            const double w = (dx ? px - x0 : 1.0 - (px - x0)) * (dy ? py - y0 : 1.0 - (py - y0));
            v += w * static_cast<double>(im.px[(static_cast<std::size_t>(yy) * static_cast<std::size_t>(im.width) + static_cast<std::size_t>(xx)) *
                                                   static_cast<std::size_t>(im.channels) + 1]);
        }
    return v;
}

// The cross-section of the brightest spike `r` px from (cx, cy): offsets -12..12 px across it, every 0.5 px.
std::vector<double> across_brightest_spike(const Image& im, double cx, double cy, double r) {
    double best = 0.0, angle = 0.0;
    for (int k = 0; k < 1440; ++k) {
        const double a = k * std::numbers::pi / 720.0, v = green_at(im, cx + r * std::cos(a), cy - r * std::sin(a));
        if (v > best) best = v, angle = a;
    }
    std::vector<double> across;
    for (int j = -24; j <= 24; ++j) {
        const double t = 0.5 * j;
        across.push_back(green_at(im, cx + r * std::cos(angle) - t * std::sin(angle), cy - r * std::sin(angle) - t * std::cos(angle)));
    }
    return across;
}

}  // namespace

// Issue 16 (the gallery's Tree): a sun added with --add-light, 8 px across, had spikes one pixel wide with
// nothing beside them, white lines to the frame edge. Its spikes are as wide as it, soft edged, with
// wings; a light a pixel across keeps thin spikes, with wings too.
TEST(FlareControls, AddedSunHasSpikesAsWideAsItWithSoftEdges) {
    const fs::path dir = temp_dir("added_sun");
    write_frame(dir / "black.exr", {}, 0.0f);
    const std::string options = kLens + " --parts starburst --starburst-scale 4";
    const Image sun = run_filter(dir, "black.exr", "sun.exr", options + " --add-light 160.5,100.5,20000,4");
    const Image point = run_filter(dir, "black.exr", "point.exr", options + " --add-light 160.5,100.5,20000,0.6");
    const auto width_above = [](const std::vector<double>& v, double level) {
        return 0.5 * static_cast<double>(std::count_if(v.begin(), v.end(), [level](double x) { return x >= level; }));
    };
    const std::vector<double> sun_across = across_brightest_spike(sun, 160.5, 100.5, 50.0);
    const std::vector<double> point_across = across_brightest_spike(point, 160.5, 100.5, 20.0);
    const double sun_peak = *std::max_element(sun_across.begin(), sun_across.end());
    const double point_peak = *std::max_element(point_across.begin(), point_across.end());
    std::printf("width at half the peak: sun (50 px out) %.1f px, point (20 px out) %.1f px; at 1e-3: sun %.1f px; at 3e-4: point %.1f px\n",
                width_above(sun_across, 0.5 * sun_peak), width_above(point_across, 0.5 * point_peak),
                width_above(sun_across, 1e-3 * sun_peak), width_above(point_across, 3e-4 * point_peak));
    // A disc of radius 4 seen edge on holds half its peak over about 7 px.
    EXPECT_GE(width_above(sun_across, 0.5 * sun_peak), 5.0);
    EXPECT_LE(width_above(sun_across, 0.5 * sun_peak), 10.0);
    // Soft: no step from the spike to nothing at its edge, for either.
    EXPECT_GE(width_above(sun_across, 1e-3 * sun_peak), width_above(sun_across, 0.5 * sun_peak) + 3.0);
    EXPECT_LE(width_above(point_across, 0.5 * point_peak), 2.5);
    // At f/4 the edge's first zero is 0.04 px here: the wings hold 3e-4 of the centre some 2.6 px out.
    EXPECT_GE(width_above(point_across, 3e-4 * point_peak), 4.5);
}

namespace {

// Green summed over the pixels whose centres lie within r px of (cx, cy).
double green_within(const Image& im, double cx, double cy, double r) {
    double sum = 0.0;
    for (int y = 0; y < im.height; ++y)
        for (int x = 0; x < im.width; ++x)
            if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) <= r)
                sum += static_cast<double>(im.px[(static_cast<std::size_t>(y) * static_cast<std::size_t>(im.width) + static_cast<std::size_t>(x)) *
                                                     static_cast<std::size_t>(im.channels) + 1]);
    return sum;
}

}  // namespace

// Issue 16 (the gallery's Tree had no sun): a light added on a plate that lacks it gets its core drawn, the
// light's own image (most of its energy, over its disc); a light the plate holds does not (its pixels are
// its core), nor does an added light over it.
TEST(FlareControls, AddedLightGetsTheCoreThePlateLacks) {
    const fs::path dir = temp_dir("added_core");
    write_frame(dir / "black.exr", {}, 0.0f);
    write_frame(dir / "lamp.exr", {{160.5, 100.5, 4.0, 20000.0}}, 0.0f);
    const std::string options = kLens + " --flare-only --parts starburst";
    const double disc = 20000.0 * std::numbers::pi * 16.0;
    const Image added = run_filter(dir, "black.exr", "added.exr", options + " --add-light 160.5,100.5,20000,4");
    const Image held = run_filter(dir, "lamp.exr", "held.exr", options);
    const Image over = run_filter(dir, "lamp.exr", "over.exr", options + " --add-light 160.5,100.5,20000,3");
    const Image lamp = read(dir / "lamp.exr");
    const double lamp_flux = green_within(lamp, 160.5, 100.5, 8.0);
    std::printf("within 6 px: added %.3f of its disc, its peak %.0f; held lamp %.3f, added over it %.3f of the lamp\n",
                green_within(added, 160.5, 100.5, 6.0) / disc, green_at(added, 160.5, 100.5), green_within(held, 160.5, 100.5, 6.0) / lamp_flux,
                green_within(over, 160.5, 100.5, 6.0) / lamp_flux);
    // The core (some 90%) and the rest of the pattern near the light: about the whole disc (before, 0.1).
    EXPECT_NEAR(green_within(added, 160.5, 100.5, 6.0) / disc, 1.0, 0.1);
    EXPECT_GT(green_at(added, 160.5, 100.5), 0.6 * 20000.0);
    EXPECT_LT(green_within(held, 160.5, 100.5, 6.0), 0.2 * lamp_flux);
    EXPECT_LT(green_within(over, 160.5, 100.5, 6.0), 0.25 * lamp_flux);
}

TEST(FlareControls, TrackGainAndExcludeControlEachTrack) {
    const fs::path dir = temp_dir("tracks");
    write_frame(dir / "black.exr", {}, 0.0f);
    const std::string lamp = R"({"id": 1, %s"keys": [{"frame": 1, "position": [230.3, 60.6], "flux": [250000, 250000, 250000]}]})";
    const std::string other = R"({"id": 2, %s"keys": [{"frame": 1, "position": [80.2, 150.4], "flux": [90000, 90000, 90000]}]})";
    auto with = [](std::string t, const std::string& controls) { return t.replace(t.find("%s"), 2, controls); };
    write_tracks(dir / "one.json", with(lamp, ""));
    write_tracks(dir / "excluded.json", with(lamp, "") + "," + with(other, R"("exclude": true, )"));
    write_tracks(dir / "half.json", with(lamp, R"("gain": 0.5, )"));
    write_tracks(dir / "huge.json", with(lamp, R"("gain": 1e40, )"));
    const std::string opts = kLens + " --flare-only --parts ghosts --min-light 0 --tracks ";
    const Image one = run_filter(dir, "black.exr", "one.exr", opts + (dir / "one.json").string());
    EXPECT_EQ(run_filter(dir, "black.exr", "ex.exr", opts + (dir / "excluded.json").string()).px, one.px);
    EXPECT_NEAR(run_filter(dir, "black.exr", "half.exr", opts + (dir / "half.json").string()).sum(1) / one.sum(1), 0.5, 1e-5);
    // Gains compose in double: 1e40 (beyond a float) times 1e-40 (below one) is the light as it was.
    const Image huge = run_filter(dir, "black.exr", "huge.exr", opts + (dir / "huge.json").string() + " --ghost-gain 1e-40");
    ASSERT_GT(one.sum(1), 0.0);
    EXPECT_NEAR(huge.sum(1) / one.sum(1), 1.0, 1e-5);
    write_tracks(dir / "bad.json", with(lamp, R"("gain": -2, )"));
    const Result bad = run("-i " + (dir / "black.exr").string() + " -o " + (dir / "bad.exr").string() + opts + (dir / "bad.json").string());
    EXPECT_NE(bad.status, 0);
    EXPECT_NE(bad.output.find("bad.json: track id 1: \"gain\""), std::string::npos) << bad.output;
}

TEST(FlareControls, NonFiniteOrNegativeGainsAreRefused) {
    const fs::path dir = temp_dir("refused");
    write_frame(dir / "in.exr", {kLamp});
    for (const std::string bad : {"--ghost-gain inf", "--ghost-gain -1", "--extended-gain nan", "--starburst-gain 1e999"}) {
        const Result r = run("-i " + (dir / "in.exr").string() + " -o " + (dir / "out.exr").string() + kLens + " " + bad);
        EXPECT_NE(r.status, 0) << bad;
        EXPECT_NE(r.output.find(bad.substr(0, bad.find(' '))), std::string::npos) << bad << ": " << r.output;
        EXPECT_FALSE(fs::exists(dir / "out.exr")) << bad;
    }
    const Result flare = run("flare --lens brendel-tessar --angle 3,2 --ghost-gain inf -o " + (dir / "f.exr").string());
    EXPECT_NE(flare.status, 0);
}

TEST(FlareControls, ARunWithoutALightSaysSoOnce) {
    const fs::path dir = temp_dir("no_light");
    write_frame(dir / "dim.exr", {{100.5, 100.5, 3.0, 12.0}});  // brightest about 12, threshold 20
    const std::string io = "-i " + (dir / "dim.exr").string() + " -o " + (dir / "out.exr").string();
    const Result r = run(io + " --lens brendel-tessar --report " + (dir / "r.json").string());
    EXPECT_EQ(r.status, 0);
    EXPECT_NE(r.output.find("lensfx: no light in any of 1 frame: the brightest luminance is 12.05, below the threshold 20"),
              std::string::npos)
        << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    const auto report = nlohmann::json::parse(std::ifstream(dir / "r.json"));
    const auto& figures = report.at("frames").at(0).at("figures");
    EXPECT_EQ(figures.at("flare.lights").get<double>(), 0.0);
    EXPECT_NEAR(figures.at("flare.brightest").get<double>(), 12.05, 0.01);
    EXPECT_EQ(figures.at("flare.threshold").get<double>(), 20.0);
    EXPECT_EQ(run(io + " --lens brendel-tessar -q").output, "") << "--quiet: nothing";
    // No lens, no flare stage: said once (a forgotten --lens wrote the frame unchanged without a word before).
    EXPECT_EQ(run(io).output, "lensfx: 1 frame written without a flare: no --lens was given (lensfx lens list names the presets)\n");
}
