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
    const auto& hist = detection.stats.histogram;
    last_was_cut_ = !previous_histogram_.empty() && histogram_distance(previous_histogram_, hist) > options_.cut_threshold;
    if (last_was_cut_) {
        tracks_.clear();
        fresh_ = true;
    }
    previous_histogram_ = hist;

    // Prediction (constant velocity, constant flux slope).
    struct Prediction { double x, y; std::array<double, 3> flux; };
    std::vector<Prediction> pred(tracks_.size());
    for (std::size_t t = 0; t < tracks_.size(); ++t) {
        const Track& tr = tracks_[t];
        pred[t].x = tr.x + tr.vx;
        pred[t].y = tr.y + tr.vy;
        for (int c = 0; c < 3; ++c) pred[t].flux[static_cast<std::size_t>(c)] = std::max(0.0, tr.flux[static_cast<std::size_t>(c)] + tr.dflux[static_cast<std::size_t>(c)]);
    }

    // Gated candidate pairs, cheapest first; ties broken by track then source order.
    const auto& sources = detection.sources;
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
    std::vector<int> match_of_track(tracks_.size(), -1);
    std::vector<bool> source_taken(sources.size(), false);
    for (const auto& [cost, t, s] : pairs) {
        if (match_of_track[t] >= 0 || source_taken[s]) continue;
        match_of_track[t] = static_cast<int>(s);
        source_taken[s] = true;
    }

    const double pa = options_.position_alpha, pb = critically_damped_beta(pa, options_.position_beta);
    const double fa = options_.flux_alpha, fb = critically_damped_beta(fa, options_.flux_beta);
    const double ea = options_.extent_alpha;
    const double fade_in = options_.fade_in_frames > 0 ? 1.0 / options_.fade_in_frames : 1.0;
    const double fade_out = options_.fade_out_frames > 0 ? 1.0 / options_.fade_out_frames : 1.0;

    for (std::size_t t = 0; t < tracks_.size(); ++t) {
        Track& tr = tracks_[t];
        const Prediction& p = pred[t];
        if (match_of_track[t] < 0) {
            // Coast: keep moving, hold the flux; after coast_frames, fade out.
            tr.x = p.x;
            tr.y = p.y;
            tr.dflux = {};
            ++tr.missed;
            if (tr.missed > options_.coast_frames) tr.weight = std::max(0.0, tr.weight - fade_out);
            continue;
        }
        const Source& s = sources[static_cast<std::size_t>(match_of_track[t])];
        if (tr.updates == 1) {
            // Second detection: two-point start of the velocity, so a steady motion is followed without lag.
            tr.vx = s.x - tr.x;
            tr.vy = s.y - tr.y;
            tr.x = s.x;
            tr.y = s.y;
            for (std::size_t c = 0; c < 3; ++c) {
                tr.dflux[c] = s.flux[c] - tr.flux[c];
                tr.flux[c] = s.flux[c];
            }
        } else {
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
        tr.extent.major += ea * (s.extent.major - tr.extent.major);
        tr.extent.minor += ea * (s.extent.minor - tr.extent.minor);
        double da = s.extent.angle_deg - tr.extent.angle_deg;  // axes: angles modulo 180
        da -= 180.0 * std::round(da / 180.0);
        tr.extent.angle_deg = std::fmod(tr.extent.angle_deg + ea * da + 180.0, 180.0);
        tr.clipped = s.clipped;
        tr.shape = s.shape;
        ++tr.updates;
        tr.missed = 0;
        tr.weight = std::min(1.0, tr.weight + fade_in);
    }
    std::erase_if(tracks_, [](const Track& tr) { return tr.missed > 0 && tr.weight <= 0.0; });

    // Births: unmatched sources whose peak reaches the birth threshold (the hysteresis upper edge).
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
        tr.weight = fresh_ ? 1.0 : fade_in;
        tr.updates = 1;
        tracks_.push_back(std::move(tr));
    }
    fresh_ = false;

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
    return lights;  // tracks_ is in birth order, so ids increase
}

}  // namespace lensfx::detect
