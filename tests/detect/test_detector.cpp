// Detection on synthetic frames with known answers.
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include <detect/detector.h>

#include "synth.h"

using namespace lensfx::detect;
using namespace lensfx::detect::test;

namespace {

DetectorOptions opts(double threshold = 20.0) {
    DetectorOptions o;
    o.threshold = Threshold{Threshold::Kind::Absolute, threshold};
    return o;
}

}  // namespace

TEST(Detector, SubPixelCentroidAndFluxOfAGaussian) {
    Detector det(opts());
    for (const auto& [cx, cy] : {std::pair{100.37, 80.81}, std::pair{57.5, 40.5}, std::pair{63.02, 71.93}}) {
        cv::Mat img = flat_frame(200, 160, 0.05f);
        add_gaussian(img, cx, cy, 1000.0, 2.0);
        const Detection d = det.detect(img);
        ASSERT_EQ(d.sources.size(), 1u);
        const Source& s = d.sources[0];
        EXPECT_NEAR(s.x, cx, 0.01);
        EXPECT_NEAR(s.y, cy, 0.01);
        // Pixels above the low threshold (10 = 1% of the peak) hold 99% of a Gaussian's energy.
        EXPECT_NEAR(s.flux[1], 0.99 * gaussian_energy(1000.0, 2.0), 0.01 * gaussian_energy(1000.0, 2.0));
        EXPECT_NEAR(s.extent.major, 4.0, 0.3);  // 2 sigma
        EXPECT_NEAR(s.extent.minor, 4.0, 0.3);
        EXPECT_NEAR(s.peak, 1000.0, 150.0);
        EXPECT_FALSE(s.clipped);
        EXPECT_FALSE(s.shape.has_value());
    }
}

TEST(Detector, ShapeOfARotatedEllipticalGaussian) {
    Detector det(opts());
    cv::Mat img = flat_frame(200, 200, 0.0f);
    add_gaussian(img, 100.2, 99.7, 500.0, 6.0, 2.0, 30.0);
    const Detection d = det.detect(img);
    ASSERT_EQ(d.sources.size(), 1u);
    const Extent& e = d.sources[0].extent;
    EXPECT_NEAR(e.angle_deg, 30.0, 1.0);
    EXPECT_NEAR(e.major, 12.0, 0.8);
    EXPECT_NEAR(e.minor, 4.0, 0.4);
    ASSERT_TRUE(d.sources[0].shape.has_value());  // its box is wider than shape_min_size
}

TEST(Detector, TintedFluxPerChannel) {
    Detector det(opts());
    cv::Mat img = flat_frame(120, 120, 0.0f);
    add_gaussian(img, 60.3, 59.6, 800.0, 1.5, -1.0, 0.0, {1.0, 0.5, 0.25});
    const Detection d = det.detect(img);
    ASSERT_EQ(d.sources.size(), 1u);
    EXPECT_NEAR(d.sources[0].flux[1] / d.sources[0].flux[0], 0.5, 1e-6);
    EXPECT_NEAR(d.sources[0].flux[2] / d.sources[0].flux[0], 0.25, 1e-6);
    const double luma = 0.2126 * d.sources[0].flux[0] + 0.7152 * d.sources[0].flux[1] + 0.0722 * d.sources[0].flux[2];
    EXPECT_NEAR(d.sources[0].luminous_flux, luma, 1e-9 * luma);
}

TEST(Detector, SinglePixelLightSurvivesDownsampling) {
    for (int f : {1, 2, 4, 8, 16}) {
        auto o = opts();
        o.downsample = f;
        Detector det(o);
        cv::Mat img = flat_frame(333, 211, 0.1f);
        img.at<cv::Vec3f>(101, 257) = cv::Vec3f(500.0f, 500.0f, 500.0f);
        const Detection d = det.detect(img);
        ASSERT_EQ(d.sources.size(), 1u) << "downsample " << f;
        EXPECT_DOUBLE_EQ(d.sources[0].x, 257.5);
        EXPECT_DOUBLE_EQ(d.sources[0].y, 101.5);
        EXPECT_EQ(d.sources[0].pixel_count, 1);
        EXPECT_DOUBLE_EQ(d.sources[0].flux[0], 500.0);
    }
}

TEST(Detector, CoarseSearchGivesTheSameSourcesAsFullResolution) {
    cv::Mat img = flat_frame(400, 300, 0.2f);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> ux(10.0, 390.0), uy(10.0, 290.0), up(30.0, 3000.0), us(0.6, 3.0);
    for (int i = 0; i < 25; ++i) add_gaussian(img, ux(rng), uy(rng), up(rng), us(rng));
    auto o1 = opts();
    o1.downsample = 1;
    o1.max_lights = 100;
    o1.visibility = 0.0;
    auto o4 = o1;
    o4.downsample = 4;
    const Detection a = Detector(o1).detect(img), b = Detector(o4).detect(img);
    ASSERT_EQ(a.sources.size(), b.sources.size());
    ASSERT_GT(a.sources.size(), 5u);
    for (std::size_t i = 0; i < a.sources.size(); ++i) {
        EXPECT_NEAR(a.sources[i].x, b.sources[i].x, 1e-9);
        EXPECT_NEAR(a.sources[i].y, b.sources[i].y, 1e-9);
        EXPECT_NEAR(a.sources[i].flux[0], b.sources[i].flux[0], 1e-9 * a.sources[i].flux[0]);
        EXPECT_EQ(a.sources[i].pixel_count, b.sources[i].pixel_count);
    }
}

TEST(Detector, NanInfAndNegativePixelsNeverMakeOrPoisonASource) {
    Detector det(opts());
    cv::Mat img = flat_frame(160, 120, 0.1f);
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    for (int y = 10; y < 20; ++y)
        for (int x = 10; x < 20; ++x) img.at<cv::Vec3f>(y, x) = cv::Vec3f(nan, nan, nan);
    for (int y = 30; y < 34; ++y)
        for (int x = 100; x < 104; ++x) img.at<cv::Vec3f>(y, x) = cv::Vec3f(inf, inf, inf);
    for (int y = 90; y < 95; ++y)
        for (int x = 20; x < 25; ++x) img.at<cv::Vec3f>(y, x) = cv::Vec3f(-1e6f, -inf, -5000.0f);
    EXPECT_TRUE(det.detect(img).sources.empty());

    add_gaussian(img, 80.4, 60.6, 600.0, 2.0);
    cv::Mat clean = img.clone();
    img.at<cv::Vec3f>(61, 81) = cv::Vec3f(nan, inf, -3.0f);  // inside the light
    clean.at<cv::Vec3f>(61, 81) = cv::Vec3f(0.0f, 0.0f, 0.0f);
    const Detection d = det.detect(img), dc = det.detect(clean);
    ASSERT_EQ(d.sources.size(), 1u);
    EXPECT_GT(d.stats.invalid_pixels, 100 + 16 + 25 - 1);
    for (double v : {d.sources[0].x, d.sources[0].y, d.sources[0].flux[0], d.sources[0].flux[1], d.sources[0].flux[2],
                     d.sources[0].extent.major, d.stats.total_luminous_flux, d.stats.median_luminance})
        EXPECT_TRUE(std::isfinite(v));
    // The bad pixel counts as black: same as the clean frame with that pixel zeroed.
    ASSERT_EQ(dc.sources.size(), 1u);
    EXPECT_DOUBLE_EQ(d.sources[0].flux[0], dc.sources[0].flux[0]);
    EXPECT_DOUBLE_EQ(d.sources[0].x, dc.sources[0].x);
}

TEST(Detector, MergesComponentsCloserThanTheRadius) {
    cv::Mat img = flat_frame(200, 100, 0.0f);
    add_gaussian(img, 50.5, 50.5, 300.0, 1.0);
    add_gaussian(img, 58.5, 50.5, 300.0, 1.0);   // gap between the two boxes: about 3 px
    add_gaussian(img, 150.5, 50.5, 300.0, 1.0);  // far away
    auto o = opts();
    o.merge_radius = 6.0;
    const Detection merged = Detector(o).detect(img);
    ASSERT_EQ(merged.sources.size(), 2u);
    EXPECT_EQ(merged.sources[0].members, 2);
    EXPECT_NEAR(merged.sources[0].x, 54.5, 0.01);
    o.merge_radius = 1.0;
    EXPECT_EQ(Detector(o).detect(img).sources.size(), 3u);
}

TEST(Detector, RelativeThresholdFollowsTheMedian) {
    cv::Mat img = flat_frame(200, 200, 0.5f);  // median 0.5 -> +6ev = 32, low threshold 16
    add_gaussian(img, 50.3, 50.3, 50.0, 1.5);
    add_gaussian(img, 150.3, 150.3, 25.0, 1.5);  // between the low and the birth threshold
    add_gaussian(img, 150.3, 50.3, 12.0, 1.5);   // below both
    auto o = opts();
    o.threshold = Threshold::parse("+6ev");
    const Detection d = Detector(o).detect(img);
    EXPECT_NEAR(d.stats.median_luminance, 0.5, 0.5 * 0.05);  // 1/16-stop histogram bins
    EXPECT_NEAR(d.stats.threshold, 32.0, 32.0 * 0.05);
    ASSERT_EQ(d.sources.size(), 2u);  // the 25 one is a candidate, reported for tracks to continue on
    EXPECT_GE(d.sources[0].peak, d.stats.threshold);
    EXPECT_LT(d.sources[1].peak, d.stats.threshold);
    EXPECT_GE(d.sources[1].peak, d.stats.low_threshold);
}

TEST(Detector, BudgetKeepsTheBrightestAndSkipsInvisibleSources) {
    cv::Mat img = flat_frame(300, 100, 0.0f);
    for (int i = 0; i < 10; ++i) add_gaussian(img, 15.5 + 28.0 * i, 50.5, 100.0 * (i + 1), 1.2);
    add_gaussian(img, 150.5, 85.5, 25.0, 0.5);  // tiny: far below 1e-3 of the frame
    auto o = opts();
    o.max_lights = 4;
    o.visibility = 1e-3;
    const Detection d = Detector(o).detect(img);
    ASSERT_EQ(d.sources.size(), 4u);
    EXPECT_EQ(d.stats.dropped_budget, 6);
    EXPECT_EQ(d.stats.dropped_invisible, 1);
    for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(d.sources[i].x, 15.5 + 28.0 * (9 - static_cast<double>(i)), 0.01);
    for (std::size_t i = 1; i < 4; ++i) EXPECT_GT(d.sources[i - 1].luminous_flux, d.sources[i].luminous_flux);
}

TEST(Detector, ClippedFlatTopsAreFlagged) {
    cv::Mat img = flat_frame(200, 100, 0.0f);
    add_gaussian(img, 50.3, 50.6, 3000.0, 3.0);
    add_gaussian(img, 150.3, 50.6, 3000.0, 3.0);
    cv::Mat right = img(cv::Rect(100, 0, 100, 100));
    cv::min(right, cv::Scalar(400.0, 400.0, 400.0), right);  // a sensor that clipped at 400
    const Detection d = Detector(opts()).detect(img);
    ASSERT_EQ(d.sources.size(), 2u);
    const Source& clipped = d.sources[0].x > 100.0 ? d.sources[0] : d.sources[1];
    const Source& clean = d.sources[0].x > 100.0 ? d.sources[1] : d.sources[0];
    EXPECT_TRUE(clipped.clipped);
    EXPECT_FALSE(clean.clipped);
    auto o = opts();
    o.clip_level = 2500.0;  // told where the camera clips: the unclipped one reaches it too
    const Detection d2 = Detector(o).detect(img);
    EXPECT_TRUE(d2.sources[0].clipped && d2.sources[1].clipped);
}

TEST(Detector, ExtendedSourceKeepsANormalisedShape) {
    cv::Mat img = flat_frame(300, 200, 0.1f);
    img(cv::Rect(100, 80, 90, 30)).setTo(cv::Scalar(50.0, 50.0, 50.0));  // a uniform 90 x 30 window
    const Detection d = Detector(opts()).detect(img);
    ASSERT_EQ(d.sources.size(), 1u);
    const Source& s = d.sources[0];
    EXPECT_DOUBLE_EQ(s.x, 145.0);
    EXPECT_DOUBLE_EQ(s.y, 95.0);
    EXPECT_EQ(s.pixel_count, 2700);
    // Uniform n-pixel run: variance (n^2 - 1) / 12; semi-axis = 2 sigma.
    EXPECT_NEAR(s.extent.major, 2.0 * std::sqrt((90.0 * 90.0 - 1.0) / 12.0), 1e-6);
    EXPECT_NEAR(s.extent.minor, 2.0 * std::sqrt((30.0 * 30.0 - 1.0) / 12.0), 1e-6);
    EXPECT_NEAR(s.extent.angle_deg, 0.0, 1e-6);
    EXPECT_TRUE(s.clipped);  // a flat top
    ASSERT_TRUE(s.shape.has_value());
    const Shape& sh = *s.shape;
    EXPECT_LE(std::max(sh.width, sh.height), 32);
    EXPECT_EQ(sh.cell, 3.0);
    EXPECT_EQ(sh.width, 30);
    EXPECT_EQ(sh.height, 10);
    double sum = 0.0;
    for (float w : sh.weights) sum += static_cast<double>(w);
    EXPECT_NEAR(sum, 1.0, 1e-6);
    EXPECT_DOUBLE_EQ(s.x + sh.origin_x, 100.0);
    EXPECT_DOUBLE_EQ(s.y + sh.origin_y, 80.0);
}

TEST(Detector, ManyTinyLightsAreClusteredConservingFluxAndCentroid) {
    cv::Mat img = flat_frame(1000, 600, 0.05f);
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> ux(5, 994), uy(5, 594);
    std::uniform_real_distribution<double> up(30.0, 300.0);
    double total = 0.0, mx = 0.0, my = 0.0;
    for (int i = 0; i < 500; ++i) {
        const int x = ux(rng), y = uy(rng);
        auto& p = img.at<cv::Vec3f>(y, x);
        if (p[0] > 1.0f) continue;
        const double v = up(rng);
        p = cv::Vec3f(static_cast<float>(v), static_cast<float>(v), static_cast<float>(v));
        total += static_cast<double>(p[0]);
        mx += static_cast<double>(p[0]) * (x + 0.5);
        my += static_cast<double>(p[0]) * (y + 0.5);
    }
    auto o = opts();
    o.max_lights = 10000;
    o.visibility = 0.0;
    o.merge_radius = 0.0;
    const Detection d = Detector(o).detect(img);
    EXPECT_TRUE(d.stats.clustered);
    EXPECT_GT(d.stats.components, 400);
    EXPECT_LE(d.sources.size(), 32u * 20u + 32u);  // at most one source per grid cell
    double f = 0.0, sx = 0.0, sy = 0.0;
    int members = 0;
    for (const Source& s : d.sources) {
        f += s.flux[0];
        members += s.members;
        // Centroids are weighted by luminance above the low threshold; here every light is a single pixel.
        sx += s.x * s.flux[0];
        sy += s.y * s.flux[0];
    }
    EXPECT_EQ(members, d.stats.components);
    EXPECT_NEAR(f, total, 1e-9 * total);
    EXPECT_NEAR(sx / f, mx / total, 5.0);  // weights differ (L vs L - T) but the picture is the same
    EXPECT_NEAR(sy / f, my / total, 5.0);
}

TEST(Detector, OffsetsMoveSourcesIntoDisplayCoordinates) {
    cv::Mat img = flat_frame(100, 100, 0.0f);
    add_gaussian(img, 40.25, 30.75, 400.0, 1.0);
    ImageView v = view_of(img);
    v.x_offset = 1000;
    v.y_offset = -20;
    Detector det(opts());
    const Detection d = det.detect(v);
    ASSERT_EQ(d.sources.size(), 1u);
    EXPECT_NEAR(d.sources[0].x, 1040.25, 0.01);
    EXPECT_NEAR(d.sources[0].y, 10.75, 0.01);
    EXPECT_GE(d.sources[0].bbox[0], 1030);
    EXPECT_LE(d.sources[0].bbox[3], 20);
}

TEST(Detector, RgbaRowsWithPaddingAreRead) {
    cv::Mat big = cv::Mat::zeros(120, 140, CV_32FC4);
    cv::Mat img = big(cv::Rect(10, 10, 100, 100));  // row stride larger than the width
    cv::Mat rgb = flat_frame(100, 100, 0.0f);
    add_gaussian(rgb, 40.25, 30.75, 400.0, 1.0);
    for (int y = 0; y < 100; ++y)
        for (int x = 0; x < 100; ++x) {
            const auto p = rgb.at<cv::Vec3f>(y, x);
            img.at<cv::Vec4f>(y, x) = cv::Vec4f(p[0], p[1], p[2], 0.0f);  // alpha 0 on emitters, as in CandleGlass
        }
    const Detection d = Detector(opts()).detect(img);
    ASSERT_EQ(d.sources.size(), 1u);
    EXPECT_NEAR(d.sources[0].x, 40.25, 0.01);
}

TEST(Detector, RejectsBadInputAndOptions) {
    Detector det(opts());
    EXPECT_THROW((void)det.detect(cv::Mat(10, 10, CV_8UC3)), std::invalid_argument);
    EXPECT_THROW((void)det.detect(ImageView{}), std::invalid_argument);
    auto o = opts();
    o.downsample = 0;
    EXPECT_THROW(Detector{o}, std::invalid_argument);
    o = opts();
    o.visibility = 1.5;
    EXPECT_THROW(Detector{o}, std::invalid_argument);
}
