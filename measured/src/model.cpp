// The measured ghost model: Bezier shape, signed distance, intensity transfer, polynomials, rendering.
#include <measured/model.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace lensfx::measured {

namespace {

struct Point {
    double x, y;
};

// The upper segment of one side: from (side, 0) to (0, h), control points axis-aligned (C1 at both ends).
struct Segment {
    Point p0, p1, p2, p3;
    Point at(double t) const {
        const double s = 1.0 - t, a = s * s * s, b = 3.0 * s * s * t, c = 3.0 * s * t * t, d = t * t * t;
        return {a * p0.x + b * p1.x + c * p2.x + d * p3.x, a * p0.y + b * p1.y + c * p2.y + d * p3.y};
    }
};

Segment side_segment(double extent, double curve, double h) {
    return {{extent, 0.0}, {extent, curve * h}, {curve * extent, h}, {0.0, h}};
}

double squared_distance(const Segment& s, double t, double u, double v) {
    const Point q = s.at(t);
    return (q.x - u) * (q.x - u) + (q.y - v) * (q.y - v);
}

// The nearest distance from (u, v) to a segment: the best of 17 samples, refined by a golden-section
// search within one sample step (the paper's binary search, 12 steps).
double distance_to(const Segment& s, double u, double v) {
    constexpr int kSamples = 16;
    int best = 0;
    double best_d = std::numeric_limits<double>::max();
    for (int i = 0; i <= kSamples; ++i) {
        const double d = squared_distance(s, static_cast<double>(i) / kSamples, u, v);
        if (d < best_d) best_d = d, best = i;
    }
    double lo = std::max(0.0, (best - 1.0) / kSamples), hi = std::min(1.0, (best + 1.0) / kSamples);
    constexpr double kGolden = 0.6180339887498949;
    double a = hi - kGolden * (hi - lo), b = lo + kGolden * (hi - lo);
    double fa = squared_distance(s, a, u, v), fb = squared_distance(s, b, u, v);
    for (int i = 0; i < 12; ++i) {
        if (fa < fb) {
            hi = b, b = a, fb = fa;
            a = hi - kGolden * (hi - lo), fa = squared_distance(s, a, u, v);
        } else {
            lo = a, a = b, fa = fb;
            b = lo + kGolden * (hi - lo), fb = squared_distance(s, b, u, v);
        }
    }
    return std::sqrt(std::min({best_d, fa, fb}));
}

// The segment's height over |u| (x runs monotonically from the side to 0 for curves in [0, 1]).
double height_over(const Segment& s, double u_abs) {
    double lo = 0.0, hi = 1.0;  // x(lo) = side >= u_abs >= x(hi) = 0
    for (int i = 0; i < 20; ++i) {
        const double mid = 0.5 * (lo + hi);
        (s.at(mid).x > u_abs ? lo : hi) = mid;
    }
    return s.at(0.5 * (lo + hi)).y;
}

constexpr double kMinSize = 1e-4;  // mm

double pixel_x_mm(const MeasuredView& view, double px) { return (px + 0.5 - 0.5 * view.width) * view.sensor_width_mm / view.width; }
double pixel_y_mm(const MeasuredView& view, double py) { return (0.5 * view.height - (py + 0.5)) * view.sensor_height_mm / view.height; }

}  // namespace

const std::array<const char*, kParamCount>& param_names() {
    static const std::array<const char*, kParamCount> names{
        "position",   "left",          "right",        "height",         "curve_left", "curve_right", "fall_inside", "slope_inside",
        "fall_outside", "slope_outside", "border_r", "border_g", "border_b", "inside_r", "inside_g", "inside_b"};
    return names;
}

GhostParams disc_ghost(double m_mm, double r_mm, std::array<double, 3> level) {
    GhostParams p{};
    p[kPosition] = m_mm;
    p[kLeft] = p[kRight] = p[kHeight] = r_mm;
    p[kCurveLeft] = p[kCurveRight] = 0.5523;
    p[kFallInside] = 0.25 * r_mm;
    p[kSlopeInside] = 1.0;
    p[kFallOutside] = 0.05 * r_mm;
    p[kSlopeOutside] = 1.0;
    for (int c = 0; c < 3; ++c) p[kBorderR + c] = p[kInsideR + c] = level[static_cast<std::size_t>(c)];
    return p;
}

GhostParams clamped(GhostParams p) {
    for (int i : {kLeft, kRight, kHeight, kFallInside, kFallOutside}) p[i] = std::max(p[i], kMinSize);
    for (int i : {kCurveLeft, kCurveRight}) p[i] = std::clamp(p[i], 0.0, 1.0);
    for (int i : {kSlopeInside, kSlopeOutside}) p[i] = std::clamp(p[i], 0.05, 20.0);
    for (int i = kBorderR; i < kParamCount; ++i) p[i] = std::max(p[i], 0.0);
    return p;
}

double signed_distance(const GhostParams& p, double u, double v) {
    v = std::abs(v);
    const Segment right = side_segment(std::max(p[kRight], kMinSize), p[kCurveRight], std::max(p[kHeight], kMinSize));
    const Segment left = side_segment(std::max(p[kLeft], kMinSize), p[kCurveLeft], std::max(p[kHeight], kMinSize));
    const Segment& near = u >= 0.0 ? right : left;
    const Segment& far = u >= 0.0 ? left : right;
    // The far side's segment lies at |u| or more from (u, v): it is nearer only when the near one is farther.
    double d = distance_to(near, std::abs(u), v);
    if (d > std::abs(u)) d = std::min(d, distance_to(far, -std::abs(u), v));
    const bool inside = std::abs(u) < near.p0.x && v < near.p3.y && v < height_over(near, std::abs(u));
    return inside ? -d : d;
}

std::array<double, 2> level_weights(const GhostParams& p, double d) {
    if (d <= 0.0) {
        const double t = std::min(1.0, -d / std::max(p[kFallInside], kMinSize));
        const double a = std::pow(1.0 - t, p[kSlopeInside]);
        return {a, 1.0 - a};
    }
    const double t = std::min(1.0, d / std::max(p[kFallOutside], kMinSize));
    return {std::pow(1.0 - t, p[kSlopeOutside]), 0.0};
}

double intensity(const GhostParams& p, int c, double d) {
    const auto [a, b] = level_weights(p, d);
    return p[kBorderR + c] * a + p[kInsideR + c] * b;
}

GhostParams MeasuredGhost::at(double angle_deg) const {
    GhostParams p{};
    for (int i = 0; i < kParamCount; ++i) {
        const auto& c = poly[static_cast<std::size_t>(i)];
        p[i] = c[0] + angle_deg * (c[1] + angle_deg * c[2]);
    }
    return clamped(p);
}

double brightness_scale(const Capture& capture, const Capture& target, double light_ratio) {
    const double f_ratio = capture.f_number > 0.0 && target.f_number > 0.0 ? capture.f_number * capture.f_number / (target.f_number * target.f_number) : 1.0;
    return f_ratio * (target.iso / capture.iso) * (target.exposure_s / capture.exposure_s) * light_ratio;
}

std::array<double, 2> field_and_roll(double ax_deg, double ay_deg) {
    constexpr double k = 3.14159265358979323846 / 180.0;
    const double tx = std::tan(ax_deg * k), ty = std::tan(ay_deg * k);
    return {std::atan(std::hypot(tx, ty)) / k, std::atan2(ty, tx)};
}

std::array<int, 4> ghost_box(const GhostParams& p, double roll_rad, const MeasuredView& view) {
    const double c = std::cos(roll_rad), s = std::sin(roll_rad);
    const double u0 = p[kPosition] - p[kLeft] - p[kFallOutside], u1 = p[kPosition] + p[kRight] + p[kFallOutside];
    const double v1 = p[kHeight] + p[kFallOutside];
    const double pw = view.sensor_width_mm / view.width, ph = view.sensor_height_mm / view.height;
    double x_lo = 1e300, x_hi = -1e300, y_lo = 1e300, y_hi = -1e300;
    for (double u : {u0, u1})
        for (double v : {-v1, v1}) {
            const double xs = u * c - v * s, ys = u * s + v * c;
            const double px = xs / pw + 0.5 * view.width - 0.5, py = 0.5 * view.height - ys / ph - 0.5;
            x_lo = std::min(x_lo, px), x_hi = std::max(x_hi, px), y_lo = std::min(y_lo, py), y_hi = std::max(y_hi, py);
        }
    auto clamp_to = [](double v, int n) { return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(n))); };
    return {clamp_to(std::floor(x_lo) - 1, view.width), clamp_to(std::floor(y_lo) - 1, view.height), clamp_to(std::ceil(x_hi) + 2, view.width),
            clamp_to(std::ceil(y_hi) + 2, view.height)};
}

void render_ghost_box(const GhostParams& p, double roll_rad, const MeasuredView& view, int x0, int y0, int x1, int y1, float* rgb) {
    const double c = std::cos(roll_rad), s = std::sin(roll_rad);
    const int w = x1 - x0;
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
            const double xs = pixel_x_mm(view, x), ys = pixel_y_mm(view, y);
            const double u = xs * c + ys * s - p[kPosition], v = -xs * s + ys * c;
            const double d = signed_distance(p, u, v);
            const auto [a, b] = level_weights(p, d);
            float* out = rgb + (static_cast<std::size_t>(y - y0) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x - x0)) * 3;
            for (int ch = 0; ch < 3; ++ch) out[ch] += static_cast<float>(p[kBorderR + ch] * a + p[kInsideR + ch] * b);
        }
}

void render_add(const MeasuredLens& lens, const MeasuredView& view, std::array<double, 3> scale, float* rgb) {
    const auto [field, roll] = field_and_roll(view.angle_x_deg, view.angle_y_deg);
    for (const MeasuredGhost& g : lens.ghosts) {
        if (!g.covers(field)) continue;
        GhostParams p = g.at(field);
        for (int ch = 0; ch < 3; ++ch) p[kBorderR + ch] *= scale[static_cast<std::size_t>(ch)], p[kInsideR + ch] *= scale[static_cast<std::size_t>(ch)];
        const auto [x0, y0, x1, y1] = ghost_box(p, roll, view);
        if (x1 <= x0 || y1 <= y0) continue;
        std::vector<float> box(static_cast<std::size_t>(x1 - x0) * static_cast<std::size_t>(y1 - y0) * 3, 0.0f);
        render_ghost_box(p, roll, view, x0, y0, x1, y1, box.data());
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x)
                for (int ch = 0; ch < 3; ++ch)
                    rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(view.width) + static_cast<std::size_t>(x)) * 3 + static_cast<std::size_t>(ch)] +=
                        box[(static_cast<std::size_t>(y - y0) * static_cast<std::size_t>(x1 - x0) + static_cast<std::size_t>(x - x0)) * 3 + static_cast<std::size_t>(ch)];
    }
}

}  // namespace lensfx::measured
