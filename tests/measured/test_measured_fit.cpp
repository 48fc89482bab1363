// The fit against synthetic sweeps (issue 19): a physical lens the fit is not told about is rendered by the
// GPU ghost renderer over a sweep, with a background level and sensor noise; the fitted measured lens is
// compared with the physical one between the sweep's angles and off the meridian.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "synthetic_sweep.h"

namespace lensfx::measured {
namespace {

using synthetic::kImageHeight;
using synthetic::kImageWidth;

// The noise seed of the test's sweep: one the fit was never tuned on (bench/measured/seeds_measured gives
// the figures over seeds 19..26, the ones the fit was developed against).
constexpr std::uint64_t kSeed = 27;

// The sweep 0..16 degrees by 1 of petzval-kodak with a background of 1e-4 and noise of sigma 2e-5 (the disc
// ghost peaks near 1e-3), fitted once for all the checks. (A sweep to 20 degrees, where the light leaves the
// frame, meets the same bounds on 6 of the 7 seeds measured (seed 33: L1 0.361 at 11.5 degrees) and ranks
// 0..20 at 0.91-1.00, but its fit takes longer: `seeds_measured FIRST LAST 20`, docs/measured-lenses.md.)
class MeasuredFit : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        truth_ = new synthetic::PhysicalLens("petzval-kodak");
        fit_ = new FitResult(fit_sweep(synthetic::captured(synthetic::clean_sweep(*truth_, 16.0, 1.0), kSeed), synthetic::fit_options()));
    }
    static void TearDownTestSuite() {
        delete fit_;
        delete truth_;
    }
    static synthetic::PhysicalLens* truth_;
    static FitResult* fit_;
};
synthetic::PhysicalLens* MeasuredFit::truth_ = nullptr;
FitResult* MeasuredFit::fit_ = nullptr;

void finds_ghosts_and_reports_every_frame(const FitResult& fit) {
    EXPECT_GE(fit.lens.ghosts.size(), 1u);
    EXPECT_EQ(fit.frames.size(), 17u);
    // The black level is 1e-4, under the petzval's wide faint ghosts that cover most of every frame.
    for (const FrameFit& f : fit.frames) EXPECT_NEAR(f.background, 1e-4, 3e-6) << f.angle_deg;
}

// Issue 19's "done when" against the physical lens: between the sweep's samples and off the meridian, the
// fitted ghosts within 35% relative L1 in 8x8 blocks and 15% total power.
void ghosts_between_samples_and_off_the_meridian(synthetic::PhysicalLens& truth, const MeasuredLens& fitted) {
    for (const auto& [ax, ay] : synthetic::check_angles()) {
        const synthetic::Accuracy a = synthetic::accuracy_at(truth, fitted, ax, ay);
        std::printf("light (%g, %g): relative L1 (8x8 blocks) %.3f, total power error %.3f\n", ax, ay, a.l1, a.power);
        EXPECT_LT(a.l1, 0.35) << ax << "," << ay;
        EXPECT_LT(a.power, 0.15) << ax << "," << ay;
    }
}

void predicted_total_ranks_like_the_physical_ghost_power(synthetic::PhysicalLens& truth, const MeasuredLens& fitted) {
    const double rho = synthetic::predicted_rank_correlation(truth, fitted, 16.0);  // the sweep's range
    std::printf("Spearman of the predicted total against the physical ghost power, 0..16 deg: %.3f\n", rho);
    EXPECT_GE(rho, 0.9);
}

// One fit of the sweep (a minute or two under the sanitizers) for all three checks.
TEST_F(MeasuredFit, MatchesThePhysicalLensBetweenSamplesAndOffTheMeridian) {
    {
        SCOPED_TRACE("finds ghosts and reports every frame");
        finds_ghosts_and_reports_every_frame(*fit_);
    }
    {
        SCOPED_TRACE("ghosts between samples and off the meridian");
        ghosts_between_samples_and_off_the_meridian(*truth_, fit_->lens);
    }
    {
        SCOPED_TRACE("predicted total ranks like the physical ghost power");
        predicted_total_ranks_like_the_physical_ghost_power(*truth_, fit_->lens);
    }
}

// The fit's own machinery on a sweep rendered from a known measured lens (two ghosts that change size and
// colour with the angle: one crossing the light's neighbourhood, one on the far side of the centre; both
// concentric near 0 degrees), with the same background and noise.
struct KnownSweep {
    MeasuredLens known;
    FitResult fit;
    std::vector<float> render(const MeasuredLens& lens, double ax, double ay) const { return synthetic::render_fitted(lens, ax, ay); }
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
        std::vector<SweepFrame> frames;
        for (int i = 0; i <= 16; i += 2) frames.push_back({kImageWidth, kImageHeight, render(known, i, 0.0), static_cast<double>(i)});
        fit = fit_sweep(synthetic::captured(frames, 7), synthetic::fit_options());
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
        const double l1 = block_l1(fitted, truth, kImageWidth, kImageHeight), power = power_error(fitted, truth);
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
