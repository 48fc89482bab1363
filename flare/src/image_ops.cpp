// RGB float image operations (flare/image_ops.h).
#include <flare/image_ops.h>

#include <flare/float_range.h>

#include <algorithm>
#include <cmath>
#include <future>
#include <optional>
#include <span>
#include <stdexcept>
#include <system_error>
#include <utility>
#include <vector>

namespace lensfx::flare {

Region nonzero_region(const ConstRgbView& image) {
    Region box{image.x + image.width, image.y + image.height, image.x, image.y};
    for (int y = image.y; y < image.y + image.height; ++y) {
        const float* row = image.at(image.x, y);
        auto lit = [&](int i) { return row[i * 3] != 0.0f || row[i * 3 + 1] != 0.0f || row[i * 3 + 2] != 0.0f; };
        int first = 0;
        while (first < image.width && !lit(first)) ++first;
        if (first == image.width) continue;
        int last = image.width - 1;
        while (!lit(last)) --last;
        box.x0 = std::min(box.x0, image.x + first);
        box.x1 = std::max(box.x1, image.x + last + 1);
        box.y0 = std::min(box.y0, y);
        box.y1 = y + 1;
    }
    return box.empty() ? Region{} : box;
}

void add(const RgbView& dst, const ConstRgbView& src, const Region& region) {
    const Region r = intersection(intersection(region, dst.region()), src.region());
    if (r.empty()) return;
    const auto n = static_cast<std::size_t>(r.width()) * 3;
    for (int y = r.y0; y < r.y1; ++y) {
        float* to = dst.at(r.x0, y);
        const float* from = src.at(r.x0, y);
        for (std::size_t i = 0; i < n; ++i) to[i] = added_within_float(to[i], from[i]);
    }
}

namespace {

// Where output pixel i of n lies on a source of sn pixels stretched over the n, pixel centres aligned and held
// within the outer centres.
double source_position(int i, int n, int sn) { return std::clamp((i + 0.5) * sn / n - 0.5, 0.0, sn - 1.0); }

}  // namespace

std::vector<BilinearTap> bilinear_taps(int n, int sn) {
    std::vector<BilinearTap> out(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        const double u = source_position(i, n, sn);
        const int i0 = std::min(static_cast<int>(u), sn - 1);
        out[static_cast<std::size_t>(i)] = {i0, std::min(i0 + 1, sn - 1), static_cast<float>(u - i0)};
    }
    return out;
}

double mitchell(double x) {
    constexpr double B = 1.0 / 3.0, C = 1.0 / 3.0;
    x = std::abs(x);
    if (x < 1.0) return ((12 - 9 * B - 6 * C) * x * x * x + (-18 + 12 * B + 6 * C) * x * x + (6 - 2 * B)) / 6.0;
    if (x < 2.0) return ((-B - 6 * C) * x * x * x + (6 * B + 30 * C) * x * x + (-12 * B - 48 * C) * x + (8 * B + 24 * C)) / 6.0;
    return 0.0;
}

std::vector<CubicTap> mitchell_taps(int n, int sn) {
    std::vector<CubicTap> out(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        const double u = source_position(i, n, sn);
        const int i0 = std::min(static_cast<int>(u), sn - 1);
        CubicTap& t = out[static_cast<std::size_t>(i)];
        for (int j = 0; j < 4; ++j) t.i[j] = std::clamp(i0 - 1 + j, 0, sn - 1);
        for (int j = 0; j < 4; ++j) t.f[j] = static_cast<float>(mitchell(u - i0 - (j - 1)));
    }
    return out;
}

namespace {

// a to b by f; a itself at f = 0 (so an infinite b there leaves no NaN).
float blend(float a, float b, float f) { return f == 0.0f ? a : a + f * (b - a); }

// A source's rows widened to the output's columns (the taps `xs`), two held at a time: an output row blends two
// of them, and the next output row mostly needs the same two.
class WidenedRows {
public:
    WidenedRows(const ConstRgbView& src, std::vector<BilinearTap> xs) : src_(src), xs_(std::move(xs)) {
        for (auto& row : rows_) row.resize(xs_.size() * 3);
    }
    // Source row `row` (0 = its top) widened; `keep`: a row the caller still needs, not evicted for this one.
    const float* row(int row, int keep) {
        for (std::size_t k = 0; k < 2; ++k)
            if (held_[k] == row) return rows_[k].data();
        const std::size_t k = held_[0] == keep ? 1 : 0;
        const float* in = src_.at(src_.x, src_.y + row);
        float* out = rows_[k].data();
        for (std::size_t x = 0; x < xs_.size(); ++x) {
            const float* a = in + static_cast<std::size_t>(xs_[x].i0) * 3;
            const float* b = in + static_cast<std::size_t>(xs_[x].i1) * 3;
            for (std::size_t c = 0; c < 3; ++c) out[x * 3 + c] = blend(a[c], b[c], xs_[x].f);
        }
        held_[k] = row;
        return out;
    }

private:
    ConstRgbView src_;
    std::vector<BilinearTap> xs_;
    std::vector<float> rows_[2];
    int held_[2] = {-1, -1};
};

}  // namespace

namespace {

// The outputs [first, end) of `taps` (relative to their first) whose taps reach source pixels [s0, s1): the
// others blend two zeros.
std::pair<int, int> reaching(const std::vector<BilinearTap>& taps, int s0, int s1) {
    const auto reaches = [&](const BilinearTap& t) { return (t.i0 >= s0 && t.i0 < s1) || (t.i1 >= s0 && t.i1 < s1); };
    int first = 0, end = static_cast<int>(taps.size());
    while (first < end && !reaches(taps[static_cast<std::size_t>(first)])) ++first;
    while (end > first && !reaches(taps[static_cast<std::size_t>(end - 1)])) --end;
    return {first, end};
}

constexpr int kSplitRows = 256;  // add_resized_each splits its rows over two threads from this many on

// One source of add_resized_each: its taps, the output rows and columns it reaches (r), and its widened rows.
struct Resize {
    Region r;
    std::vector<BilinearTap> ys;
    int region_y0;
    WidenedRows rows;
};

// The resize of src over `region` clipped to dst; nothing when it reaches no pixel of dst (or is dark).
std::optional<Resize> resize_of(const RgbView& dst, const ConstRgbView& src, const Region& region) {
    Region r = intersection(region, dst.region());
    if (r.empty() || src.width <= 0 || src.height <= 0) return std::nullopt;
    // Only what the source's lit pixels reach: an extended light's level sums and tail are dark over most of
    // the frame they are enlarged into.
    const Region lit = nonzero_region(src);
    if (lit.empty()) return std::nullopt;
    const std::vector<BilinearTap> all_xs = bilinear_taps(region.width(), src.width);
    std::vector<BilinearTap> ys = bilinear_taps(region.height(), src.height);
    const auto [cx0, cx1] = reaching(all_xs, lit.x0 - src.x, lit.x1 - src.x);
    const auto [cy0, cy1] = reaching(ys, lit.y0 - src.y, lit.y1 - src.y);
    r = intersection(r, Region{region.x0 + cx0, region.y0 + cy0, region.x0 + cx1, region.y0 + cy1});
    if (r.empty()) return std::nullopt;
    return Resize{r, std::move(ys), region.y0,
                  WidenedRows(src, {all_xs.begin() + static_cast<std::ptrdiff_t>(r.x0 - region.x0),
                                    all_xs.begin() + static_cast<std::ptrdiff_t>(r.x1 - region.x0)})};
}

// Row y of dst += the resize's row y.
void add_row(const RgbView& dst, Resize& z, int y) {
    const BilinearTap t = z.ys[static_cast<std::size_t>(y - z.region_y0)];
    const float* a = z.rows.row(t.i0, t.i1);
    const float* b = z.rows.row(t.i1, t.i0);
    float* to = dst.at(z.r.x0, y);
    const auto n = static_cast<std::size_t>(z.r.width()) * 3;
    for (std::size_t i = 0; i < n; ++i) to[i] = added_within_float(to[i], blend(a[i], b[i], t.f));
}

}  // namespace

void add_resized(const RgbView& dst, const ConstRgbView& src, const Region& region) {
    add_resized_each(dst, std::span(&src, 1), std::span(&region, 1));
}

void add_resized_each(const RgbView& dst, std::span<const ConstRgbView> srcs, std::span<const Region> regions) {
    if (srcs.size() != regions.size()) throw std::invalid_argument("add_resized_each: a region for each source");
    std::vector<Resize> resizes;
    resizes.reserve(srcs.size());
    Region rows{0, dst.y + dst.height, 0, dst.y};  // the rows any of them reaches
    for (std::size_t k = 0; k < srcs.size(); ++k) {
        std::optional<Resize> z = resize_of(dst, srcs[k], regions[k]);
        if (!z) continue;
        rows.y0 = std::min(rows.y0, z->r.y0);
        rows.y1 = std::max(rows.y1, z->r.y1);
        resizes.push_back(std::move(*z));
    }
    // Row by row, each source in turn: a frame row stays in cache while every source adds to it (each pixel's
    // sums in the sources' order, as one add_resized after another). Each half of the rows widens the sources'
    // rows in a copy of its own of `resizes`, which holds no widened row yet.
    split_rows(rows.y0, rows.y1, kSplitRows, [&](int y0, int y1) {
        std::vector<Resize> own = resizes;
        for (int y = y0; y < y1; ++y)
            for (Resize& z : own)
                if (y >= z.r.y0 && y < z.r.y1) add_row(dst, z, y);
    });
}

void split_rows(int y0, int y1, int min_rows, const std::function<void(int, int)>& body) {
    if (y1 - y0 < std::max(min_rows, 2)) return body(y0, y1);
    const int middle = y0 + (y1 - y0) / 2;
    std::future<void> second;
    try {
        second = std::async(std::launch::async, body, middle, y1);
    } catch (const std::system_error&) {  // no thread to be had: this one does every row
        return body(y0, y1);
    }
    try {
        body(y0, middle);
    } catch (...) {
        second.wait();  // body's captures stay alive until the other half is done with them
        throw;
    }
    second.get();
}

void reduce_area(const RgbView& dst, const ConstRgbView& src, int factor) {
    const auto cell_of = [factor](int v) { return v >= 0 ? v / factor : -((factor - 1 - v) / factor); };  // floor(v / f)
    const double scale = 1.0 / (static_cast<double>(factor) * factor);
    std::vector<double> sums(static_cast<std::size_t>(dst.width) * 3);
    for (int y = dst.y; y < dst.y + dst.height; ++y) {
        std::fill(sums.begin(), sums.end(), 0.0);
        const int sy0 = std::max(src.y, y * factor), sy1 = std::min(src.y + src.height, (y + 1) * factor);
        const int sx0 = std::max(src.x, dst.x * factor), sx1 = std::min(src.x + src.width, (dst.x + dst.width) * factor);
        for (int sy = sy0; sy < sy1; ++sy) {
            const float* from = src.at(sx0, sy);
            for (int sx = sx0; sx < sx1; ++sx, from += 3)
                for (std::size_t c = 0; c < 3; ++c)
                    sums[static_cast<std::size_t>(cell_of(sx) - dst.x) * 3 + c] += static_cast<double>(from[c]);
        }
        float* to = dst.at(dst.x, y);
        for (std::size_t i = 0; i < sums.size(); ++i) to[i] = static_cast<float>(sums[i] * scale);
    }
}

void add_enlarged(const RgbView& dst, const ConstRgbView& src, int factor) {
    add_resized(dst, src, Region{src.x * factor, src.y * factor, (src.x + src.width) * factor, (src.y + src.height) * factor});
}

}  // namespace lensfx::flare
