// Fitting measured ghosts to a sweep (paper section 3.3): detection on the light-centre axis, key frames,
// gradient descent on MSE + smoothed-Laplacian edge cost, tracking, polynomials over the angle.
#include <measured/fit.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cmath>
#include <mutex>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <thread>

#include <fmt/core.h>

#include "fit_image.h"

namespace lensfx::measured {

namespace {

// The capture's background level per channel, one for the whole sweep (a black level, the room's light):
// the ghosts move with the angle, so every part of the frame is dark in some frame unless a ghost covers
// it at every angle. Per 16 x 16 block and channel, one half of its pixels (a checkerboard) picks the frame
// where the block is darkest; the other half, independent of that choice's noise, gives the level there.
// The background is the median of those levels over the darkest tenth of the blocks.
std::array<double, 3> sweep_background(const std::vector<SweepFrame>& frames) {
    const int w = frames[0].width, h = frames[0].height;
    const int block = std::clamp(std::min(w, h) / 10, 4, 16);
    const int bx = w / block, by = h / block;
    std::array<double, 3> level{};
    for (std::size_t c = 0; c < 3; ++c) {
        std::vector<std::pair<double, double>> darkest(static_cast<std::size_t>(bx * by), {1e300, 0.0});  // (picker, level)
        for (const SweepFrame& f : frames)
            for (int b = 0; b < bx * by; ++b) {
                double pick = 0.0, measure = 0.0;
                for (int y = (b / bx) * block; y < (b / bx + 1) * block; ++y)
                    for (int x = (b % bx) * block; x < (b % bx + 1) * block; ++x)
                        ((x + y) % 2 ? pick : measure) += static_cast<double>(f.rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) * 3 + c]);
                auto& d = darkest[static_cast<std::size_t>(b)];
                if (pick < d.first) d = {pick, measure * 2.0 / (block * block)};
            }
        std::sort(darkest.begin(), darkest.end());
        std::vector<double> levels;
        for (std::size_t i = 0; i < std::max<std::size_t>(3, darkest.size() / 10) && i < darkest.size(); ++i) levels.push_back(darkest[i].second);
        level[c] = median(levels);
    }
    return level;
}

// A frame with its background taken off, and what the detector and the fit need of it.
struct Prepared {
    int width = 0, height = 0;
    double angle_deg = 0.0;
    std::vector<double> rgb;      // minus the background
    std::vector<double> smooth;    // luminance, Gaussian sigma 1 px
    double background = 0.0, noise = 0.0, smooth_noise = 0.0;
    double light_x = 0.0, light_y = 0.0, light_radius = 0.0;  // pixels
};

// A ghost found on the axis of one frame.
struct Detection {
    int frame = 0;
    GhostParams seed{};
    double snr = 0.0;
};

struct Track {
    std::vector<Detection> seen;
    std::vector<std::pair<int, GhostParams>> fitted;  // frame, parameters
    bool glow = false;  // a wide soft glow over the whole frame (fitted to what the ghosts leave), not a ghost
    double drawn_from = -1e300;  // a later piece of a split track: drawn after the angle where the one before ends
    std::vector<Track> pieces;   // the later pieces of a track split by split_by_level
};

double pixel_mm(const FitOptions& o, int width) { return o.sensor_width_mm / width; }

Prepared prepare(const SweepFrame& f, const std::array<double, 3>& level, const FitOptions& o) {
    Prepared p;
    p.width = f.width, p.height = f.height, p.angle_deg = f.angle_deg;
    const std::size_t n = static_cast<std::size_t>(f.width) * static_cast<std::size_t>(f.height);
    p.rgb.resize(n * 3);
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t c = 0; c < 3; ++c) p.rgb[i * 3 + c] = static_cast<double>(f.rgb[i * 3 + c]) - level[c];
    p.background = luminance(level[0], level[1], level[2]);
    const std::vector<double> lum = luminance_of(p.rgb, n);
    p.noise = robust_sigma(lum);
    p.smooth = gaussian_blur(lum, f.width, f.height, 1.0);
    p.smooth_noise = robust_sigma(p.smooth);
    const double k = 3.14159265358979323846 / 180.0;
    const double pw = pixel_mm(o, f.width), ph = o.sensor_height_mm / f.height;
    p.light_x = o.focal_length_mm * std::tan(f.angle_deg * k) / pw + 0.5 * f.width - 0.5;
    p.light_y = 0.5 * f.height - 0.5;
    p.light_radius = o.light_radius * f.width;
    (void)ph;
    return p;
}

// Ghosts on the light-centre axis of one frame: runs of the smoothed luminance above the threshold, away
// from the light, taller than a starburst spike.
std::vector<Detection> detect(const Prepared& p, int frame, const FitOptions& o) {
    const int r0 = std::clamp(p.height / 2 - 1, 0, p.height - 1), r1 = std::min(r0 + 1, p.height - 1);
    std::vector<double> profile(static_cast<std::size_t>(p.width));
    double top = 0.0;
    for (int x = 0; x < p.width; ++x) {
        profile[static_cast<std::size_t>(x)] = 0.5 * (p.smooth[static_cast<std::size_t>(r0 * p.width + x)] + p.smooth[static_cast<std::size_t>(r1 * p.width + x)]);
        if (std::abs(x - p.light_x) > p.light_radius) top = std::max(top, profile[static_cast<std::size_t>(x)]);
    }
    const double threshold = std::max(o.min_snr * p.smooth_noise, 0.02 * top);
    const double pw = pixel_mm(o, p.width), ph = o.sensor_height_mm / p.height;
    std::vector<Detection> found;
    for (int x = 0; x < p.width;) {
        const auto in_light = [&](int i) { return std::abs(i - p.light_x) <= p.light_radius; };
        const auto lit = [&](int i) { return profile[static_cast<std::size_t>(i)] > threshold && !in_light(i); };
        if (!lit(x)) {
            ++x;
            continue;
        }
        int end = x;
        // A ghost passing over the light is one run across it when it is lit on both sides (the fit masks the
        // light's own pixels).
        while (end + 1 < p.width && (lit(end + 1) || (in_light(end + 1) && profile[static_cast<std::size_t>(end)] > threshold && [&] {
                                         int after = end + 1;
                                         while (after < p.width && in_light(after)) ++after;
                                         return after < p.width && lit(after);
                                     }())))
            ++end;
        const int run = end - x + 1, middle = (x + end) / 2;
        int row = r0;
        while (row > 0 && p.smooth[static_cast<std::size_t>((row - 1) * p.width + middle)] > 0.5 * threshold) --row;
        const int half_height = r0 - row + 1;
        if (run >= 3 && half_height >= std::max(2.0, 0.2 * run)) {
            std::array<double, 3> level{};
            for (int i = x; i <= end; ++i)
                for (std::size_t c = 0; c < 3; ++c)
                    level[c] += 0.5 * (p.rgb[static_cast<std::size_t>(r0 * p.width + i) * 3 + c] + p.rgb[static_cast<std::size_t>(r1 * p.width + i) * 3 + c]) / run;
            Detection d;
            d.frame = frame;
            d.seed = disc_ghost((0.5 * (x + end) + 0.5 - 0.5 * p.width) * pw, 0.5 * run * pw, level);
            d.seed[kHeight] = half_height * ph;
            double sum = 0.0;
            for (int i = x; i <= end; ++i) sum += profile[static_cast<std::size_t>(i)];
            d.snr = sum / run / std::max(p.smooth_noise, 1e-30) * std::sqrt(static_cast<double>(run));
            found.push_back(d);
        }
        x = end + 1;
    }
    std::sort(found.begin(), found.end(), [](const Detection& a, const Detection& b) { return a.snr > b.snr; });
    if (found.size() > static_cast<std::size_t>(o.max_ghosts)) found.resize(static_cast<std::size_t>(o.max_ghosts));
    return found;
}

// Links each frame's detections to the tracks by their predicted position along the axis.
std::vector<Track> link(const std::vector<std::vector<Detection>>& per_frame, double pixel) {
    std::vector<Track> tracks;
    for (std::size_t f = 0; f < per_frame.size(); ++f) {
        std::vector<char> taken(per_frame[f].size(), 0);
        for (Track& t : tracks) {
            const Detection& last = t.seen.back();
            if (static_cast<int>(f) - last.frame > 2) continue;
            double predicted = last.seed[kPosition];
            if (t.seen.size() >= 2) {
                const Detection& before = t.seen[t.seen.size() - 2];
                predicted += (last.seed[kPosition] - before.seed[kPosition]) / (last.frame - before.frame) * (static_cast<double>(f) - last.frame);
            }
            const double gate = std::max(4.0 * pixel, 0.5 * (last.seed[kLeft] + last.seed[kRight]));
            int best = -1;
            double best_d = gate;
            for (std::size_t i = 0; i < per_frame[f].size(); ++i) {
                const double d = std::abs(per_frame[f][i].seed[kPosition] - predicted);
                // A ghost keeps its size from one frame to the next within a factor of 1.6 (a larger change is
                // another ghost passing by).
                const double size_ratio = per_frame[f][i].seed[kLeft] / std::max(last.seed[kLeft], 1e-9);
                if (!taken[i] && d < best_d && size_ratio < 1.6 && size_ratio > 1.0 / 1.6) best_d = d, best = static_cast<int>(i);
            }
            if (best >= 0) taken[static_cast<std::size_t>(best)] = 1, t.seen.push_back(per_frame[f][static_cast<std::size_t>(best)]);
        }
        for (std::size_t i = 0; i < per_frame[f].size(); ++i)
            if (!taken[i]) tracks.push_back(Track{{per_frame[f][i]}, {}, false, -1e300, {}});
    }
    return tracks;
}

// A glow is an elliptical dome: its level rises from 0 at the border to Ii at the middle (so that Ii is
// its peak, not traded against the fall-off), only its place and size free. (A disc with a lit border and
// a free fall inside fitted the test sweep's L1 better but its power worse, and an edge cannot be drawn
// reduced.)
GhostParams glow_shape(GhostParams p) {
    p[kCurveLeft] = p[kCurveRight] = 0.5523;
    p[kFallInside] = std::min(p[kHeight], 0.5 * (p[kLeft] + p[kRight]));
    p[kSlopeInside] = 1.5;
    p[kFallOutside] = 1e-3, p[kSlopeOutside] = 1.0;
    return p;
}

// The cost of one ghost against one frame's crop (paper section 3.3.1), the levels solved exactly.
class GhostCost {
public:
    // glow: no local background (the sweep's is taken off already) and no edge cost.
    GhostCost(const Prepared& p, const GhostParams& seed, const FitOptions& o, bool glow = false) : glow_(glow), options_(o) {
        view_.sensor_width_mm = o.sensor_width_mm, view_.sensor_height_mm = o.sensor_height_mm;
        view_.width = p.width, view_.height = p.height;
        GhostParams wide = seed;
        for (int i : {kLeft, kRight, kHeight}) wide[i] *= 1.4;
        wide[kFallOutside] = std::max(wide[kFallOutside], 0.0) + 3.0 * o.sensor_width_mm / p.width;
        box_ = ghost_box(wide, 0.0, view_);
        // A large ghost is fitted on every stride-th pixel: the cost stays that of a 48 x 48 crop.
        const int bw = std::max(0, box_[2] - box_[0]), bh = std::max(0, box_[3] - box_[1]);
        const int samples = glow ? kCropSamples / 2 : kCropSamples;  // a glow is smooth
        stride_ = std::max(1, (std::max(bw, bh) + samples - 1) / samples);
        w_ = (bw + stride_ - 1) / stride_, h_ = (bh + stride_ - 1) / stride_;
        const std::size_t n = static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_);
        target_.resize(n * 3), mask_.resize(n);
        std::vector<double> lum(n);
        for (int y = 0; y < h_; ++y)
            for (int x = 0; x < w_; ++x) {
                const int px = box_[0] + x * stride_, py = box_[1] + y * stride_;
                const std::size_t i = static_cast<std::size_t>(y * w_ + x), src = static_cast<std::size_t>(py * p.width + px);
                for (std::size_t c = 0; c < 3; ++c) target_[i * 3 + c] = p.rgb[src * 3 + c];
                lum[i] = luminance(target_[i * 3], target_[i * 3 + 1], target_[i * 3 + 2]);
                mask_[i] = std::hypot(px - p.light_x, py - p.light_y) > p.light_radius ? 1.0 : 0.0;
                tie_sides_ = tie_sides_ || (mask_[i] == 0.0 && !glow);
            }
        target_edges_ = edge_image(lum, w_, h_);
        for (std::size_t i = 0; i < n; ++i) {
            target_power_ += mask_[i] * (target_[i * 3] * target_[i * 3] + target_[i * 3 + 1] * target_[i * 3 + 1] + target_[i * 3 + 2] * target_[i * 3 + 2]);
            edge_power_ += mask_[i] * target_edges_[i] * target_edges_[i];
        }
        target_power_ = std::max(target_power_, 1e-30), edge_power_ = std::max(edge_power_, 1e-30);
    }

    bool empty() const { return w_ < 3 || h_ < 3; }

    // The cost at p; p's levels are set to their least-squares values.
    double operator()(GhostParams& p) {
        p = clamped(p);
        if (tie_sides_) p[kRight] = p[kLeft], p[kCurveRight] = p[kCurveLeft];
        if (glow_) p = glow_shape(p);
        distances(p);
        solve_levels(p);
        const std::size_t n = distance_.size();
        std::vector<double> lum(n);
        double mse = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            const auto [a, b] = level_weights(p, distance_[i]);
            std::array<double, 3> y{};
            for (std::size_t c = 0; c < 3; ++c) {
                y[c] = p[kBorderR + static_cast<int>(c)] * a + p[kInsideR + static_cast<int>(c)] * b + local_background_[c];
                const double e = target_[i * 3 + c] - y[c];
                mse += mask_[i] * e * e;
            }
            lum[i] = luminance(y[0], y[1], y[2]);
        }
        const std::vector<double> edges = edge_image(lum, w_, h_);
        double edge = 0.0;
        for (std::size_t i = 0; i < n; ++i) edge += mask_[i] * (edges[i] - target_edges_[i]) * (edges[i] - target_edges_[i]);
        return mse / target_power_ + (glow_ ? 0.0 : options_.edge_weight) * edge / edge_power_;
    }

    // sum |target - model| / sum |target| over the crop (outside the light).
    double residual(const GhostParams& p) {
        distances(p);
        double diff = 0.0, total = 0.0;
        for (std::size_t i = 0; i < distance_.size(); ++i)
            for (std::size_t c = 0; c < 3; ++c) {
                diff += mask_[i] * std::abs(target_[i * 3 + c] - local_background_[c] - intensity(p, static_cast<int>(c), distance_[i]));
                total += mask_[i] * std::abs(target_[i * 3 + c]);
            }
        return total > 0.0 ? diff / total : 0.0;
    }

private:
    void distances(const GhostParams& p) {
        if (!distance_.empty() && std::equal(p.begin(), p.begin() + kShapeParams, shape_.begin())) return;
        std::copy(p.begin(), p.begin() + kShapeParams, shape_.begin());
        distance_.resize(static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_));
        const double pw = view_.sensor_width_mm / view_.width, ph = view_.sensor_height_mm / view_.height;
        for (int y = 0; y < h_; ++y)
            for (int x = 0; x < w_; ++x) {
                const double xs = (box_[0] + x * stride_ + 0.5 - 0.5 * view_.width) * pw, ys = (0.5 * view_.height - (box_[1] + y * stride_ + 0.5)) * ph;
                distance_[static_cast<std::size_t>(y * w_ + x)] = signed_distance(p, xs - p[kPosition], ys);
            }
    }

    // Ib, Ii and the local background per channel by least squares (the intensity is linear in them),
    // Ib and Ii kept >= 0: the background absorbs the glow of other, larger flare around the ghost.
    void solve_levels(GhostParams& p) {
        double m[3][3] = {};
        std::array<std::array<double, 3>, 3> rhs{};  // [channel][basis]
        for (std::size_t i = 0; i < distance_.size(); ++i) {
            const auto [a, b] = level_weights(p, distance_[i]);
            const double basis[3] = {a, b, 1.0};
            for (int r = 0; r < 3; ++r) {
                for (int c = 0; c < 3; ++c) m[r][c] += mask_[i] * basis[r] * basis[c];
                for (std::size_t ch = 0; ch < 3; ++ch) rhs[ch][static_cast<std::size_t>(r)] += mask_[i] * basis[r] * target_[i * 3 + ch];
            }
        }
        if (glow_) {  // the inside level alone (a dome from 0 at the border), no background
            for (int ch = 0; ch < 3; ++ch) {
                p[kBorderR + ch] = 0.0, local_background_[static_cast<std::size_t>(ch)] = 0.0;
                p[kInsideR + ch] = m[1][1] > 0.0 ? std::max(0.0, rhs[static_cast<std::size_t>(ch)][1] / m[1][1]) : 0.0;
            }
            return;
        }
        for (int ch = 0; ch < 3; ++ch) {
            const auto& r = rhs[static_cast<std::size_t>(ch)];
            std::array<double, 3> x = solve3(m, r);
            if (!(x[0] >= 0.0 && x[1] >= 0.0)) {
                // One level for border and inside (basis a + b, 1), or none.
                const double ss = m[0][0] + 2 * m[0][1] + m[1][1], s1 = m[0][2] + m[1][2], n = m[2][2];
                const double st = r[0] + r[1], t1 = r[2], det = ss * n - s1 * s1;
                const double level = det > 1e-12 * std::max(ss * n, 1e-300) ? (n * st - s1 * t1) / det : 0.0;
                x = level > 0.0 ? std::array<double, 3>{level, level, (t1 - s1 * level) / std::max(n, 1e-300)}
                                : std::array<double, 3>{0.0, 0.0, t1 / std::max(n, 1e-300)};
            }
            p[kBorderR + ch] = x[0], p[kInsideR + ch] = x[1], local_background_[static_cast<std::size_t>(ch)] = x[2];
        }
    }

    // The 3 x 3 system m x = r by Cramer's rule (a singular one: no levels, the mean as background).
    static std::array<double, 3> solve3(const double m[3][3], const std::array<double, 3>& r) {
        auto det3 = [](const double a[3][3]) {
            return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                   a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
        };
        const double d = det3(m);
        if (!(std::abs(d) > 1e-12 * std::max(m[0][0] * m[1][1] * m[2][2], 1e-300))) return {-1.0, -1.0, 0.0};
        std::array<double, 3> x{};
        for (int k = 0; k < 3; ++k) {
            double a[3][3];
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) a[i][j] = j == k ? r[static_cast<std::size_t>(i)] : m[i][j];
            x[static_cast<std::size_t>(k)] = det3(a) / d;
        }
        return x;
    }

    std::array<double, 3> local_background_{};
    bool glow_ = false;
    // The light's own image hides part of the ghost: its two sides are taken alike (ghosts of a round lens
    // are near-symmetric along the axis), so the hidden end follows the seen one.
    bool tie_sides_ = false;
    const FitOptions& options_;
    MeasuredView view_;
    static constexpr int kCropSamples = 48;
    std::array<int, 4> box_{};
    int stride_ = 1, w_ = 0, h_ = 0;
    std::vector<double> target_, mask_, target_edges_, distance_;
    double target_power_ = 0.0, edge_power_ = 0.0;
    std::array<double, kShapeParams> shape_{};
};

// Per-parameter steps (paper 3.3.2): a quarter pixel for lengths, 0.05 for curves, 0.25 for slopes.
std::array<double, kFallOutside + 2> parameter_steps(double pixel) {
    return {0.5 * pixel, 0.5 * pixel, 0.5 * pixel, 0.5 * pixel, 0.05, 0.05, 0.5 * pixel, 0.25, 0.5 * pixel, 0.25};
}

// Gradient descent with per-parameter steps and a decaying learning rate, shape before shade, each change
// taken at once (online); the levels follow by least squares at every evaluation.
GhostParams descend(GhostCost& cost, GhostParams p, int iterations, double learning_rate, double pixel, std::size_t free_params) {
    auto all_steps = parameter_steps(pixel);
    const std::vector<double> steps(all_steps.begin(), all_steps.begin() + static_cast<std::ptrdiff_t>(std::min(free_params, all_steps.size())));
    double current = cost(p);
    for (int it = 0; it < iterations && learning_rate > 1.0 / 32; ++it) {
        bool improved = false;
        for (std::size_t k = 0; k < steps.size(); ++k) {
            GhostParams up = p, down = p;
            up[static_cast<int>(k)] += learning_rate * steps[k];
            down[static_cast<int>(k)] -= learning_rate * steps[k];
            const double cu = cost(up), cd = cost(down);
            if (std::min(cu, cd) < current) {
                p = cu < cd ? up : down;
                current = std::min(cu, cd);
                improved = true;
            }
        }
        if (!improved) learning_rate *= 0.5;
        if (it % 100 == 99) learning_rate *= 0.8;  // the paper's decay: 20% every 100 iterations
    }
    cost(p);  // the levels for the final shape
    return p;
}

// Least-squares polynomial of degree <= 2 (fewer points: lower degree) through (x, y).
std::array<double, 3> fit_polynomial(const std::vector<double>& x, const std::vector<double>& y) {
    const int degree = std::min<int>(2, static_cast<int>(x.size()) - 1);
    if (degree <= 0) return {y.empty() ? 0.0 : y[0], 0.0, 0.0};
    double m[3][4] = {};
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double pw[3] = {1.0, x[i], x[i] * x[i]};
        for (int r = 0; r <= degree; ++r) {
            for (int c = 0; c <= degree; ++c) m[r][c] += pw[r] * pw[c];
            m[r][3] += pw[r] * y[i];
        }
    }
    const int n = degree + 1;
    for (int c = 0; c < n; ++c) {
        int pivot = c;
        for (int r = c + 1; r < n; ++r)
            if (std::abs(m[r][c]) > std::abs(m[pivot][c])) pivot = r;
        for (int k = 0; k < 4; ++k) std::swap(m[c][k], m[pivot][k]);
        if (std::abs(m[c][c]) < 1e-300) return {y[0], 0.0, 0.0};
        for (int r = 0; r < n; ++r) {
            if (r == c) continue;
            const double f = m[r][c] / m[c][c];
            for (int k = 0; k < 4; ++k) m[r][k] -= f * m[c][k];
        }
    }
    std::array<double, 3> out{};
    for (int r = 0; r < n; ++r) out[static_cast<std::size_t>(r)] = m[r][3] / m[r][r];
    return out;
}

// The seed for the next frame: the neighbour's fit, its shape extrapolated by a polynomial over the
// frames fitted so far on this side of the key frame (paper 3.3.2).
GhostParams next_seed(const std::vector<std::pair<double, GhostParams>>& walk, double angle) {
    GhostParams seed = walk.back().second;
    if (walk.size() < 3) return seed;
    const std::size_t first = walk.size() > 6 ? walk.size() - 6 : 0;
    for (int k = 0; k < kShapeParams; ++k) {
        std::vector<double> x, y;
        for (std::size_t i = first; i < walk.size(); ++i) x.push_back(walk[i].first), y.push_back(walk[i].second[k]);
        const auto c = fit_polynomial(x, y);
        seed[k] = c[0] + angle * (c[1] + angle * c[2]);
    }
    return clamped(seed);
}

MeasuredGhost to_polynomials(const Track& track, const std::vector<Prepared>& frames) {
    MeasuredGhost g;
    std::vector<double> x;
    for (const auto& [f, p] : track.fitted) x.push_back(frames[static_cast<std::size_t>(f)].angle_deg);
    if (x.empty()) return g;
    // A later piece of a split track takes over just after the shared frame, which its polynomial was fitted to.
    g.angle_min_deg = track.drawn_from > -1e299 ? track.drawn_from : *std::min_element(x.begin(), x.end());
    g.angle_max_deg = *std::max_element(x.begin(), x.end());
    for (int k = 0; k < kParamCount; ++k) {
        std::vector<double> y;
        for (const auto& fp : track.fitted) y.push_back(fp.second[k]);
        g.poly[static_cast<std::size_t>(k)] = fit_polynomial(x, y);
    }
    return g;
}

// The track's fits replaced by its polynomials over the angle: the shape's polynomials first, the levels
// solved again for that shape in each frame (the per-frame shapes trade size against fall-off and level,
// so levels fitted with one shape do not suit the smoothed one), then the levels' polynomials.
void settle_on_polynomials(Track& track, const std::vector<Prepared>& frames, const FitOptions& o) {
    for (int pass = 0; pass < 2; ++pass) {
        const MeasuredGhost g = to_polynomials(track, frames);
        for (auto& [f, p] : track.fitted) {
            p = g.at(frames[static_cast<std::size_t>(f)].angle_deg);
            if (pass == 0) {
                GhostCost cost(frames[static_cast<std::size_t>(f)], p, o, track.glow);
                if (!cost.empty()) cost(p);
            }
        }
    }
}

const Detection* detection_in(const Track& track, int f) {
    const auto seen = std::find_if(track.seen.begin(), track.seen.end(), [&](const Detection& d) { return d.frame == f; });
    return seen == track.seen.end() ? nullptr : &*seen;
}

// p placed so that the middle of its extent along the axis is the detection's (a fit cannot drift along
// the track, onto the light or a neighbour).
GhostParams placed_on(GhostParams p, const Detection& d) {
    const auto middle = [](const GhostParams& q) { return q[kPosition] + 0.5 * (q[kRight] - q[kLeft]); };
    p[kPosition] += middle(d.seed) - middle(p);
    return p;
}

// A detection clear of the light's own image (which hides part of a ghost and whose edge the fit would
// take for the ghost's).
bool clear_of_light(const Detection& d, const std::vector<Prepared>& frames, const FitOptions& o) {
    const Prepared& p = frames[static_cast<std::size_t>(d.frame)];
    const double pw = pixel_mm(o, p.width);
    const double light_mm = (p.light_x + 0.5 - 0.5 * p.width) * pw;
    return std::abs(d.seed[kPosition] - light_mm) - std::max(d.seed[kLeft], d.seed[kRight]) > 2.0 * p.light_radius * pw;
}

// The key frame: the clearest detection (SNR x size), among those clear of the light where there are any.
const Detection& key_detection(const Track& track, const std::vector<Prepared>& frames, const FitOptions& o) {
    const Detection* best = nullptr;
    for (bool need_clear : {true, false}) {
        for (const Detection& d : track.seen)
            if ((!need_clear || clear_of_light(d, frames, o)) && (!best || d.snr * d.seed[kLeft] > best->snr * best->seed[kLeft])) best = &d;
        if (best) break;
    }
    return *best;
}

// A seed whose crop is the whole frame (a glow's: it is compared with others there).
GhostParams whole_frame(const FitOptions& o) {
    GhostParams p = disc_ghost(0.0, 0.5 * o.sensor_width_mm, {0.0, 0.0, 0.0});
    p[kHeight] = 0.5 * o.sensor_height_mm;
    return p;
}

// A track's parameters as degree-2 polynomials fitted to all its frames at once: the per-frame fits trade
// size against fall-off and level (a small core with a wide outer fall-off, or the ghost's own outline),
// and a walk can take one way in some frames and the other in the rest; a polynomial through such a mix
// draws neither between the samples. Each of the free parameters is held by its values at the track's
// first, middle and last angle (a polynomial through them), started from the least-squares polynomial of
// the per-frame fits and descended on the mean of the frames' costs (each frame's crop as the walk's, the
// levels solved per frame); the frames' fits are then replaced by it.
class TrackPolynomial {
public:
    TrackPolynomial(Track& track, const std::vector<Prepared>& frames, const FitOptions& o, std::size_t free) : track_(track), free_(free) {
        for (const auto& [f, p] : track.fitted) {
            const Detection* seen = detection_in(track, f);
            costs_.emplace_back(frames[static_cast<std::size_t>(f)], track.glow ? whole_frame(o) : seen ? seen->seed : p, o, track.glow);
            angles_.push_back(frames[static_cast<std::size_t>(f)].angle_deg);
        }
        nodes_ = {angles_.front(), 0.5 * (angles_.front() + angles_.back()), angles_.back()};
        const MeasuredGhost start = to_polynomials(track, frames);
        for (std::size_t k = 0; k < free_; ++k)
            for (std::size_t j = 0; j < 3; ++j) {
                const auto& c = start.poly[k];
                values_.push_back(c[0] + nodes_[j] * (c[1] + nodes_[j] * c[2]));
            }
    }

    // Coordinate descent on the node values (per-parameter steps, the learning rate halved when a pass
    // finds nothing), then the frames' fits set to the result with their levels solved.
    // The mean cost of the frames' own fits (what the walk reached): the polynomial's against it says how
    // well one polynomial stands for the track.
    double walk_cost() {
        double sum = 0.0;
        int n = 0;
        for (std::size_t i = 0; i < costs_.size(); ++i) {
            if (costs_[i].empty()) continue;
            GhostParams p = track_.fitted[i].second;
            sum += costs_[i](p), ++n;
        }
        return n > 0 ? sum / n : 0.0;
    }
    double polynomial_cost() { return cost(values_); }

    void descend(int iterations, double pixel) {
        if (angles_.size() < 3 || !(nodes_[2] > nodes_[0])) return;
        const auto steps = parameter_steps(pixel);
        double current = cost(values_), rate = 1.0;
        for (int it = 0; it < iterations && rate > 1.0 / 16; ++it) {
            bool improved = false;
            for (std::size_t i = 0; i < values_.size(); ++i)
                for (double sign : {1.0, -1.0}) {
                    std::vector<double> trial = values_;
                    trial[i] += sign * rate * steps[i / 3];
                    if (const double c = cost(trial); c < current) {
                        values_ = std::move(trial), current = c, improved = true;
                        break;
                    }
                }
            if (!improved) rate *= 0.5;
        }
        for (std::size_t i = 0; i < costs_.size(); ++i) {
            GhostParams p = at(values_, i);
            if (!costs_[i].empty()) costs_[i](p);
            track_.fitted[i].second = p;
        }
    }

private:
    // Frame i's parameters with the free ones from the node values (Lagrange through the three nodes).
    GhostParams at(const std::vector<double>& values, std::size_t i) const {
        GhostParams p = track_.fitted[i].second;
        const double a = angles_[i], n0 = nodes_[0], n1 = nodes_[1], n2 = nodes_[2];
        const std::array<double, 3> basis{(a - n1) * (a - n2) / ((n0 - n1) * (n0 - n2)), (a - n0) * (a - n2) / ((n1 - n0) * (n1 - n2)),
                                          (a - n0) * (a - n1) / ((n2 - n0) * (n2 - n1))};
        for (std::size_t k = 0; k < free_; ++k) p[static_cast<int>(k)] = values[k * 3] * basis[0] + values[k * 3 + 1] * basis[1] + values[k * 3 + 2] * basis[2];
        return p;
    }

    double cost(const std::vector<double>& values) {
        double sum = 0.0;
        int n = 0;
        for (std::size_t i = 0; i < costs_.size(); ++i) {
            if (costs_[i].empty()) continue;
            GhostParams p = at(values, i);
            sum += costs_[i](p), ++n;
        }
        return n > 0 ? sum / n : 0.0;
    }

    Track& track_;
    std::size_t free_;
    std::vector<GhostCost> costs_;
    std::vector<double> angles_, values_;
    std::array<double, 3> nodes_{};
};

// One frame of a track's walk from several starts, all fitted in one crop and the lowest cost kept: the
// walk's extrapolation and the neighbour's fit, each placed on the frame's detection, and the detection
// itself (a glow: the neighbour's fit and the frame's moments). The crop is the detection's where there
// is one (a crop that follows the walk's seed can grow with a drifting fit and feed it), a glow's the
// whole frame. Each start gets a third of the passes, the best the rest.
std::optional<GhostParams> fit_frame(const Track& track, const std::vector<Prepared>& frames, int f, const std::vector<std::pair<double, GhostParams>>& walk,
                                     const FitOptions& o, double pixel, std::size_t free) {
    const Prepared& frame = frames[static_cast<std::size_t>(f)];
    const Detection* seen = detection_in(track, f);
    std::vector<GhostParams> starts{next_seed(walk, frame.angle_deg), walk.back().second};
    if (seen && !track.glow)
        for (GhostParams& s : starts) s = placed_on(s, *seen);
    if (seen) starts.push_back(seen->seed);
    GhostCost cost(frame, track.glow ? whole_frame(o) : seen ? seen->seed : starts.front(), o, track.glow);
    if (cost.empty()) return std::nullopt;
    const int first_passes = std::max(1, o.track_iterations / 3);
    GhostParams best{};
    double best_cost = 1e300;
    for (const GhostParams& start : starts) {
        GhostParams p = descend(cost, start, first_passes, 1.0, pixel, free);
        const double c = cost(p);
        if (c < best_cost) best_cost = c, best = p;
    }
    return descend(cost, best, o.track_iterations - first_passes, 0.5, pixel, free);
}

// A ghost's brightest level (G, border or inside).
double peak_level(const GhostParams& p) { return std::max(p[kBorderG], p[kInsideG]); }

// The walk's fits in pieces where one degree-2 polynomial of the levels cannot follow them: a ghost whose
// peak level changes by more than FitOptions::max_level_ratio over its track (the disc ghost of the test's
// lens shrinks to a bright point nearing 20 degrees, its level rising some 200 times from 4 degrees) is
// split at the frame nearest the geometric mean of its extremes, the pieces sharing that frame, each again
// split where it needs to be. Each piece keeps at least 3 frames and the later one 4 (it gives up the
// shared frame once fitted).
std::vector<Track> split_by_level(const Track& track, const FitOptions& o) {
    const auto& fits = track.fitted;
    if (track.glow || fits.size() < 6) return {track};
    double low = 1e300, high = 0.0;
    for (const auto& fp : fits) low = std::min(low, peak_level(fp.second)), high = std::max(high, peak_level(fp.second));
    if (!(low > 0.0) || high / low <= o.max_level_ratio) return {track};
    const double middle = std::sqrt(low * high);
    std::size_t at = 2;
    for (std::size_t i = 2; i + 3 < fits.size(); ++i)
        if (std::abs(std::log(peak_level(fits[i].second) / middle)) < std::abs(std::log(peak_level(fits[at].second) / middle))) at = i;
    Track first = track, second = track;
    first.fitted.assign(fits.begin(), fits.begin() + static_cast<std::ptrdiff_t>(at) + 1);
    second.fitted.assign(fits.begin() + static_cast<std::ptrdiff_t>(at), fits.end());
    std::vector<Track> pieces = split_by_level(first, o);
    for (Track& t : split_by_level(second, o)) pieces.push_back(std::move(t));
    return pieces;
}

// Fits one track: its key frame from the detection, then frame by frame away from it in both directions.
void fit_track(Track& track, const std::vector<Prepared>& frames, const FitOptions& o) {
    const Detection& key = key_detection(track, frames, o);
    const double pixel = (track.glow ? 4.0 : 1.0) * o.sensor_width_mm / frames[0].width;  // a glow's steps: 4 px
    const std::size_t free = track.glow ? kCurveLeft : kFallOutside + 2;  // a glow: place and size only
    GhostCost key_cost(frames[static_cast<std::size_t>(key.frame)], track.glow ? whole_frame(o) : key.seed, o, track.glow);
    if (key_cost.empty()) return;
    const GhostParams key_fit = descend(key_cost, key.seed, o.key_iterations, 4.0, pixel, free);
    track.fitted.emplace_back(key.frame, key_fit);
    const int first = track.seen.front().frame, last = track.seen.back().frame;
    for (int direction : {1, -1}) {
        std::vector<std::pair<double, GhostParams>> walk{{frames[static_cast<std::size_t>(key.frame)].angle_deg, key_fit}};
        for (int f = key.frame + direction; f >= first && f <= last; f += direction) {
            const std::optional<GhostParams> fit = fit_frame(track, frames, f, walk, o, pixel, free);
            if (!fit) continue;
            walk.emplace_back(frames[static_cast<std::size_t>(f)].angle_deg, *fit);
            track.fitted.emplace_back(f, *fit);
        }
    }
    std::sort(track.fitted.begin(), track.fitted.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    if (o.progress && std::getenv("LENSFX_FIT_DEBUG")) {
        std::string lines = fmt::format("track (key frame {}, glow {}):", key.frame, track.glow);
        for (const auto& [f, p] : track.fitted)
            lines += fmt::format("\n   frame {:2}: M {:6.2f} L {:5.2f} R {:5.2f} h {:5.2f} Cl {:.2f} Cr {:.2f} Fi {:5.2f} Ei {:4.2f} Fo {:5.2f} Eo {:4.2f} IbG {:.2e} IiG {:.2e}", f,
                                 p[kPosition], p[kLeft], p[kRight], p[kHeight], p[kCurveLeft], p[kCurveRight], p[kFallInside], p[kSlopeInside], p[kFallOutside],
                                 p[kSlopeOutside], p[kBorderG], p[kInsideG]);
        o.progress(lines);
    }
    std::vector<Track> pieces = split_by_level(track, o);
    for (std::size_t i = 0; i < pieces.size(); ++i) {
        TrackPolynomial polynomial(pieces[i], frames, o, free);
        const double walk = polynomial.walk_cost();
        polynomial.descend(o.polynomial_iterations, pixel);
        if (o.progress && std::getenv("LENSFX_FIT_DEBUG"))
            o.progress(fmt::format("track (key frame {}) piece {}/{}: frames {}..{}, walk cost {:.4f}, polynomial cost {:.4f}", key.frame, i + 1, pieces.size(),
                                   pieces[i].fitted.front().first, pieces[i].fitted.back().first, walk, polynomial.polynomial_cost()));
        settle_on_polynomials(pieces[i], frames, o);
        if (i > 0) {  // the frame it shares with the piece before is that one's
            pieces[i].drawn_from = frames[static_cast<std::size_t>(pieces[i].fitted.front().first)].angle_deg + 1e-6;
            pieces[i].fitted.erase(pieces[i].fitted.begin());
        }
    }
    track = std::move(pieces.front());
    track.pieces.assign(std::make_move_iterator(pieces.begin() + 1), std::make_move_iterator(pieces.end()));
}

// sum |frame - model| / sum |frame| over the pixels `model_of` lights, outside the light's own image.
double frame_residual(const Prepared& p, const std::vector<double>& model) {
    double diff = 0.0, total = 0.0;
    for (int y = 0; y < p.height; ++y)
        for (int x = 0; x < p.width; ++x) {
            const std::size_t i = static_cast<std::size_t>(y * p.width + x);
            if (std::hypot(x - p.light_x, y - p.light_y) <= p.light_radius) continue;
            if (model[i * 3] == 0.0 && model[i * 3 + 1] == 0.0 && model[i * 3 + 2] == 0.0) continue;
            for (std::size_t c = 0; c < 3; ++c) diff += std::abs(p.rgb[i * 3 + c] - model[i * 3 + c]), total += std::abs(p.rgb[i * 3 + c]);
        }
    return total > 0.0 ? diff / total : 0.0;
}

void check_frames(const std::vector<SweepFrame>& frames) {
    if (frames.size() < 3) throw std::invalid_argument(fmt::format("a sweep needs at least 3 frames, not {}", frames.size()));
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const SweepFrame& f = frames[i];
        if (f.width != frames[0].width || f.height != frames[0].height)
            throw std::invalid_argument(fmt::format("frame {} is {}x{}, the first {}x{}", i, f.width, f.height, frames[0].width, frames[0].height));
        if (f.width < 16 || f.height < 16) throw std::invalid_argument(fmt::format("frame {} is {}x{}: at least 16x16 pixels", i, f.width, f.height));
        if (f.rgb.size() != static_cast<std::size_t>(f.width) * static_cast<std::size_t>(f.height) * 3)
            throw std::invalid_argument(fmt::format("frame {}: {} values for {}x{} RGB", i, f.rgb.size(), f.width, f.height));
        if (i > 0 && !(f.angle_deg > frames[i - 1].angle_deg)) throw std::invalid_argument("the sweep's angles must increase");
    }
}

// Fits every track, on `threads` threads.
void fit_tracks(std::vector<Track>& tracks, const std::vector<Prepared>& frames, const FitOptions& o) {
    std::atomic<std::size_t> next{0};
    std::mutex mutex;
    std::size_t done = 0;
    auto work = [&] {
        for (std::size_t i = next++; i < tracks.size(); i = next++) {
            fit_track(tracks[i], frames, o);
            const std::lock_guard<std::mutex> lock(mutex);
            ++done;
            if (o.progress && !tracks[i].fitted.empty())
                o.progress(fmt::format("ghost {}/{}: fitted over {:g}..{:g} deg ({} frames)", done, tracks.size(),
                                       frames[static_cast<std::size_t>(tracks[i].fitted.front().first)].angle_deg,
                                       frames[static_cast<std::size_t>(tracks[i].fitted.back().first)].angle_deg, tracks[i].fitted.size()));
        }
    };
    const unsigned n = o.threads > 0 ? static_cast<unsigned>(o.threads) : std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < std::min<unsigned>(n, static_cast<unsigned>(tracks.size())); ++t) pool.emplace_back(work);
    work();
    for (auto& t : pool) t.join();
}

// Pixels brighter than the 97th percentile of the frame's luminance dimmed to it: the light's own image
// and its starburst reach past any radius around the light, are small and much brighter than a glow.
void clip_bright(Prepared& p) {
    const std::size_t n = p.rgb.size() / 3;
    const std::vector<double> lum = luminance_of(p.rgb, n);
    std::vector<double> sorted = lum;
    const auto at = sorted.begin() + static_cast<std::ptrdiff_t>(0.97 * static_cast<double>(n - 1));
    std::nth_element(sorted.begin(), at, sorted.end());
    const double cap = std::max(*at, 0.0);
    for (std::size_t i = 0; i < n; ++i)
        if (lum[i] > cap)
            for (std::size_t c = 0; c < 3; ++c) p.rgb[i * 3 + c] *= cap / lum[i];
}

// Each frame less the fitted ghosts (and the glows fitted before), smoothed (sigma 2 px): what a glow is
// fitted to.
std::vector<Prepared> residual_frames(const std::vector<Prepared>& frames, const std::vector<Track>& tracks, const FitOptions& o) {
    std::vector<Prepared> out = frames;
    for (std::size_t f = 0; f < out.size(); ++f) {
        Prepared& p = out[f];
        MeasuredView view;
        view.sensor_width_mm = o.sensor_width_mm, view.sensor_height_mm = o.sensor_height_mm, view.width = p.width, view.height = p.height;
        std::vector<double> model(p.rgb.size(), 0.0);
        for (const Track& t : tracks)
            for (const auto& [frame, params] : t.fitted)
                if (frame == static_cast<int>(f)) {
                    const auto box = ghost_box(params, 0.0, view);
                    if (box[2] > box[0] && box[3] > box[1]) add_box(model, p.width, box, params, view);
                }
        const std::size_t n = model.size() / 3;
        for (std::size_t c = 0; c < 3; ++c) {
            std::vector<double> channel(n);
            for (std::size_t i = 0; i < n; ++i) channel[i] = p.rgb[i * 3 + c] - model[i * 3 + c];
            channel = gaussian_blur(channel, p.width, p.height, 2.0);
            for (std::size_t i = 0; i < n; ++i) p.rgb[i * 3 + c] = channel[i];
        }
        clip_bright(p);
    }
    return out;
}

// A glow's seed in one residual frame: a soft disc at the centroid of its light along the axis, as wide
// and high as twice its spread (luminance-weighted moments outside the light's own image).
Detection glow_seed(const Prepared& r, int frame, const FitOptions& o) {
    const double pw = pixel_mm(o, r.width), ph = o.sensor_height_mm / r.height;
    double sw = 0.0, sx = 0.0, sxx = 0.0, syy = 0.0;
    std::array<double, 3> level{};
    for (int y = 0; y < r.height; ++y)
        for (int x = 0; x < r.width; ++x) {
            if (std::hypot(x - r.light_x, y - r.light_y) <= r.light_radius) continue;
            const std::size_t i = static_cast<std::size_t>(y * r.width + x);
            const double w = std::max(0.0, luminance(r.rgb[i * 3], r.rgb[i * 3 + 1], r.rgb[i * 3 + 2]));
            const double xm = (x + 0.5 - 0.5 * r.width) * pw, ym = (0.5 * r.height - y - 0.5) * ph;
            sw += w, sx += w * xm, sxx += w * xm * xm, syy += w * ym * ym;
            for (std::size_t c = 0; c < 3; ++c) level[c] += std::max(0.0, r.rgb[i * 3 + c]);
        }
    Detection d;
    d.frame = frame;
    const double cx = sw > 0.0 ? sx / sw : 0.0;
    const double sigma_x = sw > 0.0 ? std::sqrt(std::max(0.0, sxx / sw - cx * cx)) : 0.25 * o.sensor_width_mm;
    const double sigma_y = sw > 0.0 ? std::sqrt(syy / sw) : 0.25 * o.sensor_height_mm;
    const double n = static_cast<double>(r.width) * r.height;
    d.seed = disc_ghost(cx, std::max(2.0 * sigma_x, 4.0 * pw), {level[0] / n, level[1] / n, level[2] / n});
    d.seed[kHeight] = std::max(2.0 * sigma_y, 4.0 * ph);
    const double size = std::min(d.seed[kLeft], d.seed[kHeight]);
    d.seed[kFallInside] = 0.8 * size, d.seed[kFallOutside] = 0.5 * size;
    d.snr = sw;
    return d;
}

// Luminance summed outside the light's own image.
double power_outside_light(const Prepared& p, const std::vector<double>& rgb) {
    double sum = 0.0;
    for (int y = 0; y < p.height; ++y)
        for (int x = 0; x < p.width; ++x) {
            if (std::hypot(x - p.light_x, y - p.light_y) <= p.light_radius) continue;
            const std::size_t i = static_cast<std::size_t>(y * p.width + x) * 3;
            sum += luminance(rgb[i], rgb[i + 1], rgb[i + 2]);
        }
    return sum;
}

// The glows' levels scaled in each frame so that together they hold what the ghosts leave there (its sum
// over the frame has a high SNR where each glow's fitted level does not: most of the flare's power is in
// them, and their polynomials carry it between the samples).
void match_glow_power(std::vector<Track>& tracks, const std::vector<Prepared>& frames, const FitOptions& o) {
    std::vector<Track> ghosts, glows;
    for (const Track& t : tracks) (t.glow ? glows : ghosts).push_back(t);
    if (glows.empty()) return;
    const std::vector<Prepared> left = residual_frames(frames, ghosts, o);
    for (std::size_t f = 0; f < frames.size(); ++f) {
        MeasuredView view;
        view.sensor_width_mm = o.sensor_width_mm, view.sensor_height_mm = o.sensor_height_mm, view.width = frames[f].width, view.height = frames[f].height;
        std::vector<double> model(frames[f].rgb.size(), 0.0);
        for (const Track& t : glows)
            for (const auto& [frame, params] : t.fitted)
                if (const auto box = ghost_box(params, 0.0, view); frame == static_cast<int>(f) && box[2] > box[0] && box[3] > box[1])
                    add_box(model, view.width, box, params, view);
        const double have = power_outside_light(frames[f], model), want = power_outside_light(left[f], left[f].rgb);
        if (!(have > 0.0) || !(want > 0.0)) continue;
        const double k = std::clamp(want / have, 0.5, 2.0);
        for (Track& t : tracks)
            if (t.glow)
                for (auto& [frame, params] : t.fitted)
                    if (frame == static_cast<int>(f))
                        for (int c = kBorderR; c < kParamCount; ++c) params[c] *= k;
    }
}

// Wide soft glows, one after the other, each fitted to what the ghosts and the glows before it leave, in
// every frame: the many faint ghosts wider than the frame that no detection on the axis separates.
void fit_glows(std::vector<Track>& tracks, const std::vector<Prepared>& frames, const FitOptions& o) {
    for (int g = 0; g < o.glows; ++g) {
        const std::vector<Prepared> residual = residual_frames(frames, tracks, o);
        Track glow;
        glow.glow = true;
        for (std::size_t f = 0; f < residual.size(); ++f) glow.seen.push_back(glow_seed(residual[f], static_cast<int>(f), o));
        fit_track(glow, residual, o);
        if (o.progress) o.progress(fmt::format("glow {}/{}: fitted over {} frames", g + 1, o.glows, glow.fitted.size()));
        tracks.push_back(std::move(glow));
    }
    match_glow_power(tracks, frames, o);
}

}  // namespace

FitResult fit_sweep(const std::vector<SweepFrame>& input, const FitOptions& o) {
    check_frames(input);
    std::vector<Prepared> frames;
    std::vector<std::vector<Detection>> per_frame;
    const std::array<double, 3> background = sweep_background(input);
    for (std::size_t i = 0; i < input.size(); ++i) {
        frames.push_back(prepare(input[i], background, o));
        per_frame.push_back(detect(frames.back(), static_cast<int>(i), o));
        if (o.progress)
            o.progress(fmt::format("frame {}/{} ({:g} deg): background {:.4g}, noise {:.3g}, {} ghosts on the axis", i + 1, input.size(),
                                   input[i].angle_deg, frames.back().background, frames.back().noise, per_frame.back().size()));
        if (o.progress && std::getenv("LENSFX_FIT_DEBUG"))
            for (const Detection& d : per_frame.back())
                o.progress(fmt::format("   at x {:.1f} px, half width {:.1f} px, half height {:.1f} px, snr {:.0f}, light at {:.1f}", d.seed[kPosition] / pixel_mm(o, input[i].width) + 0.5 * input[i].width - 0.5,
                                       d.seed[kLeft] / pixel_mm(o, input[i].width), d.seed[kHeight] / pixel_mm(o, input[i].width), d.snr, frames.back().light_x));
    }
    std::vector<Track> tracks = link(per_frame, o.sensor_width_mm / input[0].width);
    std::erase_if(tracks, [&](const Track& t) { return static_cast<int>(t.seen.size()) < o.min_frames; });
    fit_tracks(tracks, frames, o);
    std::vector<Track> later_pieces;
    for (Track& t : tracks)
        for (Track& piece : t.pieces) later_pieces.push_back(std::move(piece));
    for (Track& piece : later_pieces) tracks.push_back(std::move(piece));
    std::erase_if(tracks, [&](const Track& t) { return static_cast<int>(t.fitted.size()) < o.min_frames; });
    fit_glows(tracks, frames, o);

    FitResult result;
    MeasuredLens& lens = result.lens;
    lens.focal_length_mm = o.focal_length_mm;
    lens.sensor_mm = {o.sensor_width_mm, o.sensor_height_mm};
    lens.capture = o.capture;
    for (const Track& t : tracks) lens.ghosts.push_back(to_polynomials(t, frames));

    // The report, and the light's own energy: what each frame holds beyond the background and the ghosts.
    std::vector<double> light_energy;
    const double pixel_area = (o.sensor_width_mm / input[0].width) * (o.sensor_height_mm / input[0].height);
    for (std::size_t f = 0; f < frames.size(); ++f) {
        const Prepared& p = frames[f];
        MeasuredView view;
        view.sensor_width_mm = o.sensor_width_mm, view.sensor_height_mm = o.sensor_height_mm, view.width = p.width, view.height = p.height;
        std::vector<double> fitted(p.rgb.size(), 0.0);
        std::vector<float> modelled_float(p.rgb.size(), 0.0f);
        FrameFit report;
        report.angle_deg = p.angle_deg, report.background = p.background, report.noise = p.noise;
        for (const Track& t : tracks)
            for (const auto& [frame, params] : t.fitted)
                if (frame == static_cast<int>(f)) {
                    const auto box = ghost_box(params, 0.0, view);
                    if (box[2] <= box[0] || box[3] <= box[1]) continue;
                    add_box(fitted, p.width, box, params, view);
                    ++report.ghosts;
                }
        view.angle_x_deg = p.angle_deg;
        render_add(lens, view, {1.0, 1.0, 1.0}, modelled_float.data());
        const std::vector<double> modelled(modelled_float.begin(), modelled_float.end());
        report.residual = frame_residual(p, fitted);
        report.model_residual = frame_residual(p, modelled);
        double energy = 0.0;
        for (std::size_t i = 0; i < fitted.size() / 3; ++i)
            energy += luminance(p.rgb[i * 3] - fitted[i * 3], p.rgb[i * 3 + 1] - fitted[i * 3 + 1], p.rgb[i * 3 + 2] - fitted[i * 3 + 2]);
        light_energy.push_back(energy * pixel_area);
        result.frames.push_back(report);
    }
    lens.capture.light_energy = std::max(1e-30, median(light_energy));
    return result;
}

}  // namespace lensfx::measured
