// The measured ghost model: Bezier shape, signed distance, intensity transfer, polynomials, rendering.
#include <measured/model.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <flare/image_ops.h>

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
double pixel_mm(const MeasuredView& view) { return std::min(view.sensor_width_mm / view.width, view.sensor_height_mm / view.height); }

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

double DistanceTable::at(double u, double v) const {
    const double x = (u - u0) / du, y = std::abs(v) / dv;
    if (!(x >= 0.0 && y >= 0.0 && x <= nu - 1.0 && y <= nv - 1.0)) return far;
    const int i = std::min(static_cast<int>(x), nu - 2), j = std::min(static_cast<int>(y), nv - 2);
    const double tx = x - i, ty = y - j;
    const float* row = d.data() + static_cast<std::size_t>(j) * static_cast<std::size_t>(nu) + static_cast<std::size_t>(i);
    const auto at = [&](int k) { return static_cast<double>(row[k]); };
    const double top = at(0) + (at(1) - at(0)) * tx, bottom = at(nu) + (at(nu + 1) - at(nu)) * tx;
    return top + (bottom - top) * ty;
}

DistanceTable distance_table(const GhostParams& p, double spacing_mm) {
    DistanceTable t;
    const double fo = std::max(p[kFallOutside], kMinSize);
    const double u_extent = std::max(p[kLeft], kMinSize) + std::max(p[kRight], kMinSize) + 2.0 * fo, v_extent = std::max(p[kHeight], kMinSize) + fo;
    const auto samples = [&](double extent, int cells) { return std::clamp(static_cast<int>(std::ceil(extent / std::max(spacing_mm, 1e-9))), 1, cells) + 1; };
    t.nu = samples(u_extent, DistanceTable::kCells), t.nv = samples(v_extent, DistanceTable::kCells / 2);
    t.u0 = -std::max(p[kLeft], kMinSize) - fo, t.du = u_extent / (t.nu - 1), t.dv = v_extent / (t.nv - 1), t.far = fo;
    t.d.resize(static_cast<std::size_t>(t.nu) * static_cast<std::size_t>(t.nv));
    for (int j = 0; j < t.nv; ++j)
        for (int i = 0; i < t.nu; ++i)
            t.d[static_cast<std::size_t>(j) * static_cast<std::size_t>(t.nu) + static_cast<std::size_t>(i)] = static_cast<float>(signed_distance(p, t.u0 + i * t.du, j * t.dv));
    return t;
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

double smooth_scale_mm(const GhostParams& p) {
    double border = 0.0, inside = 0.0;
    for (int c = 0; c < 3; ++c) border = std::max(border, p[kBorderR + c]), inside = std::max(inside, p[kInsideR + c]);
    if (!(inside > 0.0) || border > 0.02 * inside || p[kSlopeInside] < 1.0) return 0.0;
    return std::min({p[kFallInside], p[kHeight], 0.5 * (p[kLeft] + p[kRight])});
}

int reduction_for(const GhostParams& p, const MeasuredView& view) {
    const double pixel = std::max(view.sensor_width_mm / view.width, view.sensor_height_mm / view.height), scale = smooth_scale_mm(p);
    int r = 1;
    while (r < 8 && 2 * r <= view.max_reduction && scale >= 8.0 * 2.0 * r * pixel) r *= 2;
    return r;
}

namespace {

// The ghost's table for drawing at sample spacing `spacing_mm`, or none where the view asks for the exact search.
std::optional<DistanceTable> table_for(const GhostParams& p, const MeasuredView& view, double spacing_mm) {
    if (!view.distance_tables) return std::nullopt;
    return distance_table(p, spacing_mm);
}

// Adds ghost p (scaled) at the distance d to the RGB at `out`; nothing beyond the fall-off outside.
void shade(const GhostParams& p, double d, float* out) {
    if (d >= p[kFallOutside]) return;
    const auto [a, b] = level_weights(p, d);
    for (int ch = 0; ch < 3; ++ch) out[ch] += static_cast<float>(p[kBorderR + ch] * a + p[kInsideR + ch] * b);
}

// Adds ghost p (already scaled) at full size into the image, over its pixel box.
void add_full(const GhostParams& p, double roll, const MeasuredView& view, float* rgb) {
    const auto [x0, y0, x1, y1] = ghost_box(p, roll, view);
    if (x1 <= x0 || y1 <= y0) return;
    const std::optional<DistanceTable> table = table_for(p, view, pixel_mm(view));
    const double c = std::cos(roll), s = std::sin(roll);
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
            const double xs = pixel_x_mm(view, x), ys = pixel_y_mm(view, y);
            const double u = xs * c + ys * s - p[kPosition], v = -xs * s + ys * c;
            shade(p, table ? table->at(u, v) : signed_distance(p, u, v),
                  rgb + (static_cast<std::size_t>(y) * static_cast<std::size_t>(view.width) + static_cast<std::size_t>(x)) * 3);
        }
}

}  // namespace

ReducedGrid reduced_grid(const MeasuredView& view, int reduction) {
    ReducedGrid g;
    g.reduction = reduction;
    g.width = (view.width + reduction - 1) / reduction + 2, g.height = (view.height + reduction - 1) / reduction + 2;
    return g;
}

double ReducedGrid::pixel_of(int sample) const { return (sample - 1) * reduction + 0.5 * (reduction - 1); }

void render_reduced(const GhostParams& p, double roll, const MeasuredView& view, const ReducedGrid& grid, float* samples) {
    const double c = std::cos(roll), s = std::sin(roll);
    const auto [x0, y0, x1, y1] = ghost_box(p, roll, view);  // outside it the ghost is 0
    const double r = grid.reduction;
    const std::optional<DistanceTable> table = table_for(p, view, r * pixel_mm(view));
    for (int j = 0; j < grid.height; ++j)
        for (int i = 0; i < grid.width; ++i) {
            if (grid.pixel_of(i) < x0 - r || grid.pixel_of(i) >= x1 + r || grid.pixel_of(j) < y0 - r || grid.pixel_of(j) >= y1 + r) continue;
            const double xs = pixel_x_mm(view, grid.pixel_of(i)), ys = pixel_y_mm(view, grid.pixel_of(j));
            const double u = xs * c + ys * s - p[kPosition], v = -xs * s + ys * c;
            shade(p, table ? table->at(u, v) : signed_distance(p, u, v),
                  samples + (static_cast<std::size_t>(j) * static_cast<std::size_t>(grid.width) + static_cast<std::size_t>(i)) * 3);
        }
}

void add_upsampled(const ReducedGrid& grid, const float* samples, const MeasuredView& view, float* rgb) {
    // Sample i lies at pixel (i - 1) r + (r - 1) / 2: the samples spread evenly over [-r, (width - 1) r).
    const int r = grid.reduction;
    flare::add_resized(flare::RgbView{rgb, 0, 0, view.width, view.height}, flare::ConstRgbView{samples, 0, 0, grid.width, grid.height},
                       flare::Region{-r, -r, (grid.width - 1) * r, (grid.height - 1) * r});
}

std::vector<GhostParams> ghosts_at(const MeasuredLens& lens, double field, std::array<double, 3> scale) {
    std::vector<GhostParams> out;
    for (const MeasuredGhost& g : lens.ghosts) {
        if (!g.covers(field)) continue;
        GhostParams p = g.at(field);
        for (int ch = 0; ch < 3; ++ch) p[kBorderR + ch] *= scale[static_cast<std::size_t>(ch)], p[kInsideR + ch] *= scale[static_cast<std::size_t>(ch)];
        out.push_back(p);
    }
    return out;
}

void render_add(const MeasuredLens& lens, const MeasuredView& view, std::array<double, 3> scale, float* rgb) {
    const auto [field, roll] = field_and_roll(view.angle_x_deg, view.angle_y_deg);
    for (int reduction : {1, 2, 4, 8}) {
        const ReducedGrid grid = reduced_grid(view, reduction);
        std::vector<float> samples;
        for (const GhostParams& p : ghosts_at(lens, field, scale)) {
            if (reduction_for(p, view) != reduction) continue;
            if (reduction == 1) {
                add_full(p, roll, view, rgb);
                continue;
            }
            samples.resize(static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height) * 3, 0.0f);
            render_reduced(p, roll, view, grid, samples.data());
        }
        if (!samples.empty()) add_upsampled(grid, samples.data(), view, rgb);
    }
}

}  // namespace lensfx::measured
