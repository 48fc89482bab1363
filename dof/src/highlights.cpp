// Highlights scattered as bokeh instead of gathered (see highlights.h).
#include <dof/highlights.h>

#include <algorithm>
#include <numbers>
#include <numeric>
#include <cmath>
#include <map>
#include <unordered_map>

#include <dof/renderer.h>

namespace lensfx::dof {

namespace {

using Point = std::array<double, 2>;

std::size_t index(int x, int y, int width) { return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x); }

// The minimum (or maximum) of each run of 2 r + 1 values of a line padded with r neutral values at either
// end (van Herk / Gil-Werman: a running extreme forward and backward within blocks of 2 r + 1, three
// comparisons per value whatever r). line: n + 2 r values, padded; out: n.
void line_extreme(const std::vector<float>& line, int r, bool largest, std::vector<float>& forward, std::vector<float>& backward, float* out, int n) {
    const auto pick = [largest](float a, float b) { return largest ? std::max(a, b) : std::min(a, b); };
    const int k = 2 * r + 1, m = static_cast<int>(line.size());
    for (int i = 0; i < m; ++i) forward[static_cast<std::size_t>(i)] = i % k == 0 ? line[static_cast<std::size_t>(i)] : pick(forward[static_cast<std::size_t>(i - 1)], line[static_cast<std::size_t>(i)]);
    for (int i = m - 1; i >= 0; --i)
        backward[static_cast<std::size_t>(i)] = (i % k == k - 1 || i == m - 1) ? line[static_cast<std::size_t>(i)] : pick(backward[static_cast<std::size_t>(i + 1)], line[static_cast<std::size_t>(i)]);
    for (int i = 0; i < n; ++i) out[i] = pick(backward[static_cast<std::size_t>(i)], forward[static_cast<std::size_t>(i + 2 * r)]);
}

// The minimum (or maximum) of `plane` over a (2 r + 1)^2 square around each pixel, clamped at the edges.
std::vector<float> square_extreme(const std::vector<float>& plane, int width, int height, int r, bool largest) {
    const float neutral = largest ? -1e30f : 1e30f;
    std::vector<float> rows(plane.size()), out(plane.size()), col(static_cast<std::size_t>(height));
    const std::size_t longest = static_cast<std::size_t>(std::max(width, height) + 2 * r);
    std::vector<float> line(longest), forward(longest), backward(longest);
    line.assign(static_cast<std::size_t>(width + 2 * r), neutral);
    for (int y = 0; y < height; ++y) {
        std::copy_n(plane.begin() + static_cast<std::ptrdiff_t>(index(0, y, width)), width, line.begin() + r);
        line_extreme(line, r, largest, forward, backward, &rows[index(0, y, width)], width);
    }
    line.assign(static_cast<std::size_t>(height + 2 * r), neutral);
    for (int x = 0; x < width; ++x) {
        for (int y = 0; y < height; ++y) line[static_cast<std::size_t>(y + r)] = rows[index(x, y, width)];
        line_extreme(line, r, largest, forward, backward, col.data(), height);
        for (int y = 0; y < height; ++y) out[index(x, y, width)] = col[static_cast<std::size_t>(y)];
    }
    return out;
}

// The plate's level under small bright features: channel c's grey opening (erosion, then dilation), interleaved.
std::vector<float> opening(const std::vector<float>& rgb, int width, int height, int r) {
    std::vector<float> out(rgb.size());
    std::vector<float> plane(rgb.size() / 3);
    for (std::size_t c = 0; c < 3; ++c) {
        for (std::size_t i = 0; i < plane.size(); ++i) plane[i] = rgb[3 * i + c];
        const std::vector<float> open = square_extreme(square_extreme(plane, width, height, r, false), width, height, r, true);
        for (std::size_t i = 0; i < plane.size(); ++i) out[3 * i + c] = open[i];
    }
    return out;
}

// Inverse depth of a depth in metres; none, 0 or not finite: at infinity (1e9 m, as the layers take it).
float inverse_depth(float metres) { return std::isfinite(metres) && metres > 0.0f ? 1.0f / std::min(metres, 1e9f) : 1e-9f; }

// The largest distance (px) at inverse depth w of the achromatic band's first 32 rays at (px, py) from where
// they cross the focus: the bokeh's radius.
double bokeh_radius(const RayTable& table, double px, double py, double w) {
    double r = 0.0;
    for (int k = 0; k < std::min(32, table.samples); ++k) {
        const ScreenRay ray = ray_at(table, table.achromatic, px, py, k);
        if (ray.weight > 0.0f) r = std::max(r, std::hypot(double{ray.ax}, double{ray.ay}) * std::abs(w - table.focus_w));
    }
    return r;
}

// Convex hull (counter-clockwise, Andrew's monotone chain) of `points`.
std::vector<Point> convex_hull(std::vector<Point> points) {
    std::sort(points.begin(), points.end());
    if (points.size() < 3) return points;
    const auto turn = [](const Point& o, const Point& a, const Point& b) { return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]); };
    std::vector<Point> hull(2 * points.size());
    std::size_t k = 0;
    for (const Point& p : points) {
        while (k >= 2 && turn(hull[k - 2], hull[k - 1], p) <= 0.0) --k;
        hull[k++] = p;
    }
    for (std::size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
        while (k >= lower && turn(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
        hull[k++] = points[i];
    }
    hull.resize(k - 1);
    return hull;
}

// Where band b's ray k at raster position s meets the pixels that see s at inverse depth w: its crossing
// there mirrored through s and scaled by the lens's magnification of that depth (ray_at's line is the
// pixel's; pixels around it see s where their rays cross it), in the layers' pixels; false if stopped.
bool bokeh_point(const RayTable& table, int band, int k, Point s, double w, double scale, Point origin, Point& out) {
    const ScreenRay r = ray_at(table, band, s[0], s[1], k);
    if (r.weight <= 0.0f) return false;
    const double qx = double{r.cx} + double{r.ax} * w, qy = double{r.cy} + double{r.ay} * w;
    out = {s[0] + (s[0] - qx) / scale - origin[0], s[1] + (s[1] - qy) / scale - origin[1]};
    return true;
}

// Each point's distance to its nearest neighbour, up to about twice the mean spacing (farther: 1e300),
// through buckets of the mean spacing (5 x 5 of them around each point).
std::vector<double> nearest_distances(const std::vector<Point>& points) {
    double xmin = 1e300, ymin = 1e300, xmax = -1e300, ymax = -1e300;
    for (const Point& p : points) xmin = std::min(xmin, p[0]), ymin = std::min(ymin, p[1]), xmax = std::max(xmax, p[0]), ymax = std::max(ymax, p[1]);
    const double cell = std::max(1e-9, std::sqrt((xmax - xmin) * (ymax - ymin) / static_cast<double>(points.size())));
    const int nx = static_cast<int>((xmax - xmin) / cell) + 1, ny = static_cast<int>((ymax - ymin) / cell) + 1;
    const auto bucket_of = [&](const Point& p) { return std::array<int, 2>{static_cast<int>((p[0] - xmin) / cell), static_cast<int>((p[1] - ymin) / cell)}; };
    std::vector<std::vector<std::size_t>> buckets(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
    for (std::size_t i = 0; i < points.size(); ++i) buckets[index(bucket_of(points[i])[0], bucket_of(points[i])[1], nx)].push_back(i);
    std::vector<double> nearest(points.size(), 1e300);
    for (std::size_t i = 0; i < points.size(); ++i) {
        const auto [bx, by] = bucket_of(points[i]);
        for (int y = std::max(0, by - 2); y <= std::min(ny - 1, by + 2); ++y)
            for (int x = std::max(0, bx - 2); x <= std::min(nx - 1, bx + 2); ++x)
                for (std::size_t j : buckets[index(x, y, nx)])
                    if (j != i) nearest[i] = std::min(nearest[i], std::hypot(points[i][0] - points[j][0], points[i][1] - points[j][1]));
    }
    return nearest;
}

// The points without strays: a few rays that graze a clear aperture land far outside the pupil's image,
// alone; a point whose nearest neighbour is more than twice the median such distance away is dropped
// (from `index` too).
std::vector<Point> without_strays(const std::vector<Point>& points, std::vector<int>& index) {
    if (points.size() < 8) return points;
    const std::vector<double> nearest = nearest_distances(points);
    std::vector<double> sorted = nearest;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double limit = 2.0 * sorted[sorted.size() / 2];
    std::vector<Point> kept;
    std::vector<int> kept_index;
    for (std::size_t i = 0; i < points.size(); ++i)
        if (nearest[i] <= limit) kept.push_back(points[i]), kept_index.push_back(index[i]);
    index = std::move(kept_index);
    return kept;
}

// The samples whose points span the bokeh (its hull's corners) are nearly the same for every highlight of
// a 32 px tile, whatever its depth (the points scale with w - focus_w): found once per tile and band from
// every sample, then only those are evaluated.
class HullSamples {
public:
    std::vector<Point> hull(const RayTable& table, int band, Point s, double w, double scale, Point origin) {
        const long key = (static_cast<long>(s[1]) / 32 * 65536 + static_cast<long>(s[0]) / 32) * table.channels + band;
        auto it = corners_.find(key);
        if (it == corners_.end()) it = corners_.emplace(key, corner_samples(table, band, s, w, scale, origin)).first;
        std::vector<Point> points;
        Point p{};
        for (int k : it->second)
            if (bokeh_point(table, band, k, s, w, scale, origin, p)) points.push_back(p);
        return convex_hull(points);
    }

private:
    static std::vector<int> corner_samples(const RayTable& table, int band, Point s, double w, double scale, Point origin) {
        std::vector<Point> points;
        std::vector<int> index;
        Point p{};
        for (int k = 0; k < table.samples; ++k)
            if (bokeh_point(table, band, k, s, w, scale, origin, p)) points.push_back(p), index.push_back(k);
        points = without_strays(points, index);
        const std::vector<Point> corners = convex_hull(points);
        std::vector<int> out;
        for (const Point& c : corners) out.push_back(index[static_cast<std::size_t>(std::find(points.begin(), points.end(), c) - points.begin())]);
        return out;
    }
    std::unordered_map<long, std::vector<int>> corners_;
};

// dof::scene_scale per band and inverse depth, each computed once (highlights share a few depths).
class SceneScales {
public:
    double at(const RayTable& table, int band, float w) {
        const auto key = std::make_pair(band, w);
        auto it = known_.find(key);
        if (it == known_.end()) it = known_.emplace(key, scene_scale(table, band, double{w})).first;
        return it->second;
    }

private:
    std::map<std::pair<int, float>, double> known_;
};

// A convex polygon's coverage of each pixel of its bounding box (4 sub-rows per row, exact along them).
struct Coverage {
    int x0 = 0, y0 = 0, width = 0, height = 0;
    std::vector<double> area;
    double total = 0.0;
};

// The polygon's left and right x at height y (false where it does not reach y).
bool span_at(const std::vector<Point>& poly, double y, double& left, double& right) {
    left = 1e300, right = -1e300;
    for (std::size_t i = 0; i < poly.size(); ++i) {
        const Point& a = poly[i];
        const Point& b = poly[(i + 1) % poly.size()];
        if ((a[1] <= y) == (b[1] <= y)) continue;
        const double x = a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
        left = std::min(left, x), right = std::max(right, x);
    }
    return left < right;
}

// The coverage of a convex polygon (at least three corners).
Coverage cover(const std::vector<Point>& poly) {
    constexpr int kSub = 4;
    double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
    for (const Point& p : poly) xmin = std::min(xmin, p[0]), xmax = std::max(xmax, p[0]), ymin = std::min(ymin, p[1]), ymax = std::max(ymax, p[1]);
    Coverage c;
    c.x0 = static_cast<int>(std::floor(xmin)), c.y0 = static_cast<int>(std::floor(ymin));
    c.width = static_cast<int>(std::floor(xmax)) - c.x0 + 1, c.height = static_cast<int>(std::floor(ymax)) - c.y0 + 1;
    c.area.assign(static_cast<std::size_t>(c.width) * static_cast<std::size_t>(c.height), 0.0);
    for (int row = 0; row < c.height; ++row)
        for (int j = 0; j < kSub; ++j) {
            double left = 0.0, right = 0.0;
            if (!span_at(poly, c.y0 + row + (j + 0.5) / kSub, left, right)) continue;
            for (int x = static_cast<int>(std::floor(left)); x <= static_cast<int>(std::floor(right)); ++x) {
                const double overlap = (std::min(x + 1.0, right) - std::max(double(x), left)) / kSub;
                c.area[index(x - c.x0, row, c.width)] += overlap;
                c.total += overlap;
            }
        }
    return c;
}

// Adds `energy` (R, G, B) spread over the coverage to rgb, except where a nearer surface hides inverse depth w.
void add_spread(const Coverage& c, const std::array<double, 3>& energy, float w, const std::vector<float>& front_m, int width, int height,
                double step, std::vector<float>& rgb) {
    if (!(c.total > 0.0)) return;
    const double hidden_above = double{w} * (1.0 + step);
    for (int row = 0; row < c.height; ++row) {
        const int y = c.y0 + row;
        if (y < 0 || y >= height) continue;
        for (int col = 0; col < c.width; ++col) {
            const int x = c.x0 + col;
            const double share = c.area[index(col, row, c.width)] / c.total;
            if (x < 0 || x >= width || share <= 0.0 || double{inverse_depth(front_m[index(x, y, width)])} > hidden_above) continue;
            for (std::size_t ch = 0; ch < 3; ++ch) rgb[3 * index(x, y, width) + ch] += static_cast<float>(energy[ch] * share);
        }
    }
}

// Per cell of the table's grid, 1 where every band's rays stay within 0.1 px of the achromatic band's over
// the highlights' depths (dof::achromatic_cells, as the gather's): one blur serves every band there. All 1
// without chromatic blur.
std::vector<float> one_blur_cells(const std::vector<Highlight>& highlights, const RayTable& table, bool chromatic) {
    const std::size_t cells = static_cast<std::size_t>(table.grid_x - 1) * static_cast<std::size_t>(table.grid_y - 1);
    if (!chromatic) return std::vector<float>(cells, 1.0f);
    float w_near = 0.0f, w_far = 1e30f;
    for (const Highlight& h : highlights) w_near = std::max(w_near, h.w), w_far = std::min(w_far, h.w);
    return achromatic_cells(table, double{w_near}, double{w_far}, 0.1);
}

// The cell of the table's grid that raster position s lies in (row-major, as achromatic_cells).
std::size_t cell_of(const RayTable& table, Point s) {
    const int x = std::clamp(static_cast<int>(s[0] / table.cell_w), 0, table.grid_x - 2), y = std::clamp(static_cast<int>(s[1] / table.cell_h), 0, table.grid_y - 2);
    return index(x, y, table.grid_x - 1);
}

// The brightest of `found` (by the sum of their excess), from the brightest down while there are at most `count`
// and their areas sum to at most `max_area`, less any as bright as the first left out, in the plate's order; the
// others stay in the plate, with the gather.
void keep_brightest_within(std::vector<Highlight>& found, const std::vector<double>& area, std::size_t count, double max_area) {
    std::vector<std::size_t> order(found.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    const auto energy = [&](std::size_t k) { return found[k].excess[0] + found[k].excess[1] + found[k].excess[2]; };
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return energy(a) > energy(b); });
    std::size_t n = 0;
    double used = 0.0;
    for (; n < order.size() && n < count && used + area[order[n]] <= max_area; ++n) used += area[order[n]];
    if (n == found.size()) return;
    // Lights as bright as the first left out are all left out: a cap splitting equal lights by their place
    // would splat a band of them and gather the rest (a field of equal lights is gathered smooth).
    while (n > 0 && energy(order[n - 1]) == energy(order[n])) --n;
    order.resize(n);
    std::sort(order.begin(), order.end());  // kept in the plate's order
    std::vector<Highlight> kept;
    for (const std::size_t k : order) kept.push_back(found[k]);
    found = std::move(kept);
}

}  // namespace

std::vector<Highlight> take_highlights(std::vector<float>& rgb, const std::vector<float>& depth_m, int width, int height,
                                       const RayTable& table, int origin_x, int origin_y, const HighlightSettings& settings) {
    std::vector<Highlight> found;
    // a highlight's excess is at most its value: a plate with none that bright has none (no opening to compute)
    if (std::none_of(rgb.begin(), rgb.end(), [&](float v) { return double{v} >= settings.min_excess; }) || settings.max_count == 0) return found;
    const std::vector<float> level = opening(rgb, width, height, settings.radius);
    std::vector<double> area;  // each one's bokeh's, pi r^2 (pixels)
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const std::size_t i = index(x, y, width);
            Highlight h{x, y, inverse_depth(depth_m[i]), {}};
            float most = 0.0f, base = 0.0f;
            for (std::size_t c = 0; c < 3; ++c) {
                h.excess[c] = std::max(0.0f, rgb[3 * i + c] - level[3 * i + c]);
                most = std::max(most, h.excess[c]), base = std::max(base, level[3 * i + c]);
            }
            if (!(double{most} >= settings.min_excess && double{most} >= settings.min_ratio * double{base})) continue;
            const double r = bokeh_radius(table, x + 0.5 + origin_x, y + 0.5 + origin_y, h.w);
            if (r < settings.min_blur_px) continue;
            found.push_back(h);
            area.push_back(std::numbers::pi * r * r);
        }
    keep_brightest_within(found, area, settings.max_count, settings.max_area_ratio * width * height);
    for (const Highlight& h : found)
        for (std::size_t c = 0; c < 3; ++c) rgb[3 * index(h.x, h.y, width) + c] -= h.excess[c];
    return found;
}

void splat_highlights(const std::vector<Highlight>& highlights, const RayTable& table, int origin_x, int origin_y, bool chromatic,
                      const std::vector<float>& front_m, int width, int height, std::vector<float>& rgb, double step) {
    HullSamples hulls;
    SceneScales scales;
    const Point origin{double(origin_x), double(origin_y)};
    const std::vector<float> one_blur = one_blur_cells(highlights, table, chromatic);
    for (const Highlight& h : highlights) {
        const Point s{h.x + 0.5 + origin_x, h.y + 0.5 + origin_y};
        const bool one = one_blur[cell_of(table, s)] > 0.5f;
        for (int b = 0; b < table.channels; ++b) {
            if (one && b != table.achromatic) continue;
            const std::array<float, 3> mix = one ? std::array<float, 3>{1.0f, 1.0f, 1.0f} : table.channel_weight[static_cast<std::size_t>(b)];
            std::array<double, 3> energy{};
            for (std::size_t c = 0; c < 3; ++c) energy[c] = double{mix[c]} * double{h.excess[c]};
            if (energy[0] <= 0.0 && energy[1] <= 0.0 && energy[2] <= 0.0) continue;
            // the gather images a point at this depth with the lens's magnification there, so its energy too
            const double scale = scales.at(table, b, h.w);
            const double j = scale > 0.0 ? scale : 1.0;
            for (double& e : energy) e /= j * j;
            const std::vector<Point> hull = hulls.hull(table, b, s, double{h.w}, j, origin);
            if (hull.size() >= 3) {
                add_spread(cover(hull), energy, h.w, front_m, width, height, step, rgb);
                continue;
            }
            for (std::size_t c = 0; c < 3; ++c) rgb[3 * index(h.x, h.y, width) + c] += static_cast<float>(energy[c]);  // no area: kept in place
        }
    }
}

}  // namespace lensfx::dof
