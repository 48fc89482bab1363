// Tracking: association, smoothing without lag, fades, hysteresis, coasting, cuts, determinism.
#include <cmath>
#include <map>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include <detect/detector.h>
#include <detect/tracker.h>

#include "synth.h"

using namespace lensfx::detect;
using namespace lensfx::detect::test;

namespace {

std::vector<float> flat_histogram() {
    std::vector<float> h(33, 0.0f);
    h[15] = 1.0f;
    return h;
}

Source point(double x, double y, double flux, double peak) {
    Source s;
    s.x = x;
    s.y = y;
    s.flux = {flux, flux, flux};
    s.luminous_flux = flux;
    s.peak = peak;
    s.extent = {1.0, 1.0, 0.0};
    return s;
}

Detection frame(std::vector<Source> sources, double threshold = 20.0) {
    Detection d;
    d.sources = std::move(sources);
    d.stats.width = 640;
    d.stats.height = 480;
    d.stats.threshold = threshold;
    d.stats.low_threshold = threshold / 2.0;
    d.stats.histogram = flat_histogram();
    return d;
}

}  // namespace

TEST(Tracker, FollowsASmoothlyMovingRenderedLightWithoutLag) {
    DetectorOptions dopt;
    Detector det(dopt);
    Tracker tr;
    const double vx = 0.37, vy = -0.21;
    std::set<int> ids;
    double worst = 0.0;
    for (int f = 0; f < 60; ++f) {
        const double cx = 40.3 + vx * f, cy = 90.8 + vy * f;
        cv::Mat img = flat_frame(160, 120, 0.02f);
        add_gaussian(img, cx, cy, 900.0, 1.6);
        const auto lights = tr.update(det.detect(img));
        ASSERT_EQ(lights.size(), 1u) << "frame " << f;
        ids.insert(lights[0].id);
        EXPECT_DOUBLE_EQ(lights[0].weight, 1.0);  // present from the first frame: no fade-in
        if (f >= 2) worst = std::max(worst, std::hypot(lights[0].x - cx, lights[0].y - cy));
    }
    EXPECT_EQ(ids.size(), 1u);
    EXPECT_LT(worst, 0.02) << "largest distance between tracked and true position (px)";
}

TEST(Tracker, SmoothsJitterAndFlux) {
    Tracker tr;
    double err_raw = 0.0, err_tracked = 0.0;
    for (int f = 0; f < 80; ++f) {
        const double jitter = ((f * 7919) % 13 - 6) / 6.0 * 0.3;  // deterministic +-0.3 px
        const double fl = 1000.0 * (1.0 + 0.05 * (((f * 104729) % 7) - 3) / 3.0);
        const auto lights = tr.update(frame({point(100.0 + 0.5 * f + jitter, 200.0, fl, 100.0)}));
        ASSERT_EQ(lights.size(), 1u);
        if (f >= 10) {
            err_raw += std::abs(jitter);
            err_tracked += std::abs(lights[0].x - (100.0 + 0.5 * f));
        }
    }
    EXPECT_LT(err_tracked, 0.8 * err_raw);
}

TEST(Tracker, BirthMidShotFadesInAndDeathFadesOutAfterCoasting) {
    TrackerOptions o;
    o.fade_in_frames = 4;
    o.fade_out_frames = 4;
    o.coast_frames = 2;
    Tracker tr(o);
    EXPECT_TRUE(tr.update(frame({})).empty());  // shot starts without the light
    std::vector<double> weights;
    for (int f = 0; f < 6; ++f) {
        const auto l = tr.update(frame({point(300.0 + f, 100.0, 500.0, 60.0)}));
        ASSERT_EQ(l.size(), 1u);
        weights.push_back(l[0].weight);
    }
    EXPECT_EQ(weights, (std::vector<double>{0.25, 0.5, 0.75, 1.0, 1.0, 1.0}));
    weights.clear();
    for (int f = 0; f < 8; ++f) {
        const auto l = tr.update(frame({}));
        weights.push_back(l.empty() ? 0.0 : l[0].weight);
        if (!l.empty()) {
            EXPECT_NEAR(l[0].x, 306.0 + f, 1e-9);  // coasts on at its velocity
        }
    }
    EXPECT_EQ(weights, (std::vector<double>{1.0, 1.0, 0.75, 0.5, 0.25, 0.0, 0.0, 0.0}));
}

TEST(Tracker, ShortOcclusionKeepsTheId) {
    Tracker tr;
    int id = -1;
    for (int f = 0; f < 30; ++f) {
        const bool hidden = f == 12 || f == 13;
        const auto l = tr.update(frame(hidden ? std::vector<Source>{} : std::vector<Source>{point(50.0 + 1.5 * f, 60.0, 800.0, 90.0)}));
        ASSERT_EQ(l.size(), 1u) << "frame " << f;
        if (id < 0) id = l[0].id;
        EXPECT_EQ(l[0].id, id) << "frame " << f;
        EXPECT_DOUBLE_EQ(l[0].weight, 1.0);
        EXPECT_NEAR(l[0].x, 50.0 + 1.5 * f, 1e-6);
    }
}

TEST(Tracker, HysteresisStopsBlinkingNearTheThreshold) {
    Tracker tr;
    std::set<int> ids;
    int present = 0;
    for (int f = 0; f < 40; ++f) {
        const double peak = 20.0 + 4.0 * std::sin(f * 1.3);  // around the birth threshold 20, above the low 10
        const auto l = tr.update(frame({point(200.0, 200.0, 10.0 * peak, peak)}));
        if (!l.empty()) {
            ++present;
            ids.insert(l[0].id);
            EXPECT_DOUBLE_EQ(l[0].weight, 1.0);
        } else {
            EXPECT_EQ(present, 0) << "vanished at frame " << f;
        }
    }
    EXPECT_EQ(ids.size(), 1u);
    EXPECT_EQ(present, 40);
}

TEST(Tracker, WeakSourcesAreNotBornButStrongOnesAre) {
    Tracker tr;
    const auto l = tr.update(frame({point(10.0, 10.0, 100.0, 15.0), point(300.0, 300.0, 100.0, 25.0)}));
    ASSERT_EQ(l.size(), 1u);
    EXPECT_DOUBLE_EQ(l[0].x, 300.0);
}

TEST(Tracker, GatesByDistanceAndFlux) {
    Tracker tr;
    const int id = tr.update(frame({point(100.0, 100.0, 1000.0, 100.0)}))[0].id;
    // Too far: a new light is born and the old one coasts.
    auto l = tr.update(frame({point(200.0, 100.0, 1000.0, 100.0)}));
    ASSERT_EQ(l.size(), 2u);
    EXPECT_EQ(l[0].id, id);
    EXPECT_DOUBLE_EQ(l[0].x, 100.0);
    EXPECT_NE(l[1].id, id);
    Tracker tr2;
    const int id2 = tr2.update(frame({point(100.0, 100.0, 1000.0, 100.0)}))[0].id;
    l = tr2.update(frame({point(102.0, 100.0, 50.0, 100.0)}));  // near, but 20 times dimmer
    ASSERT_EQ(l.size(), 2u);
    EXPECT_EQ(l[0].id, id2);
    EXPECT_DOUBLE_EQ(l[0].x, 100.0);
}

TEST(Tracker, CrossingLightsOfDifferentFluxKeepTheirIds) {
    Tracker tr;
    std::map<int, std::vector<double>> xs;
    for (int f = 0; f < 40; ++f) {
        const auto l = tr.update(frame({point(100.0 + 2.0 * f, 100.0 + 0.2 * f, 5000.0, 200.0), point(180.0 - 2.0 * f, 104.0 - 0.2 * f, 600.0, 80.0)}));
        ASSERT_EQ(l.size(), 2u);
        for (const auto& li : l) xs[li.id].push_back(li.x);
    }
    ASSERT_EQ(xs.size(), 2u);
    EXPECT_NEAR(xs.begin()->second.back(), 178.0, 1e-6);
    EXPECT_NEAR(std::next(xs.begin())->second.back(), 102.0, 1e-6);
}

TEST(Tracker, CutResetsTracking) {
    Tracker tr;
    const int id = tr.update(frame({point(100.0, 100.0, 1000.0, 100.0)}))[0].id;
    (void)tr.update(frame({point(100.0, 100.0, 1000.0, 100.0)}));
    EXPECT_FALSE(tr.last_was_cut());
    Detection other = frame({point(100.0, 100.0, 1000.0, 100.0)});
    other.stats.histogram.assign(33, 0.0f);
    other.stats.histogram[5] = 1.0f;
    const auto l = tr.update(other);
    EXPECT_TRUE(tr.last_was_cut());
    ASSERT_EQ(l.size(), 1u);
    EXPECT_NE(l[0].id, id);
    EXPECT_DOUBLE_EQ(l[0].weight, 1.0);  // a light present at a cut is there at once
}

TEST(Tracker, LightLeavingTheFrameCoastsOutAndFades) {
    Tracker tr;
    std::set<int> ids;
    int last_seen = -1;
    for (int f = 0; f < 40; ++f) {
        const double x = 600.0 + 3.0 * f;
        std::vector<Source> s;
        if (x < 640.0) s.push_back(point(x, 240.0, 1000.0, 100.0));
        const auto l = tr.update(frame(s));
        for (const auto& li : l) ids.insert(li.id);
        if (!l.empty()) last_seen = f;
    }
    EXPECT_EQ(ids.size(), 1u);
    EXPECT_EQ(last_seen, 13 + 3 + 3);  // last detection at 13, 3 frames coasting, 3 fading (weight 0.75..0.25)
}

TEST(Tracker, IsDeterministic) {
    auto run = [] {
        Tracker tr;
        std::vector<std::vector<Light>> out;
        for (int f = 0; f < 30; ++f) {
            std::vector<Source> s;
            for (int k = 0; k < 6; ++k)
                if ((f + k) % 7 != 0) s.push_back(point(50.0 * k + 0.3 * f, 100.0 + k, 100.0 * (k + 1), 50.0));
            out.push_back(tr.update(frame(s)));
        }
        return out;
    };
    EXPECT_EQ(run(), run());
}
