// Frame-to-frame tracking of detected sources.
#include <detect/tracker.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>

#include <fmt/core.h>

namespace lensfx::detect {

namespace {

double luminous(const std::array<double, 3>& rgb) {
    return kRec709Luma[0] * rgb[0] + kRec709Luma[1] * rgb[1] + kRec709Luma[2] * rgb[2];
}

double critically_damped_beta(double alpha, double beta) { return beta > 0.0 ? beta : alpha * alpha / (2.0 - alpha); }

}  // namespace

void TrackerOptions::validate() const {
    auto fail = [](const char* what) { throw std::invalid_argument(fmt::format("tracker option {}", what)); };
    if (!(gate_px > 0.0)) fail("gate_px: must be positive");
    if (!(gate_flux_ratio > 1.0)) fail("gate_flux_ratio: must be > 1");
    if (!(position_alpha > 0.0 && position_alpha <= 1.0)) fail("position_alpha: must be in (0, 1]");
    if (!(flux_alpha > 0.0 && flux_alpha <= 1.0)) fail("flux_alpha: must be in (0, 1]");
    if (!(position_beta < 2.0) || !(flux_beta < 2.0)) fail("beta: must be < 2");
    if (!(extent_alpha > 0.0 && extent_alpha <= 1.0)) fail("extent_alpha: must be in (0, 1]");
    if (coast_frames < 0) fail("coast_frames: must be >= 0");
    if (fade_in_frames < 0 || fade_out_frames < 0) fail("fade frames: must be >= 0");
    if (!(cut_threshold > 0.0)) fail("cut_threshold: must be positive");
}

double histogram_distance(const std::vector<float>& a, const std::vector<float>& b) {
    if (a.size() != b.size()) return 2.0;
    double d = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) d += std::abs(static_cast<double>(a[i]) - static_cast<double>(b[i]));
    return d;
}

Tracker::Tracker(TrackerOptions options) : options_(options) { options_.validate(); }

void Tracker::reset() {
    tracks_.clear();
    previous_histogram_.clear();
    fresh_ = true;
}

std::vector<Light> Tracker::update(const Detection& detection) {
    ++frames_;
    forget_tracks_at_cut(detection.stats.histogram);
    const std::vector<Prediction> predicted = predict();
    const Association association = associate(predicted, detection.sources);
    for (std::size_t t = 0; t < tracks_.size(); ++t) {
        const int s = association.match_of_track[t];
        if (s < 0) {
            coast(tracks_[t], predicted[t]);
        } else {
            correct(tracks_[t], predicted[t], detection.sources[static_cast<std::size_t>(s)]);
        }
    }
    std::erase_if(tracks_, [](const Track& tr) { return tr.missed > 0 && tr.weight <= 0.0; });
    start_tracks(detection, association.source_taken);
    fresh_ = false;
    return visible_lights();
}

void Tracker::forget_tracks_at_cut(const std::vector<float>& histogram) {
    last_was_cut_ = !previous_histogram_.empty() && histogram_distance(previous_histogram_, histogram) > options_.cut_threshold;
    if (last_was_cut_) {
        tracks_.clear();
        fresh_ = true;
    }
    previous_histogram_ = histogram;
}

// Constant velocity, constant flux slope.
std::vector<Tracker::Prediction> Tracker::predict() const {
    std::vector<Prediction> pred(tracks_.size());
    for (std::size_t t = 0; t < tracks_.size(); ++t) {
        const Track& tr = tracks_[t];
        pred[t].x = tr.x + tr.vx;
        pred[t].y = tr.y + tr.vy;
        for (std::size_t c = 0; c < 3; ++c) pred[t].flux[c] = std::max(0.0, tr.flux[c] + tr.dflux[c]);
    }
    return pred;
}

// Greedy: gated candidate pairs, cheapest first; ties broken by track then source order.
Tracker::Association Tracker::associate(const std::vector<Prediction>& pred, const std::vector<Source>& sources) const {
    std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;
    const double log_gate = std::log(options_.gate_flux_ratio);
    for (std::size_t t = 0; t < tracks_.size(); ++t) {
        const double gate = std::max(options_.gate_px, tracks_[t].extent.major);
        const double tl = luminous(pred[t].flux);
        for (std::size_t s = 0; s < sources.size(); ++s) {
            const double d = std::hypot(sources[s].x - pred[t].x, sources[s].y - pred[t].y);
            if (d > gate) continue;
            const double ratio = std::abs(std::log(std::max(sources[s].luminous_flux, 1e-300) / std::max(tl, 1e-300)));
            if (ratio > log_gate) continue;
            pairs.emplace_back(d / gate + ratio / log_gate, t, s);
        }
    }
    std::sort(pairs.begin(), pairs.end());
    Association a{std::vector<int>(tracks_.size(), -1), std::vector<bool>(sources.size(), false)};
    for (const auto& [cost, t, s] : pairs) {
        if (a.match_of_track[t] >= 0 || a.source_taken[s]) continue;
        a.match_of_track[t] = static_cast<int>(s);
        a.source_taken[s] = true;
    }
    return a;
}

double Tracker::fade_in_step() const { return options_.fade_in_frames > 0 ? 1.0 / options_.fade_in_frames : 1.0; }

double Tracker::fade_out_step() const { return options_.fade_out_frames > 0 ? 1.0 / options_.fade_out_frames : 1.0; }

// No detection: keep moving, hold the flux; after coast_frames, fade out.
void Tracker::coast(Track& tr, const Prediction& p) const {
    tr.x = p.x;
    tr.y = p.y;
    tr.dflux = {};
    ++tr.missed;
    if (tr.missed > options_.coast_frames) tr.weight = std::max(0.0, tr.weight - fade_out_step());
}

// A detection: move the filters towards it, take its extent and shape, fade in.
void Tracker::correct(Track& tr, const Prediction& p, const Source& s) const {
    if (tr.updates == 1) {
        start_velocity(tr, s);
    } else {
        filter_motion(tr, p, s);
    }
    smooth_extent(tr.extent, s.extent, options_.extent_alpha);
    tr.clipped = s.clipped;
    tr.shape = s.shape;
    ++tr.updates;
    tr.missed = 0;
    tr.weight = std::min(1.0, tr.weight + fade_in_step());
}

// Second detection: two-point start of the velocity, so a steady motion is followed without lag.
void Tracker::start_velocity(Track& tr, const Source& s) {
    tr.vx = s.x - tr.x;
    tr.vy = s.y - tr.y;
    tr.x = s.x;
    tr.y = s.y;
    for (std::size_t c = 0; c < 3; ++c) {
        tr.dflux[c] = s.flux[c] - tr.flux[c];
        tr.flux[c] = s.flux[c];
    }
}

// Alpha-beta filters of position and flux, driven by the residual to the prediction.
void Tracker::filter_motion(Track& tr, const Prediction& p, const Source& s) const {
    const double pa = options_.position_alpha, pb = critically_damped_beta(pa, options_.position_beta);
    const double fa = options_.flux_alpha, fb = critically_damped_beta(fa, options_.flux_beta);
    const double rx = s.x - p.x, ry = s.y - p.y;
    tr.x = p.x + pa * rx;
    tr.y = p.y + pa * ry;
    tr.vx += pb * rx;
    tr.vy += pb * ry;
    for (std::size_t c = 0; c < 3; ++c) {
        const double r = s.flux[c] - p.flux[c];
        tr.flux[c] = std::max(0.0, p.flux[c] + fa * r);
        tr.dflux[c] += fb * r;
    }
}

// Exponential smoothing of the axes; the angle of an axis is modulo 180 degrees.
void Tracker::smooth_extent(Extent& e, const Extent& seen, double alpha) {
    e.major += alpha * (seen.major - e.major);
    e.minor += alpha * (seen.minor - e.minor);
    double da = seen.angle_deg - e.angle_deg;
    da -= 180.0 * std::round(da / 180.0);
    e.angle_deg = std::fmod(e.angle_deg + alpha * da + 180.0, 180.0);
}

// Births: unmatched sources whose peak reaches the birth threshold (the hysteresis upper edge).
void Tracker::start_tracks(const Detection& detection, const std::vector<bool>& source_taken) {
    const auto& sources = detection.sources;
    for (std::size_t s = 0; s < sources.size(); ++s) {
        if (source_taken[s] || sources[s].peak < detection.stats.threshold) continue;
        Track tr;
        tr.id = next_id_++;
        tr.x = sources[s].x;
        tr.y = sources[s].y;
        tr.flux = sources[s].flux;
        tr.extent = sources[s].extent;
        tr.clipped = sources[s].clipped;
        tr.shape = sources[s].shape;
        tr.weight = fresh_ ? 1.0 : fade_in_step();
        tr.updates = 1;
        tracks_.push_back(std::move(tr));
    }
}

// The tracks of non-zero weight, as lights; tracks_ is in birth order, so ids increase.
std::vector<Light> Tracker::visible_lights() const {
    std::vector<Light> lights;
    for (const Track& tr : tracks_) {
        if (tr.weight <= 0.0) continue;
        Light l;
        l.id = tr.id;
        l.x = tr.x;
        l.y = tr.y;
        l.flux = tr.flux;
        l.extent = tr.extent;
        l.weight = tr.weight;
        l.clipped = tr.clipped;
        l.shape = tr.shape;
        lights.push_back(std::move(l));
    }
    return lights;
}

}  // namespace lensfx::detect
