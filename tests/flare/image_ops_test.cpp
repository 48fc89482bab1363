// The composite's image operations (flare/image_ops.h): regions, nonzero_region, add and add_resized between
// views placed at different origins, clipped to both and held within float range.
#include <algorithm>
#include <bit>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <atomic>
#include <gtest/gtest.h>

#include <flare/image_ops.h>
#include <opencv2/imgproc.hpp>

namespace lensfx::flare {
namespace {

TEST(ImageOps, NonzeroRegionIsTheLitBoxInThePixelSpace) {
    std::vector<float> rgb(5 * 4 * 3, 0.0f);
    const ConstRgbView view{rgb.data(), 10, 20, 5, 4};
    EXPECT_TRUE(nonzero_region(view).empty());
    rgb[(1 * 5 + 3) * 3 + 2] = 0.5f;   // (3, 1): blue only
    rgb[(2 * 5 + 1) * 3 + 0] = -1.0f;  // (1, 2): negative counts as lit
    const Region r = nonzero_region(view);
    EXPECT_EQ(r.x0, 11);
    EXPECT_EQ(r.y0, 21);
    EXPECT_EQ(r.x1, 14);
    EXPECT_EQ(r.y1, 23);
}

TEST(ImageOps, AddCoversTheOverlapOnlyAndSaturates) {
    std::vector<float> dst(4 * 3 * 3, 1.0f);  // at (2, 1), 4 x 3
    std::vector<float> src(3 * 3 * 3, 0.0f);  // at (0, 0), 3 x 3: overlaps columns 2, rows 1..2
    for (std::size_t i = 0; i < src.size(); ++i) src[i] = static_cast<float>(i);
    const float big = std::numeric_limits<float>::max();
    dst[0] = big;  // (2, 1) red: the largest float plus the largest float stays finite
    src[(1 * 3 + 2) * 3] = big;
    const RgbView to{dst.data(), 2, 1, 4, 3};
    const ConstRgbView from{src.data(), 0, 0, 3, 3};
    add(to, from, from.region());
    EXPECT_EQ(dst[0], big);                             // held, not inf
    EXPECT_EQ(dst[1], 1.0f + src[(1 * 3 + 2) * 3 + 1]);  // (2, 1) green
    EXPECT_EQ(dst[(1 * 4 + 0) * 3 + 2], 1.0f + src[(2 * 3 + 2) * 3 + 2]);  // (2, 2) blue
    EXPECT_EQ(dst[3], 1.0f);                            // (3, 1): outside the source
    EXPECT_EQ(dst[(2 * 4 + 0) * 3], 1.0f);              // (2, 3): below it
    // A region that misses either view adds nothing.
    add(to, from, Region{0, 0, 2, 3});
    EXPECT_EQ(dst[3], 1.0f);
}

// An image of w x h whose pixel (x, y) channel c holds value(x, y, c).
template <typename Value>
std::vector<float> image_of(int w, int h, Value value) {
    std::vector<float> rgb(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) * 3 + static_cast<std::size_t>(c)] = value(x, y, c);
    return rgb;
}

TEST(ImageOps, AddResizedBlendsBetweenPixelCentresAndHoldsTheEdges) {
    // A 2 x 1 ramp (0, 1) over 4 x 1: output centres at source positions -0.25, 0.25, 0.75, 1.25.
    const std::vector<float> src{0.0f, 0.0f, 0.0f, 1.0f, 2.0f, 4.0f};
    std::vector<float> dst(4 * 3, 1.0f);
    add_resized(RgbView{dst.data(), 0, 0, 4, 1}, ConstRgbView{src.data(), 0, 0, 2, 1}, Region{0, 0, 4, 1});
    const float expected[4] = {0.0f, 0.25f, 0.75f, 1.0f};
    for (std::size_t x = 0; x < 4; ++x)
        for (std::size_t c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(dst[x * 3 + c], 1.0f + expected[x] * src[3 + c]) << x << " " << c;
}

TEST(ImageOps, BilinearTapsHoldTheEdgesAndStayInsideTheSource) {
    const std::vector<BilinearTap> taps = bilinear_taps(4, 2);
    ASSERT_EQ(taps.size(), 4u);
    EXPECT_EQ(taps[0].i0, 0);  // before the first centre: held
    EXPECT_EQ(taps[0].f, 0.0f);
    EXPECT_EQ(taps[1].i1, 1);
    EXPECT_EQ(taps[1].f, 0.25f);
    EXPECT_EQ(taps[3].i0, 1);  // beyond the last: held, no pixel past the source
    EXPECT_EQ(taps[3].i1, 1);
    for (const BilinearTap& t : bilinear_taps(7, 3)) EXPECT_TRUE(t.i0 >= 0 && t.i1 <= 2 && t.f >= 0.0f && t.f < 1.0f);
}

TEST(ImageOps, AddResizedAtTheSameSizeIsAdd) {
    const auto value = [](int x, int y, int c) { return static_cast<float>(x * 7 + y * 3 + c) * 0.125f; };
    const std::vector<float> src = image_of(5, 4, value);
    std::vector<float> resized(6 * 6 * 3, 0.5f), added = resized;
    const ConstRgbView from{src.data(), 1, 2, 5, 4};
    add_resized(RgbView{resized.data(), 0, 0, 6, 6}, from, from.region());
    add(RgbView{added.data(), 0, 0, 6, 6}, from, from.region());
    EXPECT_EQ(resized, added);
}

TEST(ImageOps, AddResizedOverARegionBeyondTheImageAddsTheOverlapOnly) {
    // A 3 x 3 source over a 12 x 12 region starting at (-4, -4), into a whole 8 x 8 image and into a 3 x 2 one
    // at (5, 6): the small one gets exactly the whole one's pixels there; nothing else changes.
    const std::vector<float> src = image_of(3, 3, [](int x, int y, int c) { return static_cast<float>(1 + x + 3 * y + c); });
    const ConstRgbView from{src.data(), 0, 0, 3, 3};
    const Region region{-4, -4, 8, 8};
    std::vector<float> whole(8 * 8 * 3, 0.0f), part(3 * 2 * 3, 0.0f);
    add_resized(RgbView{whole.data(), 0, 0, 8, 8}, from, region);
    add_resized(RgbView{part.data(), 5, 6, 3, 2}, from, region);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x)
            for (int c = 0; c < 3; ++c)
                EXPECT_EQ(part[static_cast<std::size_t>((y * 3 + x) * 3 + c)], whole[static_cast<std::size_t>(((y + 6) * 8 + x + 5) * 3 + c)]);
    // Pixel (0, 0) is the region's (4, 4): source position 4.5 x 3 / 12 - 0.5 = 0.625 both ways, where the
    // linear source holds 1 + 0.625 + 3 x 0.625 in red.
    EXPECT_FLOAT_EQ(whole[0], 1.0f + 0.625f + 3.0f * 0.625f);
    std::vector<float> untouched(4 * 3, 2.0f);
    add_resized(RgbView{untouched.data(), 8, 0, 2, 2}, from, region);  // beside the region
    EXPECT_EQ(untouched, std::vector<float>(4 * 3, 2.0f));
}

TEST(ImageOps, AddResizedSaturatesAndLeavesNoNaNBesideAnInfinitePixel) {
    const float big = std::numeric_limits<float>::max(), inf = std::numeric_limits<float>::infinity();
    const std::vector<float> src{big, big, inf, 0.0f, 0.0f, 0.0f};  // 2 x 1
    std::vector<float> dst(2 * 3, big);
    add_resized(RgbView{dst.data(), 0, 0, 2, 1}, ConstRgbView{src.data(), 0, 0, 2, 1}, Region{0, 0, 2, 1});
    EXPECT_EQ(dst[0], big);   // big + big held
    EXPECT_EQ(dst[2], inf);   // an infinite input passes through
    EXPECT_EQ(dst[3], big);   // its neighbour, at its own centre, is not NaN
    EXPECT_EQ(dst[5], big);
}

// The footprint's enlargements were OpenCV's bilinear resize (pixel centres aligned, edges held); add_resized
// into zeros gives the same image within float rounding: whole factors and a stretch to an odd size.
TEST(ImageOps, AddResizedIntoZerosIsOpenCvsBilinearResize) {
    const int sw = 13, sh = 9;
    const std::vector<float> src = image_of(sw, sh, [](int x, int y, int c) { return std::sin(0.7f * x + 1.3f * y + c) + 1.5f; });
    for (const auto& [w, h] : {std::pair{39, 27}, std::pair{52, 36}, std::pair{50, 31}}) {
        std::vector<float> ours(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3, 0.0f);
        add_resized(RgbView{ours.data(), 0, 0, w, h}, ConstRgbView{src.data(), 0, 0, sw, sh}, Region{0, 0, w, h});
        cv::Mat theirs;
        cv::resize(cv::Mat(sh, sw, CV_32FC3, const_cast<float*>(src.data())), theirs, cv::Size(w, h), 0.0, 0.0, cv::INTER_LINEAR);
        float worst = 0.0f;
        for (std::size_t i = 0; i < ours.size(); ++i) worst = std::max(worst, std::abs(ours[i] - theirs.ptr<float>()[i]));
        EXPECT_LT(worst, 4e-6f) << w << "x" << h;  // values 0.5..2.5: a few float steps
    }
}

// The Mitchell taps sample where the bilinear ones do: at the same size each pixel is its own centre (weights
// 1/18, 16/18, 1/18 over its neighbours), and enlarged the four weights sum to one over pixels of the source.
TEST(ImageOps, MitchellTapsShareTheBilinearMappingAndSumToOne) {
    for (const CubicTap& t : mitchell_taps(3, 3)) {
        EXPECT_NEAR(t.f[0], 1.0 / 18.0, 1e-7);
        EXPECT_NEAR(t.f[1], 16.0 / 18.0, 1e-7);
        EXPECT_NEAR(t.f[2], 1.0 / 18.0, 1e-7);
        EXPECT_EQ(t.f[3], 0.0f);
    }
    const std::vector<BilinearTap> bilinear = bilinear_taps(11, 4);
    const std::vector<CubicTap> cubic = mitchell_taps(11, 4);
    for (std::size_t i = 0; i < cubic.size(); ++i) {
        const CubicTap& t = cubic[i];
        EXPECT_EQ(t.i[1], bilinear[i].i0);
        EXPECT_NEAR(t.f[0] + t.f[1] + t.f[2] + t.f[3], 1.0, 1e-6);
        for (int j = 0; j < 4; ++j) EXPECT_TRUE(t.i[j] >= 0 && t.i[j] <= 3);
    }
}

// Reduction by a whole factor: each reduced pixel the mean of the f x f pixels it covers (beyond the image: 0), in
// a pixel space f times coarser, whatever the image's origin.
TEST(ImageOps, ReduceAreaAveragesTheBlocksEachPixelCovers) {
    const int w = 7, h = 5, f = 3;  // 3 x 2 reduced pixels, the last column and row partly beyond the image
    const std::vector<float> src = image_of(w, h, [](int x, int y, int c) { return static_cast<float>(1 + x + 10 * y + 100 * c); });
    std::vector<float> small(static_cast<std::size_t>(reduced_side(w, f) * reduced_side(h, f)) * 3, -1.0f);
    ASSERT_EQ(reduced_side(w, f), 3);
    ASSERT_EQ(reduced_side(h, f), 2);
    reduce_area(RgbView{small.data(), 0, 0, 3, 2}, ConstRgbView{src.data(), 0, 0, w, h}, f);
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 3; ++i)
            for (int c = 0; c < 3; ++c) {
                double sum = 0.0;
                for (int y = j * f; y < std::min(h, (j + 1) * f); ++y)
                    for (int x = i * f; x < std::min(w, (i + 1) * f); ++x) sum += 1 + x + 10 * y + 100 * c;
                EXPECT_FLOAT_EQ(small[static_cast<std::size_t>((j * 3 + i) * 3 + c)], static_cast<float>(sum / (f * f))) << i << "," << j;
            }
    // The same image at (-4, 6) of its pixel space: reduced pixel (-2, 2) covers (-6..-4, 6..8), of which the
    // image holds column -4 (its first); (-1, 2) covers its columns 1..3.
    std::vector<float> placed(3 * 3 * 3, -1.0f);
    reduce_area(RgbView{placed.data(), -2, 2, 3, 3}, ConstRgbView{src.data(), -4, 6, w, h}, f);
    EXPECT_FLOAT_EQ(placed[0], (1.0f + 11.0f + 21.0f) / 9.0f);
    EXPECT_FLOAT_EQ(placed[3], (3.0f * 3.0f + 3.0f * (1.0f + 2.0f + 3.0f) + 3.0f * 30.0f) / 9.0f);
    EXPECT_FLOAT_EQ(placed[(2 * 3 + 2) * 3], 0.0f);  // (0, 4): covers (0..2, 12..14), beyond the image
}

// add_enlarged is reduce_area's way back: a reduced pixel's centre lands at the centre of the f x f pixels it
// covers, so a flat image comes back flat and a lone reduced pixel spreads symmetrically round its block.
TEST(ImageOps, AddEnlargedKeepsEachReducedPixelCentredOnItsBlock) {
    const int w = 12, h = 8, f = 4;
    const std::vector<float> flat = image_of(w, h, [](int, int, int c) { return 1.0f + static_cast<float>(c); });
    std::vector<float> small(3 * 2 * 3), back(static_cast<std::size_t>(w * h * 3), 0.0f);
    reduce_area(RgbView{small.data(), 0, 0, 3, 2}, ConstRgbView{flat.data(), 0, 0, w, h}, f);
    add_enlarged(RgbView{back.data(), 0, 0, w, h}, ConstRgbView{small.data(), 0, 0, 3, 2}, f);
    for (std::size_t i = 0; i < back.size(); ++i) EXPECT_FLOAT_EQ(back[i], flat[i]) << i;
    std::vector<float> lone(5 * 1 * 3, 0.0f), row(static_cast<std::size_t>(5 * f * 3), 0.0f);
    lone[2 * 3] = 1.0f;  // reduced pixel 2 covers full pixels 8..11, centre 9.5
    add_enlarged(RgbView{row.data(), 0, 0, 5 * f, 1}, ConstRgbView{lone.data(), 0, 0, 5, 1}, f);
    double sum = 0.0, moment = 0.0;
    for (int x = 0; x < 5 * f; ++x) {
        sum += static_cast<double>(row[static_cast<std::size_t>(x) * 3]);
        moment += x * static_cast<double>(row[static_cast<std::size_t>(x) * 3]);
    }
    EXPECT_NEAR(moment / sum, 9.5, 1e-6);
    EXPECT_NEAR(sum, f, 1e-6);
}

// A source dark but for a few pixels changes only the frame's pixels their taps reach: those match the
// bilinear blend of every source pixel, and the rest are left bit for bit (a -0 stays -0, which adding a
// blended zero would turn to +0).
TEST(ImageOps, AddResizedVisitsOnlyWhatTheLitSourceReaches) {
    const int sw = 17, sh = 11, w = 70, h = 45;
    std::vector<float> src(static_cast<std::size_t>(sw * sh * 3), 0.0f);
    src[static_cast<std::size_t>(4 * sw + 6) * 3 + 1] = 2.0f;
    src[static_cast<std::size_t>(7 * sw + 9) * 3 + 2] = -1.5f;
    std::vector<float> ours(static_cast<std::size_t>(w * h * 3), -0.0f), want(ours.size(), 0.0f);
    add_resized(RgbView{ours.data(), 3, 2, w, h}, ConstRgbView{src.data(), 5, 1, sw, sh}, Region{-2, 1, w + 5, h + 4});
    // The blend of every source pixel, written out: taps over the region, sampled where the frame lies.
    const std::vector<BilinearTap> xs = bilinear_taps(w + 7, sw), ys = bilinear_taps(h + 3, sh);
    int changed = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (std::size_t c = 0; c < 3; ++c) {
                const BilinearTap tx = xs[static_cast<std::size_t>(x + 3 + 2)], ty = ys[static_cast<std::size_t>(y + 2 - 1)];
                auto at = [&](int i, int j) { return src[static_cast<std::size_t>(j * sw + i) * 3 + c]; };
                auto row = [&](int j) { return at(tx.i0, j) + tx.f * (at(tx.i1, j) - at(tx.i0, j)); };
                const float v = row(ty.i0) + ty.f * (row(ty.i1) - row(ty.i0));
                const float got = ours[static_cast<std::size_t>(y * w + x) * 3 + c];
                EXPECT_NEAR(got, v, 1e-6f) << x << "," << y << "," << c;
                if (!std::signbit(got) || got != 0.0f) ++changed;
            }
    EXPECT_GT(changed, 20);            // the lit pixels spread
    EXPECT_LT(changed, w * h * 3 / 4);  // and most of the frame is untouched -0
    EXPECT_TRUE(std::signbit(ours[0]));
}

// The level sums' one pass: the same floats as one add_resized after another, sources of different sizes over
// regions that overlap, reach beyond the frame or miss it, one of them dark.
TEST(ImageOps, AddResizedEachIsEachAddResizedInTurn) {
    const int w = 41, h = 29;
    const std::vector<float> a = image_of(11, 8, [](int x, int y, int c) { return std::sin(0.9f * x + 0.4f * y + c) * 3.0f; });
    const std::vector<float> b = image_of(5, 4, [](int x, int y, int c) { return 1e-3f * (x + 2 * y + c) + 1e30f * (x == 2 && y == 1); });
    const std::vector<float> dark(3 * 3 * 3, 0.0f);
    const std::vector<ConstRgbView> srcs{ConstRgbView{a.data(), 0, 0, 11, 8}, ConstRgbView{b.data(), 0, 0, 5, 4},
                                         ConstRgbView{dark.data(), 0, 0, 3, 3}, ConstRgbView{a.data(), 0, 0, 11, 8}};
    const std::vector<Region> regions{Region{0, 0, 44, 32}, Region{-7, 5, 30, 40}, Region{0, 0, w, h}, Region{50, 0, 60, 10}};
    std::vector<float> each = image_of(w, h, [](int x, int y, int c) { return 0.25f * (x - y) + c; }), turn = each;
    add_resized_each(RgbView{each.data(), 0, 0, w, h}, srcs, regions);
    for (std::size_t k = 0; k < srcs.size(); ++k) add_resized(RgbView{turn.data(), 0, 0, w, h}, srcs[k], regions[k]);
    ASSERT_EQ(each.size(), turn.size());
    for (std::size_t i = 0; i < each.size(); ++i) ASSERT_EQ(std::bit_cast<std::uint32_t>(each[i]), std::bit_cast<std::uint32_t>(turn[i])) << i;
    EXPECT_THROW(add_resized_each(RgbView{each.data(), 0, 0, w, h}, srcs, std::span(regions).first(2)), std::invalid_argument);
}

// From 256 rows on, add_resized_each adds half the rows on a second thread: bit for bit what the frame's two
// halves get when each is a view of its own (under 256 rows, added on one thread).
TEST(ImageOps, AddResizedEachSplitOverTwoThreadsIsTheSame) {
    const int w = 97, h = 400;
    const std::vector<float> a = image_of(13, 9, [](int x, int y, int c) { return std::sin(0.7f * x + 0.3f * y + c) * 2.0f + 2.5f; });
    const std::vector<float> b = image_of(6, 40, [](int x, int y, int c) { return 1e-2f * (x + y + c); });
    const std::vector<ConstRgbView> srcs{ConstRgbView{a.data(), 0, 0, 13, 9}, ConstRgbView{b.data(), 0, 0, 6, 40}};
    const std::vector<Region> regions{Region{0, 0, w, h}, Region{-20, 150, 60, 380}};
    std::vector<float> whole = image_of(w, h, [](int x, int y, int c) { return 0.01f * (x - y) + c; }), halves = whole;
    add_resized_each(RgbView{whole.data(), 0, 0, w, h}, srcs, regions);
    for (const int y0 : {0, 200})
        add_resized_each(RgbView{halves.data() + static_cast<std::size_t>(y0) * w * 3, 0, y0, w, 200}, srcs, regions);
    for (std::size_t i = 0; i < whole.size(); ++i) ASSERT_EQ(std::bit_cast<std::uint32_t>(whole[i]), std::bit_cast<std::uint32_t>(halves[i])) << i;
}

// split_rows visits every row once, on two threads from min_rows rows on, and passes on what the body throws.
TEST(ImageOps, SplitRowsVisitsEveryRowOnceAndPassesErrorsOn) {
    for (const int rows : {0, 1, 7, 300}) {
        std::vector<int> seen(static_cast<std::size_t>(rows), 0);
        std::atomic<int> calls = 0;
        split_rows(0, rows, 256, [&](int y0, int y1) {
            ++calls;
            for (int y = y0; y < y1; ++y) ++seen[static_cast<std::size_t>(y)];
        });
        EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int n) { return n == 1; })) << rows;
        EXPECT_EQ(calls.load(), rows >= 256 ? 2 : 1) << rows;
    }
    for (const int failing : {0, 200})  // the first half's thread or the second's
        EXPECT_THROW(split_rows(0, 400, 256, [&](int y0, int) {
                         if (y0 == failing) throw std::runtime_error("row");
                     }),
                     std::runtime_error);
}

}  // namespace
}  // namespace lensfx::flare
