// Tracking on moving-light sequences made from real frames: a crop panned with sub-pixel steps across
// StageEnvLatLong (a stage lamp), an occlusion, and a cut to another picture.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <detect/detector.h>
#include <detect/track_file.h>
#include <detect/tracker.h>

#include "exr_io.h"

using namespace lensfx::detect;
using namespace lensfx::detect::test;

namespace {

constexpr int kW = 480, kH = 270;

// The kW x kH crop whose top-left corner is at (ox, oy) in the source (bilinear, sub-pixel).
cv::Mat crop(const cv::Mat& src, double ox, double oy) {
    cv::Mat out;
    // getRectSubPix puts pixel centres at integer coordinates; ours are at i + 0.5.
    cv::getRectSubPix(src, cv::Size(kW, kH), cv::Point2f(static_cast<float>(ox + (kW - 1) / 2.0), static_cast<float>(oy + (kH - 1) / 2.0)),
                      out, CV_32F);
    return out;
}

struct Pan {
    double ox0 = 330.0, oy0 = 20.0, vx = 1.37, vy = 0.23;
    [[nodiscard]] double ox(int f) const { return ox0 + vx * f; }
    [[nodiscard]] double oy(int f) const { return oy0 + vy * f; }
};

struct SeqRun {
    std::vector<std::vector<Light>> lights;  // per frame
    std::vector<bool> cuts;
};

SeqRun track(const std::vector<cv::Mat>& frames, const DetectorOptions& dopt, const TrackerOptions& topt = {}) {
    Detector det(dopt);
    Tracker tr(topt);
    SeqRun r;
    for (const cv::Mat& f : frames) {
        r.lights.push_back(tr.update(det.detect(f)));
        r.cuts.push_back(tr.last_was_cut());
    }
    return r;
}

// Frames where each id is present.
std::map<int, std::vector<int>> presence(const SeqRun& r) {
    std::map<int, std::vector<int>> p;
    for (std::size_t f = 0; f < r.lights.size(); ++f)
        for (const Light& l : r.lights[f]) p[l.id].push_back(static_cast<int>(f));
    return p;
}

// Flicker events: a track that vanished and came back, a track whose weight dipped and recovered, or a new
// id born within 3 px of where a light was during the previous 5 frames.
int blinks(const SeqRun& r) {
    int n = 0;
    for (const auto& [id, frames] : presence(r))
        for (std::size_t i = 1; i < frames.size(); ++i) n += frames[i] != frames[i - 1] + 1;
    std::map<int, double> last_weight;
    std::map<int, bool> dipped;
    std::set<int> seen;
    for (std::size_t f = 0; f < r.lights.size(); ++f)
        for (const Light& l : r.lights[f]) {
            if (last_weight.count(l.id) && l.weight < last_weight[l.id]) dipped[l.id] = true;
            if (last_weight.count(l.id) && l.weight > last_weight[l.id] && dipped[l.id]) {
                ++n;
                dipped[l.id] = false;
            }
            last_weight[l.id] = l.weight;
            if (seen.insert(l.id).second && f > 0) {
                bool near_old = false;
                for (std::size_t g = f >= 5 ? f - 5 : 0; g < f; ++g)
                    for (const Light& old : r.lights[g]) near_old = near_old || (old.id != l.id && std::hypot(old.x - l.x, old.y - l.y) < 3.0);
                n += near_old;
            }
        }
    return n;
}

class PanSequence : public ::testing::Test {
protected:
    void SetUp() override {
        const auto path = hdr_dir() / "MultiResolution/StageEnvLatLong.exr";
        LENSFX_REQUIRE_DATA(path);
        full_ = read_rgb(path).rgb;
        for (int f = 0; f < 36; ++f) frames_.push_back(crop(full_, pan_.ox(f), pan_.oy(f)));
        // The lamp: the brightest source of the whole picture, measured there.
        DetectorOptions o;
        const Detection d = Detector(o).detect(full_);
        lamp_ = d.sources.front();
        for (const Source& s : d.sources)
            if (s.peak > lamp_.peak) lamp_ = s;
    }
    // The track following the lamp in frame f (nearest to its true place).
    static const Light* near(const std::vector<Light>& lights, double x, double y) {
        const Light* best = nullptr;
        for (const Light& l : lights)
            if (!best || std::hypot(l.x - x, l.y - y) < std::hypot(best->x - x, best->y - y)) best = &l;
        return best && std::hypot(best->x - x, best->y - y) < 5.0 ? best : nullptr;
    }
    cv::Mat full_;
    std::vector<cv::Mat> frames_;
    Pan pan_;
    Source lamp_;
};

}  // namespace

TEST_F(PanSequence, LampKeepsOneIdAndMovesSmoothly) {
    const SeqRun r = track(frames_, DetectorOptions{});
    std::set<int> ids;
    std::vector<double> xs, ys;
    double worst = 0.0;
    for (int f = 0; f < static_cast<int>(frames_.size()); ++f) {
        const double tx = lamp_.x - pan_.ox(f), ty = lamp_.y - pan_.oy(f);
        const Light* l = near(r.lights[static_cast<std::size_t>(f)], tx, ty);
        ASSERT_NE(l, nullptr) << "lamp lost at frame " << f;
        ids.insert(l->id);
        EXPECT_DOUBLE_EQ(l->weight, 1.0);
        xs.push_back(l->x);
        ys.push_back(l->y);
        if (f >= 2) worst = std::max(worst, std::hypot(l->x - tx, l->y - ty));
    }
    double jerk = 0.0;
    for (std::size_t f = 1; f + 1 < xs.size(); ++f)
        jerk = std::max(jerk, std::hypot(xs[f + 1] - 2.0 * xs[f] + xs[f - 1], ys[f + 1] - 2.0 * ys[f] + ys[f - 1]));
    std::printf("pan: lamp at (%.2f, %.2f) in the full frame; tracked vs true position: worst %.2g px; worst 2nd difference %.2g px; "
                "%zu ids over the shot\n",
                lamp_.x, lamp_.y, worst, jerk, presence(r).size());
    EXPECT_EQ(ids.size(), 1u);
    EXPECT_LT(worst, 0.25);
    EXPECT_LT(jerk, 0.1);
}

TEST_F(PanSequence, NoBlinkingNearTheThresholdThanksToHysteresis) {
    // The threshold at the median peak of an unclipped light well inside the first frame, so that the
    // resampling of the pan pushes its peak across the threshold and back.
    const Detection first = Detector(DetectorOptions{}).detect(frames_[0]);
    const auto inside = std::find_if(first.sources.begin(), first.sources.end(), [](const Source& s) {
        return !s.clipped && s.bbox[0] > 40 && s.bbox[1] > 40 && s.bbox[2] < kW - 40 && s.bbox[3] < kH - 40;
    });
    ASSERT_NE(inside, first.sources.end());
    const double x0 = inside->x + pan_.ox(0), y0 = inside->y + pan_.oy(0);  // in the full frame
    std::vector<double> peaks;
    for (std::size_t f = 0; f < frames_.size(); ++f) {
        const Detection d = Detector(DetectorOptions{}).detect(frames_[f]);
        for (const Source& s : d.sources)
            if (std::hypot(s.x + pan_.ox(static_cast<int>(f)) - x0, s.y + pan_.oy(static_cast<int>(f)) - y0) < 5.0) peaks.push_back(s.peak);
    }
    ASSERT_EQ(peaks.size(), frames_.size());
    std::sort(peaks.begin(), peaks.end());
    DetectorOptions with;
    with.threshold = Threshold{Threshold::Kind::Absolute, peaks[peaks.size() / 2]};
    with.visibility = 0.0;  // this test is about the threshold alone
    DetectorOptions without = with;
    without.hysteresis_ev = 0.0;
    const SeqRun a = track(frames_, with), b = track(frames_, without);
    std::printf("pan, threshold %.1f (peaks of that light %.1f-%.1f): %d flicker events with 1 stop of hysteresis, %d without\n",
                with.threshold.value, peaks.front(), peaks.back(), blinks(a), blinks(b));
    EXPECT_EQ(blinks(a), 0);
    EXPECT_GT(blinks(b), 0);  // the sequence does exercise the threshold
}

TEST_F(PanSequence, TwoFrameOcclusionKeepsTheLampsId) {
    std::vector<cv::Mat> frames = frames_;
    for (int f : {14, 15}) {
        const cv::Point c(static_cast<int>(lamp_.x - pan_.ox(f)), static_cast<int>(lamp_.y - pan_.oy(f)));
        cv::rectangle(frames[static_cast<std::size_t>(f)], cv::Rect(c.x - 20, c.y - 20, 41, 41), cv::Scalar(0.0, 0.0, 0.0), cv::FILLED);
    }
    const SeqRun r = track(frames, DetectorOptions{});
    const Light* before = near(r.lights[13], lamp_.x - pan_.ox(13), lamp_.y - pan_.oy(13));
    ASSERT_NE(before, nullptr);
    for (int f = 14; f < 20; ++f) {
        const Light* l = near(r.lights[static_cast<std::size_t>(f)], lamp_.x - pan_.ox(f), lamp_.y - pan_.oy(f));
        ASSERT_NE(l, nullptr) << "frame " << f;
        EXPECT_EQ(l->id, before->id) << "frame " << f;
        EXPECT_DOUBLE_EQ(l->weight, 1.0);
    }
}

TEST_F(PanSequence, CutToAnotherPictureResetsTracking) {
    const auto candle = hdr_dir() / "ScanLines/CandleGlass.exr";
    LENSFX_REQUIRE_DATA(candle);
    const cv::Mat other = read_rgb(candle).rgb;
    std::vector<cv::Mat> frames(frames_.begin(), frames_.begin() + 10);
    for (int f = 0; f < 5; ++f) frames.push_back(crop(other, 130.0 + 0.5 * f, 220.0));
    const SeqRun r = track(frames, DetectorOptions{});
    std::set<int> before;
    for (std::size_t f = 0; f < 10; ++f) {
        EXPECT_FALSE(r.cuts[f]) << "frame " << f;
        for (const Light& l : r.lights[f]) before.insert(l.id);
    }
    EXPECT_TRUE(r.cuts[10]);
    for (std::size_t f = 11; f < frames.size(); ++f) EXPECT_FALSE(r.cuts[f]);
    ASSERT_EQ(r.lights[10].size(), 1u);  // the flame, at full weight at once
    EXPECT_EQ(before.count(r.lights[10][0].id), 0u);
    EXPECT_DOUBLE_EQ(r.lights[10][0].weight, 1.0);
}

TEST_F(PanSequence, TrackFileRendersAnyFrameRangeLikeTheWholeShot) {
    Detector det{DetectorOptions{}};
    Tracker tr;
    TrackFile file;
    file.width = kW;
    file.height = kH;
    std::vector<std::vector<Light>> live;
    for (std::size_t f = 0; f < frames_.size(); ++f) {
        live.push_back(tr.update(det.detect(frames_[f])));
        file.append(static_cast<int>(f) + 1, live.back());
    }
    const TrackFile back = parse_track_json(to_json_text(file), "pan.json");
    for (int f = 20; f <= 30; ++f) EXPECT_EQ(back.lights_at(f), live[static_cast<std::size_t>(f - 1)]) << "frame " << f;
}
