// Extended sources' footprints (flare/footprint.h): the convolution scaled and turned with each ghost,
// the grouping by blur and magnification, the reduced image for wide kernels, the extended starburst.
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <detect/source.h>
#include <flare/footprint.h>
#include <optics/aperture.h>
#include <optics/ghosts.h>
#include <optics/starburst.h>

using namespace lensfx;

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

namespace {

// A bar 12 px wide, 4 px tall, to the right of the light (cells of 2 px): its centre 6 px right.
detect::Shape right_bar() {
    detect::Shape bar;
    bar.width = 6;
    bar.height = 2;
    bar.cell = 2.0;
    bar.origin_x = 0.0;
    bar.origin_y = -2.0;
    bar.weights.assign(12, 1.0f / 12.0f);
    return bar;
}

}  // namespace

TEST(Footprint, ConvolutionScalesAndTurnsTheFootprintWithTheGhost) {
    flare::ConvolveScratch scratch;  // the FFTs' arrays (flare/convolve.h)
    const detect::Shape bar = right_bar();
    const int w = 121, h = 41;
    for (const double m : {1.0, 2.0, -1.5, 0.5, -0.25}) {
        std::vector<float> rgb(static_cast<std::size_t>(w * h * 3), 0.0f);
        const std::size_t light = static_cast<std::size_t>(20 * w + 60);
        rgb[light * 3] = 1.0f;
        rgb[light * 3 + 1] = 2.0f;
        rgb[light * 3 + 2] = 3.0f;
        flare::convolve_footprint(rgb, w, h, bar, m, scratch);
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
    const auto groups = flare::footprint_groups(ghosts, imaging, power, square, 0.02);
    ASSERT_EQ(groups.size(), 3u);
    EXPECT_EQ(groups[0].magnification, 0.0);
    EXPECT_EQ(groups[0].ghosts, (std::vector<std::pair<int, int>>{{3, 0}, {4, 0}, {5, 0}}));
    std::map<double, std::vector<std::pair<int, int>>> sharp;
    for (std::size_t k = 1; k < groups.size(); ++k) sharp[groups[k].magnification] = groups[k].ghosts;
    EXPECT_EQ(sharp.at(1.0), (std::vector<std::pair<int, int>>{{1, 0}}));
    EXPECT_EQ(sharp.at(-2.0), (std::vector<std::pair<int, int>>{{2, 0}}));
}

// A few lit pixels in a large image are convolved over the part the kernel reaches from them only: the same
// values as the whole of a small image holding them, 0 everywhere else, also where the part meets the border.
TEST(Footprint, OnlyThePartTheLightReachesIsConvolved) {
    flare::ConvolveScratch scratch;  // the FFTs' arrays (flare/convolve.h)
    const detect::Shape bar = right_bar();
    const int w = 600, h = 400, sw = 71, sh = 25;  // the small image: the light at its centre, and the kernel's reach
    for (const auto& [lx, ly] : {std::pair{300, 200}, std::pair{2, 397}}) {
        std::vector<float> large(static_cast<std::size_t>(w * h * 3), 0.0f);
        std::vector<float> small(static_cast<std::size_t>(sw * sh * 3), 0.0f);
        const int ox = lx - sw / 2, oy = ly - sh / 2;  // the small image's corner in the large one
        for (const auto& [dx, dy] : {std::pair{0, 0}, std::pair{3, 1}}) {
            if (lx + dx >= w || ly + dy >= h) continue;
            large[static_cast<std::size_t>((ly + dy) * w + lx + dx) * 3 + 1] = 2.0f;
            small[static_cast<std::size_t>((ly + dy - oy) * sw + lx + dx - ox) * 3 + 1] = 2.0f;
        }
        flare::convolve_footprint(large, w, h, bar, 2.0, scratch);
        flare::convolve_footprint(small, sw, sh, bar, 2.0, scratch);
        double worst = 0.0, outside = 0.0, sum = 0.0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const double v = large[static_cast<std::size_t>(y * w + x) * 3 + 1];
                sum += v;
                const int sx = x - ox, sy = y - oy;
                if (sx >= 0 && sy >= 0 && sx < sw && sy < sh)
                    worst = std::max(worst, std::abs(v - static_cast<double>(small[static_cast<std::size_t>(sy * sw + sx) * 3 + 1])));
                else
                    outside = std::max(outside, std::abs(v));
            }
        EXPECT_GT(sum, 0.5) << "light at " << lx << "," << ly;
        EXPECT_LT(worst, 1e-6) << "light at " << lx << "," << ly;
        EXPECT_EQ(outside, 0.0) << "light at " << lx << "," << ly;
    }
}

TEST(Footprint, WideKernelsRunOnAReducedImageAndKeepTheSumAndCentre) {
    flare::ConvolveScratch scratch;  // the FFTs' arrays (flare/convolve.h)
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
    flare::convolve_footprint(rgb, w, h, square, -5.0, scratch);
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

TEST(Footprint, PeakShareBoundsAnyConvolvedGhostAndIsReachedByAPoint) {
    flare::ConvolveScratch scratch;  // the FFTs' arrays (flare/convolve.h)
    // The bar brighter on its left, at magnifications that enlarge, shrink, turn round and reduce the image.
    const detect::Shape bar = bar_footprint();
    const int w = 400, h = 300;
    for (const double m : {3.0, 0.6, -1.5, 9.0}) {
        const double share = flare::footprint_peak_share(bar, m);
        ASSERT_GT(share, 0.0) << m;
        ASSERT_LE(share, 1.0) << m;
        // A point of power 1 (value 1 in one pixel) peaks at the share: the bound is tight.
        std::vector<float> point(static_cast<std::size_t>(w * h * 3), 0.0f);
        point[static_cast<std::size_t>(150 * w + 200) * 3] = 1.0f;
        flare::convolve_footprint(point, w, h, bar, m, scratch);
        float peak = 0.0f;
        for (std::size_t i = 0; i < point.size(); i += 3) peak = std::max(peak, point[i]);
        EXPECT_LE(peak, 1.0001 * share) << m;
        EXPECT_GE(peak, 0.5 * share) << m;
        // Any image's peak after convolution is at most its sum times the share: a sharp spike and a spread
        // ghost of 37 pixels, each of sum 1.
        std::vector<float> ghost(static_cast<std::size_t>(w * h * 3), 0.0f);
        for (int k = 0; k < 37; ++k) ghost[static_cast<std::size_t>((140 + k % 6) * w + 190 + k / 6) * 3] = k == 0 ? 0.64f : 0.01f;
        flare::convolve_footprint(ghost, w, h, bar, m, scratch);
        float ghost_peak = 0.0f;
        for (std::size_t i = 0; i < ghost.size(); i += 3) ghost_peak = std::max(ghost_peak, ghost[i]);
        EXPECT_LE(ghost_peak, 1.0001 * share) << m;
    }
    // Nothing convolved keeps the ghost's own peak; a kernel that clears the image leaves nothing.
    detect::Shape empty = bar;
    std::fill(empty.weights.begin(), empty.weights.end(), 0.0f);
    EXPECT_EQ(flare::footprint_peak_share(empty, 2.0), 1.0);
    EXPECT_EQ(flare::footprint_peak_share(bar, 1e12), 0.0);
}

TEST(Footprint, ExtendedStarburstLeavesOutWhatTheSourcesOwnPixelsHold) {
    flare::ConvolveScratch scratch;  // the FFTs' arrays (flare/convolve.h)
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
        flare::convolve_footprint(whole, w, h, bar, 1.0, scratch);
        std::vector<float> added(whole.size(), 0.0f);
        // A vanishing length scale leaves the texture alone (its tail share and the tail both vanish).
        flare::add_extended_starburst(sb, optics::Aperture{6, 0.0, 0.0}, 1e-12, {cx, cy, f_number, core}, power, bar, {added.data(), w, h, pixel, pixel}, scratch);
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
    flare::ConvolveScratch scratch;  // the FFTs' arrays (flare/convolve.h)
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
        flare::add_extended_starburst(sb, hexagon, scale, {cx, cy, f_number, 1.0}, power, disc, {rgb.data(), w, h, pixel, pixel}, scratch);
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
    flare::ConvolveScratch scratch;  // the FFTs' arrays (flare/convolve.h)
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
            flare::convolve_footprint(rgb, w, h, huge, m, scratch);  // ends; spreads the point or leaves it
            EXPECT_TRUE(std::all_of(rgb.begin(), rgb.end(), [](float v) { return std::isfinite(v) && v >= 0.0f; })) << cell << " m " << m;
        }
    }
}
