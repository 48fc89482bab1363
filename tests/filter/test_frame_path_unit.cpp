// The frame side of the flare stage without the GPU: the --min-light fade, the starburst's disk cache,
// and the frame operations the composite needs (growing the data window, adding a flare layer).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <Imath/half.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filter/flare_stage.h>
#include <filter/footprint.h>
#include <filter/frame.h>
#include <optics/aperture.h>
#include <optics/lens_file.h>
#include <optics/starburst.h>
#include <optics/system.h>

namespace fs = std::filesystem;
using namespace lensfx;
using Imath::half;

namespace {

fs::path temp_dir(const std::string& name) {
    // Named by the process too: runs of other checkouts at the same time must not share it.
    const fs::path dir = fs::temp_directory_path() / ("lensfx_frame_path_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

// A frame with channels R, G, B (half) and Z (float), data window (x, y, w, h) inside a 20 x 10 display
// window; channel c of pixel i holds 10 i + c.
filter::Frame make_frame(int x, int y, int w, int h) {
    filter::Frame frame;
    frame.spec = filter::ImageSpec(w, h, 4, filter::PixelType::half);
    frame.spec.channelnames = {"R", "G", "B", "Z"};
    frame.spec.channeltypes = {filter::PixelType::half, filter::PixelType::half, filter::PixelType::half, filter::PixelType::float32};
    frame.spec.x = x;
    frame.spec.y = y;
    frame.spec.full_x = 0;
    frame.spec.full_y = 0;
    frame.spec.full_width = 20;
    frame.spec.full_height = 10;
    frame.pixels = filter::PixelBuffer(frame.spec.image_bytes());
    std::vector<float> values(static_cast<std::size_t>(w * h * 4));
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<float>(10 * (i / 4) + i % 4);
    const auto offsets = filter::channel_offsets(frame.spec);
    const std::size_t px = frame.spec.pixel_bytes();
    for (std::size_t i = 0; i < static_cast<std::size_t>(w * h); ++i) {
        for (std::size_t c = 0; c < 3; ++c) {
            const half v(values[i * 4 + c]);
            std::memcpy(frame.pixels.data() + i * px + offsets[c], &v, sizeof v);
        }
        std::memcpy(frame.pixels.data() + i * px + offsets[3], &values[i * 4 + 3], sizeof(float));
    }
    filter::find_rgb_channels(frame);
    return frame;
}

}  // namespace

TEST(FramePath, MinLightFadeIsSmoothAndSkipsOnlyDimLights) {
    EXPECT_EQ(filter::min_light_fade(0.0005, 1e-3), 0.0);
    EXPECT_EQ(filter::min_light_fade(1e-3, 1e-3), 0.0);
    EXPECT_EQ(filter::min_light_fade(2e-3, 1e-3), 1.0);
    EXPECT_EQ(filter::min_light_fade(1.0, 1e-3), 1.0);
    EXPECT_EQ(filter::min_light_fade(1e-9, 0.0), 1.0);  // 0: every light is kept
    EXPECT_NEAR(filter::min_light_fade(1.5e-3, 1e-3), 0.5, 1e-12);
    double previous = 0.0;
    for (int i = 0; i <= 1000; ++i) {  // monotone, and no step larger than the slope allows
        const double w = filter::min_light_fade(1e-3 + 1e-3 * i / 1000.0, 1e-3);
        EXPECT_GE(w, previous);
        EXPECT_LE(w - previous, 1.5 / 1000.0 + 1e-12);
        previous = w;
    }
}

TEST(FramePath, CacheDirectoryFollowsTheEnvironment) {
    const char* saved = std::getenv("LENSFX_CACHE_DIR");
    const std::string keep = saved ? saved : "";
    ::setenv("LENSFX_CACHE_DIR", "/some/where", 1);
    EXPECT_EQ(filter::cache_directory(), "/some/where");
    ::setenv("LENSFX_CACHE_DIR", "none", 1);
    EXPECT_EQ(filter::cache_directory(), "");
    ::unsetenv("LENSFX_CACHE_DIR");
    if (const char* home = std::getenv("HOME"); home && *home) {
        EXPECT_EQ(filter::cache_directory(), (fs::path(home) / ".cache" / "lensfx").string());
    }
    if (saved) ::setenv("LENSFX_CACHE_DIR", keep.c_str(), 1);
}

TEST(FramePath, StarburstCacheStoresReadsAndRepairs) {
    const fs::path dir = temp_dir("cache");
    optics::Aperture hexagon;
    hexagon.blades = 6;
    hexagon.rotation_deg = 10.0;
    const optics::Starburst computed = filter::cached_starburst(hexagon, {}, (dir / "sub").string());
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir / "sub")) files.push_back(e.path());
    ASSERT_EQ(files.size(), 1u) << "one file per iris, no temporary left";
    const optics::Starburst read = filter::cached_starburst(hexagon, {}, (dir / "sub").string());
    EXPECT_EQ(read.size, computed.size);
    EXPECT_EQ(read.texel_per_fnumber_mm, computed.texel_per_fnumber_mm);
    EXPECT_EQ(read.rgb, computed.rgb);

    // A damaged (truncated) file is recomputed and rewritten.
    fs::resize_file(files[0], fs::file_size(files[0]) / 2);
    const optics::Starburst repaired = filter::cached_starburst(hexagon, {}, (dir / "sub").string());
    EXPECT_EQ(repaired.rgb, computed.rgb);
    EXPECT_EQ(fs::file_size(files[0]), 19 + 4 + 8 + computed.rgb.size() * sizeof(float));

    // Other options (dirt on the pupil, other primaries) are other textures, in other files.
    optics::StarburstOptions dirty;
    dirty.dirt.scratches = 20;
    const optics::Starburst scratched = filter::cached_starburst(hexagon, dirty, (dir / "sub").string());
    EXPECT_NE(scratched.rgb, computed.rgb);
    optics::StarburstOptions acescg;
    acescg.xyz_to_rgb[0][0] = 1.6410234;
    EXPECT_NE(filter::cached_starburst(hexagon, acescg, (dir / "sub").string()).rgb, computed.rgb);
    EXPECT_EQ(std::distance(fs::directory_iterator(dir / "sub"), fs::directory_iterator{}), 3);
}

TEST(FramePath, GrowDataWindowKeepsPixelsAndZeroFillsTheRest) {
    filter::Frame frame = make_frame(3, 2, 4, 3);
    filter::load_rgb(frame);
    const std::vector<float> before_z = filter::channels_as_float(frame, {3});
    filter::grow_data_window(frame, 0, 0, 20, 10);
    EXPECT_EQ(frame.spec.x, 0);
    EXPECT_EQ(frame.spec.y, 0);
    EXPECT_EQ(frame.spec.width, 20);
    EXPECT_EQ(frame.spec.height, 10);
    ASSERT_EQ(frame.rgb.size(), 200u * 3u);
    ASSERT_EQ(frame.pixels.size(), frame.spec.image_bytes());
    const std::vector<float> z = filter::channels_as_float(frame, {3});
    const std::vector<float> r = filter::channels_as_float(frame, {0});
    for (int y = 0; y < 10; ++y)
        for (int x = 0; x < 20; ++x) {
            const bool inside = x >= 3 && x < 7 && y >= 2 && y < 5;
            const std::size_t i = static_cast<std::size_t>(y * 20 + x);
            const std::size_t old = inside ? static_cast<std::size_t>((y - 2) * 4 + (x - 3)) : 0;
            EXPECT_EQ(z[i], inside ? before_z[old] : 0.0f) << x << "," << y;
            EXPECT_EQ(r[i], inside ? static_cast<float>(10 * old) : 0.0f) << x << "," << y;
            EXPECT_EQ(frame.rgb[i * 3 + 1], inside ? static_cast<float>(10 * old + 1) : 0.0f) << x << "," << y;
        }
    // Already covered: nothing changes.
    const filter::PixelBuffer copy = frame.pixels;
    filter::grow_data_window(frame, 5, 5, 6, 6);
    EXPECT_EQ(frame.spec.width, 20);
    EXPECT_EQ(std::vector<std::byte>(copy.data(), copy.data() + copy.size()),
              std::vector<std::byte>(frame.pixels.data(), frame.pixels.data() + frame.pixels.size()));
}

TEST(FramePath, AddRgbLayerAppendsChannelsBesideTheOriginals) {
    filter::Frame frame = make_frame(0, 0, 4, 3);
    const std::vector<float> original = filter::channels_as_float(frame, {0, 1, 2, 3});
    std::vector<float> flare(12 * 3);
    for (std::size_t i = 0; i < flare.size(); ++i) flare[i] = 0.25f * static_cast<float>(i);
    filter::add_rgb_layer(frame, "flare", flare);
    ASSERT_EQ(frame.spec.nchannels(), 7);
    EXPECT_EQ(frame.spec.channelnames, (std::vector<std::string>{"R", "G", "B", "Z", "flare.R", "flare.G", "flare.B"}));
    EXPECT_EQ(frame.spec.channel_type(4), filter::PixelType::half);  // the R channel's type
    EXPECT_EQ(frame.pixels.size(), frame.spec.image_bytes());
    EXPECT_EQ(filter::channels_as_float(frame, {0, 1, 2, 3}), original);
    EXPECT_EQ(filter::channels_as_float(frame, {4, 5, 6}), flare);
    EXPECT_THROW(filter::add_rgb_layer(frame, "flare", flare), std::invalid_argument);
    EXPECT_THROW(filter::add_rgb_layer(frame, "more", std::vector<float>(5)), std::invalid_argument);
}

TEST(FramePath, DirectPowerTableTracesOnDemandAndKeepsItsSamplesOnDisk) {
    const fs::path dir = temp_dir("direct");
    const optics::System system = optics::realize(optics::load_lens("brendel-tessar"), 0.0, std::nullopt);
    filter::DirectPowerTable table(system, 20.0, 12, 8);
    EXPECT_EQ(table.traced(), 0);
    const auto near_axis = table.at(0.5, 0.2);
    EXPECT_EQ(table.traced(), 3) << "samples 0, 1 and 2 (the first is repeated below 0)";
    EXPECT_GT(near_axis[1], 0.0);
    table.save(dir / "t.bin", "key");

    filter::DirectPowerTable again(system, 20.0, 12, 8);
    EXPECT_FALSE(again.load(dir / "t.bin", "another key"));
    EXPECT_EQ(again.traced(), 0);
    EXPECT_TRUE(again.load(dir / "t.bin", "key"));
    EXPECT_EQ(again.traced(), 3);
    EXPECT_EQ(again.at(0.5, 0.2), near_axis);
    EXPECT_EQ(again.traced(), 3) << "nothing traced for a lookup the file covers";
    filter::DirectPowerTable other_size(system, 20.0, 10, 8);
    EXPECT_FALSE(other_size.load(dir / "t.bin", "key"));
    fs::resize_file(dir / "t.bin", fs::file_size(dir / "t.bin") - 1);
    filter::DirectPowerTable damaged(system, 20.0, 12, 8);
    EXPECT_FALSE(damaged.load(dir / "t.bin", "key"));
}

namespace {

// x centroid and sum of channel c of an RGB image.
std::pair<double, double> centroid_x(const std::vector<float>& rgb, int width, int c) {
    double sum = 0.0, moment = 0.0;
    for (std::size_t i = 0; i < rgb.size() / 3; ++i) {
        sum += static_cast<double>(rgb[i * 3 + static_cast<std::size_t>(c)]);
        moment += static_cast<double>(rgb[i * 3 + static_cast<std::size_t>(c)]) * static_cast<double>(i % static_cast<std::size_t>(width));
    }
    return {moment / sum, sum};
}

}  // namespace

TEST(Footprint, ConvolutionScalesAndTurnsTheFootprintWithTheGhost) {
    // A bar 12 px wide, 4 px tall, to the right of the light (cells of 2 px): its centre 6 px right.
    detect::Shape bar;
    bar.width = 6;
    bar.height = 2;
    bar.cell = 2.0;
    bar.origin_x = 0.0;
    bar.origin_y = -2.0;
    bar.weights.assign(12, 1.0f / 12.0f);
    const int w = 121, h = 41;
    for (const double m : {1.0, 2.0, -1.5, 0.5, -0.25}) {
        std::vector<float> rgb(static_cast<std::size_t>(w * h * 3), 0.0f);
        const std::size_t light = static_cast<std::size_t>(20 * w + 60);
        rgb[light * 3] = 1.0f;
        rgb[light * 3 + 1] = 2.0f;
        rgb[light * 3 + 2] = 3.0f;
        filter::convolve_footprint(rgb, w, h, bar, m);
        for (int c = 0; c < 3; ++c) {
            const auto [cx, sum] = centroid_x(rgb, w, c);
            EXPECT_NEAR(sum, c + 1.0, 1e-4 * (c + 1)) << "m " << m;
            EXPECT_NEAR(cx - 60.0, m * 6.0, 0.75) << "m " << m;
        }
        // The spread: the bar's width and half a cell's ramp either side (the weights are interpolated
        // between cell centres) scaled by |m|, at least the one pixel the light was.
        int lit = 0;
        for (int x = 0; x < w; ++x) lit += rgb[static_cast<std::size_t>(20 * w + x) * 3 + 1] > 1e-6f ? 1 : 0;
        EXPECT_NEAR(lit, std::max(1.0, (12.0 + 2.0) * std::abs(m)), 2.0) << "m " << m;
    }
}

TEST(Footprint, GroupsFollowEachGhostsBlurAndMagnification) {
    // A 20 x 20 px footprint on 0.02 mm pixels. Ghosts: sharp at 1, sharp and inverted at -2, close to 1.1
    // but blurred over 10 mm (500 px, more than 4 x 22 px), too small to show (0.01 x 20 px), and sharp at
    // 3 but nearly dark: it joins the point group.
    detect::Shape square;
    square.width = square.height = 10;
    square.cell = 2.0;
    square.origin_x = square.origin_y = -10.0;
    square.weights.assign(100, 0.01f);
    std::vector<optics::Ghost> ghosts(5);
    for (int g = 0; g < 5; ++g) ghosts[static_cast<std::size_t>(g)] = {g + 1, 0, {}, false};
    const std::vector<optics::GhostImaging> imaging{{1.0, 0.0}, {-2.0, 0.01}, {1.1, 10.0}, {0.01, 0.0}, {3.0, 0.0}};
    const std::vector<double> power{1.0, 1.0, 1.0, 1.0, 1e-5};
    const auto groups = filter::footprint_groups(ghosts, imaging, power, square, 0.02);
    ASSERT_EQ(groups.size(), 3u);
    EXPECT_EQ(groups[0].magnification, 0.0);
    EXPECT_EQ(groups[0].ghosts, (std::vector<std::pair<int, int>>{{3, 0}, {4, 0}, {5, 0}}));
    std::map<double, std::vector<std::pair<int, int>>> sharp;
    for (std::size_t k = 1; k < groups.size(); ++k) sharp[groups[k].magnification] = groups[k].ghosts;
    EXPECT_EQ(sharp.at(1.0), (std::vector<std::pair<int, int>>{{1, 0}}));
    EXPECT_EQ(sharp.at(-2.0), (std::vector<std::pair<int, int>>{{2, 0}}));
}

TEST(Footprint, WideKernelsRunOnAReducedImageAndKeepTheSumAndCentre) {
    // A 40 px square footprint at magnification -5 (a 200 px kernel): done at a quarter of the size.
    detect::Shape square;
    square.width = square.height = 10;
    square.cell = 4.0;
    square.origin_x = 0.0;
    square.origin_y = -20.0;
    square.weights.assign(100, 0.01f);
    const int w = 640, h = 300;
    std::vector<float> rgb(static_cast<std::size_t>(w * h * 3), 0.0f);
    rgb[static_cast<std::size_t>(150 * w + 420) * 3 + 1] = 5.0f;
    filter::convolve_footprint(rgb, w, h, square, -5.0);
    const auto [cx, sum] = centroid_x(rgb, w, 1);
    EXPECT_NEAR(sum, 5.0, 0.05);
    EXPECT_NEAR(cx - 420.0, -5.0 * 20.0, 3.0);
    float peak = 0.0f;
    for (std::size_t i = 1; i < rgb.size(); i += 3) peak = std::max(peak, rgb[i]);
    EXPECT_NEAR(peak, 5.0f / (200.0f * 200.0f), 0.15f * 5.0f / (200.0f * 200.0f)) << "spread over 200 x 200 px";
}

namespace {

// A 22 x 14 px bar of 2 px cells round the light, brighter on its left.
detect::Shape bar_footprint() {
    detect::Shape bar;
    bar.width = 11;
    bar.height = 7;
    bar.cell = 2.0;
    bar.origin_x = -11.0;
    bar.origin_y = -7.0;
    double sum = 0.0;
    for (int j = 0; j < bar.height; ++j)
        for (int i = 0; i < bar.width; ++i) sum += static_cast<double>(bar.weights.emplace_back(static_cast<float>(2.0 - i / 10.0)));
    for (float& w : bar.weights) w = static_cast<float>(static_cast<double>(w) / sum);
    return bar;
}

}  // namespace

TEST(Footprint, ExtendedStarburstLeavesOutWhatTheSourcesOwnPixelsHold) {
    // The pattern (texels half a pixel, ~64 px across) round a 22 x 14 px bar, in the frame and cut by its
    // right edge, against the rule done over the whole frame: each point's pattern within the bar's radius
    // (the disc of its area) left out, the rest spread over the bar, and nothing added on the bar's own
    // pixels (1 at its cells' centres, falling to 0 half a cell outside them).
    optics::StarburstOptions options;
    options.size = 128;
    options.pupil_samples = 24;
    const optics::Starburst sb = optics::make_starburst(optics::Aperture{6, 0.0, 0.0}, options);
    const detect::Shape bar = bar_footprint();
    const int w = 300, h = 200;
    const double f_number = 8.0, pixel = 2.0 * sb.texel_per_fnumber_mm * f_number, core = 5.0;
    const double radius_px = std::sqrt(bar.width * bar.height / std::numbers::pi) * bar.cell;
    const std::array<double, 3> power{2.0, 1.0, 0.5};
    const auto inside = [&](double ox, double oy) {  // the bar's cells, interpolated between their centres
        const double u = (ox - bar.origin_x) / bar.cell - 0.5, v = (oy - bar.origin_y) / bar.cell - 0.5;
        return std::clamp(std::min(u + 1.0, bar.width - u), 0.0, 1.0) * std::clamp(std::min(v + 1.0, bar.height - v), 0.0, 1.0);
    };
    for (const double cx : {150.4, 290.7}) {
        const double cy = 80.2;
        std::vector<float> whole(static_cast<std::size_t>(w * h * 3), 0.0f);
        optics::splat_starburst(sb, {cx, cy, f_number, 2.0 * radius_px}, power, {whole.data(), w, h, pixel, pixel});
        filter::convolve_footprint(whole, w, h, bar, 1.0);
        std::vector<float> added(whole.size(), 0.0f);
        // A vanishing length scale leaves the texture alone (its tail share and the tail both vanish).
        filter::add_extended_starburst(sb, optics::Aperture{6, 0.0, 0.0}, 1e-12, {cx, cy, f_number, core}, power, bar, {added.data(), w, h, pixel, pixel});
        float peak = 0.0f;
        for (float v : whole) peak = std::max(peak, v);
        ASSERT_GT(peak, 0.0f);
        double sum_expected = 0.0, sum_added = 0.0, on_bar = 0.0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const double beyond = 1.0 - inside(x + 0.5 - cx, y + 0.5 - cy);
                for (std::size_t c = 0; c < 3; ++c) {
                    const std::size_t i = static_cast<std::size_t>(y * w + x) * 3 + c;
                    const double expected = beyond * static_cast<double>(whole[i]);
                    ASSERT_NEAR(added[i], expected, 1e-5 * static_cast<double>(peak)) << "pixel " << x << "," << y;
                    sum_expected += expected;
                    sum_added += static_cast<double>(added[i]);
                    if (beyond == 0.0) on_bar += static_cast<double>(added[i]);
                }
            }
        EXPECT_NEAR(sum_added, sum_expected, 1e-5 * sum_expected) << "x " << cx;
        EXPECT_EQ(on_bar, 0.0) << "x " << cx;
        EXPECT_GT(sum_added * pixel * pixel, 0.005) << "the spikes beyond the bar, x " << cx;
    }
}

namespace {

// A disc of 2 px cells, radius_cells cells, even weights summing to 1, centred on the light.
detect::Shape disc_footprint(int radius_cells) {
    detect::Shape disc;
    disc.width = disc.height = 2 * radius_cells;
    disc.cell = 2.0;
    disc.origin_x = disc.origin_y = -2.0 * radius_cells;
    for (int j = 0; j < disc.height; ++j)
        for (int i = 0; i < disc.width; ++i)
            disc.weights.push_back(std::hypot(i + 0.5 - radius_cells, j + 0.5 - radius_cells) < radius_cells ? 1.0f : 0.0f);
    float sum = 0.0f;
    for (float w : disc.weights) sum += w;
    for (float& w : disc.weights) w /= sum;
    return disc;
}

// The upward spike of a hexagonal iris at rows [row0, row1) above the light, within +-half px of its
// column: the green energy there and the root-mean-square offset across the spike.
struct SpikeCut {
    double energy = 0.0, rms_px = 0.0;
};
SpikeCut cut_spike(const std::vector<float>& rgb, int w, double cx, int row0, int row1, int half) {
    SpikeCut cut;
    double moment = 0.0;
    for (int y = row0; y < row1; ++y)
        for (int x = static_cast<int>(cx) - half; x <= static_cast<int>(cx) + half; ++x) {
            const double v = static_cast<double>(rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) * 3 + 1]);
            cut.energy += v;
            moment += v * (x + 0.5 - cx) * (x + 0.5 - cx);
        }
    cut.rms_px = std::sqrt(moment / cut.energy);
    return cut;
}

}  // namespace

// Issue 16: --starburst-scale lengthens an extended light's spikes as a point light's (the light far out
// grows with the scale) and leaves them as wide (it once enlarged the whole texture: fat petals).
TEST(Footprint, ExtendedStarburstScaleLengthensTheSpikesWithoutWideningThem) {
    optics::StarburstOptions options;
    options.size = 128;
    options.pupil_samples = 24;
    const optics::Aperture hexagon{6, 0.0, 0.0};
    const optics::Starburst sb = optics::make_starburst(hexagon, options);
    const detect::Shape disc = disc_footprint(4);  // 16 px across
    const int w = 240, h = 400;
    const double f_number = 8.0, pixel = 2.0 * sb.texel_per_fnumber_mm * f_number, cx = 120.3, cy = 300.6;
    const std::array<double, 3> power{1.0, 1.0, 1.0};
    std::vector<SpikeCut> cuts;
    for (const double scale : {1.0, 4.0}) {
        std::vector<float> rgb(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3, 0.0f);
        filter::add_extended_starburst(sb, hexagon, scale, {cx, cy, f_number, 1.0}, power, disc, {rgb.data(), w, h, pixel, pixel});
        cuts.push_back(cut_spike(rgb, w, cx, 20, 120, 30));  // 180 to 280 px above the light
        const auto [low, high] = std::minmax_element(rgb.begin(), rgb.end());
        EXPECT_TRUE(std::all_of(rgb.begin(), rgb.end(), [](float v) { return std::isfinite(v); }));
        EXPECT_GE(*low, -1e-6f * *high) << "no more than the DFT filter's rounding below 0";
    }
    ASSERT_GT(cuts[0].energy, 0.0) << "the spike reaches 180 px, far beyond the texture's 32 px";
    EXPECT_NEAR(cuts[1].energy / cuts[0].energy, 4.0, 0.4) << "the light far out grows with the scale";
    EXPECT_NEAR(cuts[1].rms_px, cuts[0].rms_px, 0.05 * cuts[0].rms_px) << "as wide at any scale";
    EXPECT_GT(cuts[0].rms_px, 3.0) << "as wide as the 16 px source, not the point light's 1 px";
    EXPECT_LT(cuts[0].rms_px, 8.0);
}

// Issue 14, class 1: lights far outside the frame draw nothing and touch no memory out of bounds (an int
// overflow once wrote out of the buffer), and a footprint of enormous cells ends (it once looped forever).
TEST(Footprint, LightsFarOutsideAndHugeCellsAreBounded) {
    optics::StarburstOptions options;
    options.size = 64;
    options.pupil_samples = 16;
    const optics::Starburst sb = optics::make_starburst(optics::Aperture{6, 0.0, 0.0}, options);
    const int w = 64, h = 48;
    const double pixel = 2.0 * sb.texel_per_fnumber_mm * 8.0;
    for (const double x : {3e9, -3e9, 1e300, 40.0}) {
        for (const double f_number : {8.0, 8000.0}) {  // texels smaller and far larger than pixels
            std::vector<float> rgb(static_cast<std::size_t>(w * h * 3), 0.0f);
            optics::splat_starburst(sb, {x, x == 40.0 ? 3e9 : 20.0, f_number, 0.0}, {1.0, 1.0, 1.0}, {rgb.data(), w, h, pixel, pixel});
            EXPECT_TRUE(std::all_of(rgb.begin(), rgb.end(), [](float v) { return v == 0.0f; })) << x << " f/" << f_number;
        }
    }
    detect::Shape huge;
    huge.width = huge.height = 2;
    huge.origin_x = huge.origin_y = -1e4;
    huge.weights.assign(4, 0.25f);
    for (const double cell : {1e4, 1e30}) {
        huge.cell = cell;
        for (const double m : {0.01, 0.5, 2.0}) {
            std::vector<float> rgb(static_cast<std::size_t>(w * h * 3), 0.0f);
            rgb[static_cast<std::size_t>(24 * w + 32) * 3] = 1.0f;
            filter::convolve_footprint(rgb, w, h, huge, m);  // ends; spreads the point or leaves it
            EXPECT_TRUE(std::all_of(rgb.begin(), rgb.end(), [](float v) { return std::isfinite(v) && v >= 0.0f; })) << cell << " m " << m;
        }
    }
}
