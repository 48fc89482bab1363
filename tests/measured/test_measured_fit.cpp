// The fit against synthetic sweeps (issue 19): a physical lens the fit is not told about is rendered by the
// GPU ghost renderer over a sweep, with a background level and sensor noise; the fitted measured lens is
// compared with the physical one between the sweep's angles and off the meridian.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <array>
#include <cstdio>
#include <functional>
#include <numeric>
#include <random>
#include <vector>

#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <measured/fit.h>
#include <measured/model_file.h>
#include <measured/predict.h>
#include <optics/lens_file.h>
#include <optics/presets.h>
#include <optics/system.h>

namespace lensfx::measured {
namespace {

constexpr int kImageWidth = 240, kImageHeight = 160;
constexpr double kSensorW = 72.0, kSensorH = 48.0;

flare::FlareView view_at(double ax, double ay) {
    flare::FlareView v;
    v.angle_x_deg = ax, v.angle_y_deg = ay;
    v.sensor_width_mm = kSensorW, v.sensor_height_mm = kSensorH;
    v.width = kImageWidth, v.height = kImageHeight;
    return v;
}

struct Truth {
    gpu::Context context{gpu::Platform::Surfaceless};
    optics::System system = optics::realize(optics::load_preset("petzval-kodak"), 0.0);
    gpu::FlareRenderer renderer{context};
    std::vector<float> render(double ax, double ay) { return renderer.render(system, view_at(ax, ay), gpu::GpuFlareOptions{}).rgb; }
};

// The sweep 0..16 degrees by 1 with a background of 1e-4 and noise of sigma 2e-5 (the disc ghost peaks near 1e-3).
std::vector<SweepFrame> sweep(Truth& truth) {
    std::mt19937_64 random(19);
    std::normal_distribution<double> noise(0.0, 2e-5);
    std::vector<SweepFrame> frames;
    for (int i = 0; i <= 16; ++i) {
        SweepFrame f{kImageWidth, kImageHeight, truth.render(i, 0.0), static_cast<double>(i)};
        for (float& v : f.rgb) v = static_cast<float>(static_cast<double>(v) + 1e-4 + noise(random));
        frames.push_back(std::move(f));
    }
    return frames;
}

// sum over 8x8 blocks of |fit - true| (each block's sum, all channels) over the true image's sum.
double block_l1(const std::vector<float>& fit, const std::vector<float>& truth) {
    double diff = 0.0, total = 0.0;
    for (int by = 0; by < kImageHeight; by += 8)
        for (int bx = 0; bx < kImageWidth; bx += 8)
            for (int c = 0; c < 3; ++c) {
                double a = 0.0, b = 0.0;
                for (int y = by; y < std::min(by + 8, kImageHeight); ++y)
                    for (int x = bx; x < std::min(bx + 8, kImageWidth); ++x) {
                        const std::size_t i = static_cast<std::size_t>((y * kImageWidth + x) * 3 + c);
                        a += static_cast<double>(fit[i]), b += static_cast<double>(truth[i]);
                    }
                diff += std::abs(a - b), total += b;
            }
    return diff / total;
}

double sum(const std::vector<float>& v) { return std::accumulate(v.begin(), v.end(), 0.0, [](double s, float x) { return s + static_cast<double>(x); }); }

std::vector<double> ranks(const std::vector<double>& v) {
    std::vector<std::size_t> order(v.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
    std::vector<double> r(v.size());
    for (std::size_t i = 0; i < order.size(); ++i) r[order[i]] = static_cast<double>(i);
    return r;
}

double spearman(const std::vector<double>& a, const std::vector<double>& b) {
    const std::vector<double> ra = ranks(a), rb = ranks(b);
    double d2 = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) d2 += (ra[i] - rb[i]) * (ra[i] - rb[i]);
    const double n = static_cast<double>(a.size());
    return 1.0 - 6.0 * d2 / (n * (n * n - 1.0));
}

class MeasuredFit : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        truth_ = new Truth();
        FitOptions o;
        o.focal_length_mm = 100.0;  // what the photographer knows: the lens's nominal focal length
        o.sensor_width_mm = kSensorW, o.sensor_height_mm = kSensorH;
        fit_ = new FitResult(fit_sweep(sweep(*truth_), o));
    }
    static void TearDownTestSuite() {
        delete fit_;
        delete truth_;
    }
    static std::vector<float> fitted(double ax, double ay) {
        std::vector<float> rgb(static_cast<std::size_t>(kImageWidth * kImageHeight * 3), 0.0f);
        render_add(fit_->lens, MeasuredView{ax, ay, kSensorW, kSensorH, kImageWidth, kImageHeight}, {1, 1, 1}, rgb.data());
        return rgb;
    }
    static Truth* truth_;
    static FitResult* fit_;
};
Truth* MeasuredFit::truth_ = nullptr;
FitResult* MeasuredFit::fit_ = nullptr;

void finds_ghosts_and_reports_every_frame(const FitResult& fit) {
    EXPECT_GE(fit.lens.ghosts.size(), 1u);
    EXPECT_EQ(fit.frames.size(), 17u);
    // The black level is 1e-4, under the petzval's wide faint ghosts that cover most of every frame.
    for (const FrameFit& f : fit.frames) EXPECT_NEAR(f.background, 1e-4, 3e-6) << f.angle_deg;
}

// Issue 19's "done when" against the physical lens: between the sweep's samples and off the meridian, the
// fitted ghosts within 35% relative L1 in 8x8 blocks and 15% total power.
void ghosts_between_samples_and_off_the_meridian(Truth& truth_, const std::function<std::vector<float>(double, double)>& fitted) {
    for (const auto& [ax, ay] : {std::pair{8.5, 0.0}, std::pair{11.5, 0.0}, std::pair{6.0, 6.5}, std::pair{-7.0, 8.0}}) {
        const std::vector<float> truth = truth_.render(ax, ay), fit = fitted(ax, ay);
        const double l1 = block_l1(fit, truth), power = std::abs(sum(fit) - sum(truth)) / sum(truth);
        std::printf("light (%g, %g): relative L1 (8x8 blocks) %.3f, total power error %.3f (fit %.4g, true %.4g)\n", ax, ay, l1, power, sum(fit), sum(truth));
        EXPECT_LT(l1, 0.35) << ax << "," << ay;
        EXPECT_LT(power, 0.15) << ax << "," << ay;
    }
}

void predicted_total_ranks_like_the_physical_ghost_power(Truth& truth_, const std::function<std::vector<float>(double, double)>& fitted) {
    std::vector<double> predicted, physical;
    for (double a = 0.0; a <= 16.0; a += 1.0) {  // the sweep's whole range (the model does not reach beyond it)
        const std::vector<float> fit = fitted(a, 0.0);
        const std::vector<float> truth = truth_.render(a, 0.0);
        predicted.push_back(estimate(fit, kImageWidth, kImageHeight, {1e-3f}, 1.0).total);
        physical.push_back(sum(truth));
    }
    const double rho = spearman(predicted, physical);
    std::printf("Spearman of the predicted total against the physical ghost power, 0..16 deg: %.3f\n", rho);
    EXPECT_GE(rho, 0.9);
}

// One fit of the sweep (a minute under the sanitizers) for all three checks.
TEST_F(MeasuredFit, MatchesThePhysicalLensBetweenSamplesAndOffTheMeridian) {
    {
        SCOPED_TRACE("finds ghosts and reports every frame");
        finds_ghosts_and_reports_every_frame(*fit_);
    }
    {
        SCOPED_TRACE("ghosts between samples and off the meridian");
        ghosts_between_samples_and_off_the_meridian(*truth_, fitted);
    }
    {
        SCOPED_TRACE("predicted total ranks like the physical ghost power");
        predicted_total_ranks_like_the_physical_ghost_power(*truth_, fitted);
    }
}

// The fit's own machinery on a sweep rendered from a known measured lens (two ghosts that change size and
// colour with the angle: one crossing the light's neighbourhood, one on the far side of the centre; both
// concentric near 0 degrees), with the same background and noise.
struct KnownSweep {
    MeasuredLens known;
    FitResult fit;
    std::vector<float> render(const MeasuredLens& lens, double ax, double ay) const {
        std::vector<float> rgb(static_cast<std::size_t>(kImageWidth * kImageHeight * 3), 0.0f);
        render_add(lens, MeasuredView{ax, ay, kSensorW, kSensorH, kImageWidth, kImageHeight}, {1, 1, 1}, rgb.data());
        return rgb;
    }
    KnownSweep() {
        known.focal_length_mm = 100.0;
        const std::array<std::array<double, 3>, 2> positions{{{-1.0, -1.2, 0.0}, {0.0, 1.9, 0.01}}};
        for (std::size_t k = 0; k < 2; ++k) {
            MeasuredGhost g;
            g.angle_min_deg = 0.0, g.angle_max_deg = 16.0;
            const GhostParams p = disc_ghost(0.0, k == 0 ? 3.0 : 4.5, {k == 0 ? 8e-4 : 3e-4, 5e-4, k == 0 ? 3e-4 : 9e-4});
            for (int i = 0; i < kParamCount; ++i) g.poly[static_cast<std::size_t>(i)] = {p[i], 0.0, 0.0};
            g.poly[kPosition] = positions[k];
            g.poly[kRight] = {p[kRight], 0.08, 0.0};
            g.poly[kFallOutside] = {0.6, 0.0, 0.0};
            g.poly[kInsideG] = {5e-4, -1.5e-5, 0.0};
            known.ghosts.push_back(g);
        }
        std::mt19937_64 random(7);
        std::normal_distribution<double> noise(0.0, 2e-5);
        std::vector<SweepFrame> frames;
        for (int i = 0; i <= 16; i += 2) {
            SweepFrame f{kImageWidth, kImageHeight, render(known, i, 0.0), static_cast<double>(i)};
            for (float& v : f.rgb) v = static_cast<float>(static_cast<double>(v) + 1e-4 + noise(random));
            frames.push_back(std::move(f));
        }
        FitOptions o;
        o.focal_length_mm = 100.0, o.sensor_width_mm = kSensorW, o.sensor_height_mm = kSensorH;
        fit = fit_sweep(frames, o);
    }
};

// The ghost on the far side of the centre is found, tracked and turned into polynomials that place and
// size it between the sweep's samples (7 and 11 degrees; the sweep has 0, 2, ... 16).
void recovers_the_separate_ghost_between_samples(const KnownSweep& s) {
    ASSERT_GE(s.fit.lens.ghosts.size(), 1u);
    for (double angle : {7.0, 11.0}) {
        const GhostParams truth = s.known.ghosts[0].at(angle);
        const MeasuredGhost* nearest = nullptr;
        for (const MeasuredGhost& g : s.fit.lens.ghosts)
            if (g.covers(angle) && (!nearest || std::abs(g.at(angle)[kPosition] - truth[kPosition]) < std::abs(nearest->at(angle)[kPosition] - truth[kPosition])))
                nearest = &g;
        ASSERT_NE(nearest, nullptr) << angle;
        const GhostParams p = nearest->at(angle);
        // M, L and R are redundant along the axis: compare the ends and the height.
        EXPECT_NEAR(p[kPosition] - p[kLeft], truth[kPosition] - truth[kLeft], 0.6) << angle;
        EXPECT_NEAR(p[kPosition] + p[kRight], truth[kPosition] + truth[kRight], 0.6) << angle;
        EXPECT_NEAR(p[kHeight], truth[kHeight], 0.6) << angle;
        EXPECT_NEAR(p[kInsideR] / p[kInsideB], truth[kInsideR] / truth[kInsideB], 0.3 * truth[kInsideR] / truth[kInsideB]) << angle;
    }
}

// Issue 19's bounds on the known model: every ghost, between samples and off the meridian.
void recovers_all_ghosts_within_issue_bounds(const KnownSweep& s) {
    for (const auto& [ax, ay] : {std::pair{7.0, 0.0}, std::pair{11.0, 0.0}, std::pair{5.0, 6.0}, std::pair{-6.0, 7.0}}) {
        const std::vector<float> truth = s.render(s.known, ax, ay), fitted = s.render(s.fit.lens, ax, ay);
        const double l1 = block_l1(fitted, truth), power = std::abs(sum(fitted) - sum(truth)) / sum(truth);
        std::printf("known model, light (%g, %g): relative L1 (8x8 blocks) %.3f, total power error %.3f\n", ax, ay, l1, power);
        EXPECT_LT(l1, 0.35) << ax << "," << ay;
        EXPECT_LT(power, 0.15) << ax << "," << ay;
    }
}

// One fit of the known sweep for both checks.
TEST(MeasuredFitKnownModel, RecoversTheGhostsBetweenSamplesWithinIssueBounds) {
    const KnownSweep s;
    {
        SCOPED_TRACE("the separate ghost between samples");
        recovers_the_separate_ghost_between_samples(s);
    }
    {
        SCOPED_TRACE("all ghosts within the issue's bounds");
        recovers_all_ghosts_within_issue_bounds(s);
    }
}

}  // namespace
}  // namespace lensfx::measured
