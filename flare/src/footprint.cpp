// Extended sources: footprint groups and the footprint convolution.
#include <flare/footprint.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <numbers>

#include <flare/convolve.h>
#include <flare/image_ops.h>
#include <opencv2/core.hpp>

namespace lensfx::flare {

namespace {

// A light's footprint as a function of the offset from the light in pixels: its weight interpolated
// bilinearly between cell centres (cells of many pixels would otherwise print their squares), 0 beyond half
// a cell outside it.
struct FootprintSampler {
    const detect::Shape& shape;
    double cell = std::max(1e-6, shape.cell);
    double x0 = shape.origin_x, y0 = shape.origin_y;
    double x1 = x0 + shape.width * cell, y1 = y0 + shape.height * cell;

    float cell_weight(int i, int j) const {
        if (i < 0 || j < 0 || i >= shape.width || j >= shape.height) return 0.0f;
        return shape.weights[static_cast<std::size_t>(j) * static_cast<std::size_t>(shape.width) + static_cast<std::size_t>(i)];
    }
    template <class Of>
    float interpolate(double ox, double oy, Of of) const {
        const double u = (ox - x0) / cell - 0.5, v = (oy - y0) / cell - 0.5;
        if (!(u > -1.0 && v > -1.0 && u < shape.width && v < shape.height)) return 0.0f;
        const int i = static_cast<int>(std::floor(u)), j = static_cast<int>(std::floor(v));
        const float fu = static_cast<float>(u - i), fv = static_cast<float>(v - j);
        return (1.0f - fv) * ((1.0f - fu) * of(cell_weight(i, j)) + fu * of(cell_weight(i + 1, j))) +
               fv * ((1.0f - fu) * of(cell_weight(i, j + 1)) + fu * of(cell_weight(i + 1, j + 1)));
    }
    float operator()(double ox, double oy) const {
        return interpolate(ox, oy, [](float w) { return w; });
    }
    // 1 where the light's own pixels are (its cells holding any of its light), 0 beyond, interpolated alike.
    float inside(double ox, double oy) const {
        return interpolate(ox, oy, [](float w) { return w > 0.0f ? 1.0f : 0.0f; });
    }
    // Half-widths in pixels of the kernel at magnification m (computed in double, kept within int range).
    int reach_x(double m) const { return reach(m, std::max(std::abs(x0), std::abs(x1))); }
    int reach_y(double m) const { return reach(m, std::max(std::abs(y0), std::abs(y1))); }
    int reach(double m, double extent) const {
        const double r = std::ceil(std::abs(m) * (extent + 0.5 * cell)) + 1.0;
        return r < kMaxReach ? static_cast<int>(r) : kMaxReach;
    }
    static constexpr int kMaxReach = 1 << 29;
    // The spacing of the samples of the footprint in pixels: 1, or coarser for a footprint of more than
    // kMaxSamples pixels a side, so a huge one costs no more than that (and never loops in place).
    double sample_step() const { return std::max(1.0, std::max(x1 - x0, y1 - y0) / kMaxSamples); }
    static constexpr double kMaxSamples = 2048.0;
};

// The pixels of an RGB image (width x height, top row first) that hold any light: [x0, x1) x [y0, y1), empty
// (x1 <= x0) when none do. A row is scanned from either end to its first lit value, so an image lit nearly
// everywhere costs little.
struct LitBox {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};
LitBox lit_box(const std::vector<float>& rgb, int width, int height) {
    LitBox box{width, height, 0, 0};
    const auto values = static_cast<std::ptrdiff_t>(width) * 3;
    for (int y = 0; y < height; ++y) {
        const float* row = rgb.data() + y * values;
        const float* first = std::find_if(row, row + values, [](float v) { return v != 0.0f; });
        if (first == row + values) continue;
        const auto last = std::find_if(std::make_reverse_iterator(row + values), std::make_reverse_iterator(first),
                                       [](float v) { return v != 0.0f; });
        box.x0 = std::min(box.x0, static_cast<int>((first - row) / 3));
        box.x1 = std::max(box.x1, static_cast<int>((last.base() - 1 - row) / 3) + 1);
        box.y0 = std::min(box.y0, y);
        box.y1 = y + 1;
    }
    return box;
}

// The factor a kernel of half-widths rx, ry (pixels) is convolved reduced by: 2 or more reduces the image,
// 0 or 1 keeps it (convolve_whole), and a part convolved alone stays on the reduced image's cells.
int kernel_reduction(int rx, int ry) { return std::max(rx, ry) / (kMaxKernelRadius / 2); }

// The footprint at magnification m as a kernel of half-widths rx, ry (pixels, known to be in range),
// normalised to a sum of 1; empty when none of it is left.
cv::Mat footprint_kernel(const detect::Shape& shape, double m, int rx, int ry);

// convolve_footprint over the whole image, its kernel's half-widths rx, ry (pixels) known to be in range.
void convolve_whole(std::vector<float>& rgb, int width, int height, const detect::Shape& shape, double m, int rx, int ry,
                    ConvolveScratch& scratch);

}  // namespace

detect::Shape reduced_footprint(detect::Shape shape, int factor) {
    shape.cell /= factor;
    shape.origin_x /= factor;
    shape.origin_y /= factor;
    return shape;
}

void convolve_footprint(std::vector<float>& rgb, int width, int height, const detect::Shape& shape, double m,
                        ConvolveScratch& scratch) {
    const FootprintSampler weight_at{shape};
    const int rx = weight_at.reach_x(m), ry = weight_at.reach_y(m);
    if (rx >= FootprintSampler::kMaxReach || ry >= FootprintSampler::kMaxReach) {
        // Spread over half a billion pixels or more: no pixel keeps a float-visible share of the light.
        std::fill(rgb.begin(), rgb.end(), 0.0f);
        return;
    }
    // Only the lit pixels and as far as the kernel (and a reduced image's filters) reach from them: beyond
    // that the result is 0. Where that is under half the image, the part is convolved alone (a sharp ghost of
    // an extended lamp, pan1080 with canon-70-200: 0.19 s of CPU a group on the whole 1080p frame).
    const LitBox lit = lit_box(rgb, width, height);
    if (lit.x1 <= lit.x0) return;  // no light to spread
    const int factor = std::max(1, kernel_reduction(rx, ry));
    const int bx0 = std::max(0, lit.x0 - rx - 2 * factor), by0 = std::max(0, lit.y0 - ry - 2 * factor);
    const int x0 = bx0 - bx0 % factor, y0 = by0 - by0 % factor;  // a reduced image's cells stay the whole image's
    const int x1 = std::min(width, lit.x1 + rx + 2 * factor), y1 = std::min(height, lit.y1 + ry + 2 * factor);
    const int w = x1 - x0, h = y1 - y0;
    if (2.0 * w * h >= static_cast<double>(width) * height) {
        convolve_whole(rgb, width, height, shape, m, rx, ry, scratch);
        return;
    }
    const auto row_values = static_cast<std::ptrdiff_t>(w) * 3;
    std::vector<float> part(static_cast<std::size_t>(row_values) * static_cast<std::size_t>(h));
    auto at = [&](int y) { return rgb.begin() + (static_cast<std::ptrdiff_t>(y) * width + x0) * 3; };
    for (int y = 0; y < h; ++y) std::copy_n(at(y0 + y), row_values, part.begin() + y * row_values);
    convolve_whole(part, w, h, shape, m, rx, ry, scratch);
    for (int y = 0; y < h; ++y) std::copy_n(part.begin() + y * row_values, row_values, at(y0 + y));
}

namespace {

void convolve_whole(std::vector<float>& rgb, int width, int height, const detect::Shape& shape, double m, int rx, int ry,
                    ConvolveScratch& scratch) {
    if (const int factor = kernel_reduction(rx, ry); factor >= 2) {
        // A wide kernel leaves nothing finer than a fraction of its radius: convolve at 1/factor of the
        // size (area averages), with the footprint in those pixels, and enlarge bilinearly (image_ops.h's
        // one mapping: reduced pixel i covers pixels [i f, (i + 1) f), as the footprint's reduced cells).
        const int sw = reduced_side(width, factor), sh = reduced_side(height, factor);
        std::vector<float> small(static_cast<std::size_t>(sw) * static_cast<std::size_t>(sh) * 3);
        reduce_area(RgbView{small.data(), 0, 0, sw, sh}, ConstRgbView{rgb.data(), 0, 0, width, height}, factor);
        convolve_footprint(small, sw, sh, reduced_footprint(shape, factor), m, scratch);
        std::fill(rgb.begin(), rgb.end(), 0.0f);
        add_enlarged(RgbView{rgb.data(), 0, 0, width, height}, ConstRgbView{small.data(), 0, 0, sw, sh}, factor);
        return;
    }
    const cv::Mat kernel = footprint_kernel(shape, m, rx, ry);
    if (kernel.empty()) return;  // nothing of the footprint left: the ghost stays the point light's
    convolve_rgb(rgb, width, height, kernel.ptr<float>(), rx, ry, scratch);
}

cv::Mat footprint_kernel(const detect::Shape& shape, double m, int rx, int ry) {
    const FootprintSampler weight_at{shape};
    const double cell = weight_at.cell;
    const double x0 = weight_at.x0, y0 = weight_at.y0, x1 = weight_at.x1, y1 = weight_at.y1;
    cv::Mat kernel(2 * ry + 1, 2 * rx + 1, CV_32F, cv::Scalar(0.0));
    if (std::abs(m) >= 1.0) {  // enlarged: each kernel pixel looks up where it came from
        for (int ky = -ry; ky <= ry; ++ky)
            for (int kx = -rx; kx <= rx; ++kx) kernel.at<float>(ry + ky, rx + kx) = weight_at(kx / m, ky / m);
    } else {  // shrunk: each footprint pixel is shared bilinearly where it lands
        const double step = weight_at.sample_step();
        for (double oy = y0 - 0.5 * cell + 0.5; oy < y1 + 0.5 * cell; oy += step) {
            for (double ox = x0 - 0.5 * cell + 0.5; ox < x1 + 0.5 * cell; ox += step) {
                const float w = weight_at(ox, oy);
                if (w == 0.0f) continue;
                const double tx = rx + m * (ox - 0.5), ty = ry + m * (oy - 0.5);
                const int ix = static_cast<int>(std::floor(tx)), iy = static_cast<int>(std::floor(ty));
                const float fx = static_cast<float>(tx - ix), fy = static_cast<float>(ty - iy);
                for (int dy = 0; dy < 2; ++dy)
                    for (int dx = 0; dx < 2; ++dx)
                        if (ix + dx >= 0 && iy + dy >= 0 && ix + dx < kernel.cols && iy + dy < kernel.rows)
                            kernel.at<float>(iy + dy, ix + dx) += w * (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy);
            }
        }
    }
    const double sum = cv::sum(kernel)[0];
    if (!(sum > 0.0)) return {};
    kernel /= sum;
    return kernel;
}

}  // namespace

double footprint_peak_share(const detect::Shape& shape, double m) {
    const FootprintSampler weight_at{shape};
    const int rx = weight_at.reach_x(m), ry = weight_at.reach_y(m);
    if (rx >= FootprintSampler::kMaxReach || ry >= FootprintSampler::kMaxReach) return 0.0;  // the image is cleared
    // Convolved reduced (convolve_whole): a reduced pixel holds the mean of factor^2 pixels, so its kernel's
    // largest weight spreads 1/factor^2 of a pixel's light at most, and enlarging bilinearly adds no maximum.
    if (const int factor = kernel_reduction(rx, ry); factor >= 2)
        return footprint_peak_share(reduced_footprint(shape, factor), m) / (static_cast<double>(factor) * factor);
    const cv::Mat kernel = footprint_kernel(shape, m, rx, ry);
    if (kernel.empty()) return 1.0;  // not convolved: the ghost keeps its own peak
    double largest = 0.0;
    cv::minMaxLoc(kernel, nullptr, &largest);
    return largest;
}

namespace {

// The radius in pixels of the disc of the footprint's cells holding any of the light: each point's pattern
// within it, spread over the source, would only blur the source within its own size.
double own_radius_px(const detect::Shape& shape) {
    std::size_t cells = 0;
    for (float v : shape.weights) cells += v > 0.0f ? 1 : 0;
    return std::sqrt(static_cast<double>(cells) / std::numbers::pi) * FootprintSampler{shape}.cell;
}

// The texture's part of an extended light's diffraction (see add_extended_starburst).
void add_extended_texture(const optics::Starburst& sb, const optics::StarburstPlacement& at, const std::array<double, 3>& power,
                          const detect::Shape& shape, const optics::SensorImage& image, ConvolveScratch& scratch) {
    const double f_number = at.f_number, cx = at.cx, cy = at.cy;
    const double pixel_w_mm = image.pixel_w_mm, pixel_h_mm = image.pixel_h_mm;
    const int width = image.width, height = image.height;
    // The region the pattern and then the footprint can reach: the same sums as over the whole frame
    // (nothing is drawn or spread beyond it), at the cost of the source and its pattern.
    const FootprintSampler footprint{shape};
    const double texel_mm = sb.texel_per_fnumber_mm * f_number;
    const double reach_x = 0.5 * sb.size * texel_mm / pixel_w_mm + 2.0 + footprint.reach_x(1.0);
    const double reach_y = 0.5 * sb.size * texel_mm / pixel_h_mm + 2.0 + footprint.reach_y(1.0);
    const int x0 = static_cast<int>(std::clamp(std::floor(cx - reach_x), 0.0, static_cast<double>(width)));
    const int x1 = static_cast<int>(std::clamp(std::ceil(cx + reach_x), 0.0, static_cast<double>(width)));
    const int y0 = static_cast<int>(std::clamp(std::floor(cy - reach_y), 0.0, static_cast<double>(height)));
    const int y1 = static_cast<int>(std::clamp(std::ceil(cy + reach_y), 0.0, static_cast<double>(height)));
    if (x1 <= x0 || y1 <= y0) return;
    const int w = x1 - x0, h = y1 - y0;
    std::vector<float> own(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3, 0.0f);
    // Each point's pattern within the source's radius (of the disc of its cells' area), spread over the
    // source, would only blur it within its own size: the recording holds that. What reaches farther (the
    // spikes) is new.
    const double radius_px = own_radius_px(shape);
    const double core = std::max(at.core_radius_texels, radius_px * std::min(pixel_w_mm, pixel_h_mm) / texel_mm);
    if (core >= 0.5 * sb.size * std::numbers::sqrt2) return;  // the whole texture lies within it
    optics::splat_starburst(sb, {cx - x0, cy - y0, f_number, core}, power, {own.data(), w, h, pixel_w_mm, pixel_h_mm});
    convolve_footprint(own, w, h, shape, 1.0, scratch);
    // Over the light's own pixels the recording already holds its light, spread by the lens or not: the
    // pattern is new only beyond them (as a point light's beyond its pixel), so nothing blooms the source.
    for (int y = 0; y < h; ++y) {
        const float* from = own.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w) * 3;
        float* to = image.rgb + (static_cast<std::size_t>(y0 + y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x0)) * 3;
        for (int x = 0; x < w; ++x) {
            const float beyond = 1.0f - footprint.inside(x0 + x + 0.5 - cx, y0 + y + 0.5 - cy);
            if (beyond <= 0.0f) continue;
            for (std::size_t c = 0; c < 3; ++c)
                to[static_cast<std::size_t>(x) * 3 + c] += beyond * from[static_cast<std::size_t>(x) * 3 + c];
        }
    }
}

// Adds rows [y0, y0 + rows) of the enlarged tail (`from`, those rows only) into the image beyond the light's
// own pixels.
void add_tail_rows(const float* from_rows, int y0, int rows, const FootprintSampler& footprint, double cx, double cy,
                   const optics::SensorImage& image) {
    const int width = image.width;
    for (int y = y0; y < y0 + rows; ++y) {
        const float* from = from_rows + static_cast<std::size_t>(y - y0) * static_cast<std::size_t>(width) * 3;
        float* to = image.rgb + static_cast<std::size_t>(y) * static_cast<std::size_t>(width) * 3;
        const double oy = y + 0.5 - cy;
        const bool rows_of_light = oy > footprint.y0 - footprint.cell && oy < footprint.y1 + footprint.cell;
        for (int x = 0; x < width; ++x) {
            const double ox = x + 0.5 - cx;
            const float beyond = rows_of_light ? 1.0f - footprint.inside(ox, oy) : 1.0f;
            if (beyond <= 0.0f) continue;
            for (std::size_t c = 0; c < 3; ++c)  // the DFT filter's rounding leaves tiny negatives: no light
                to[static_cast<std::size_t>(x) * 3 + c] += beyond * std::max(0.0f, from[static_cast<std::size_t>(x) * 3 + c]);
        }
    }
}

// The spikes beyond the texture, spread over the footprint: they hold nothing finer than the footprint, so
// they are drawn and spread at 1/factor of the frame's size (the footprint's kernel at most ~8 px wide),
// enlarged bilinearly and added beyond the light's own pixels.
void add_extended_tail(const optics::Starburst& sb, const optics::Aperture& aperture, double length_scale,
                       const optics::StarburstPlacement& at, const std::array<double, 3>& power, const detect::Shape& shape,
                       const optics::SensorImage& image, ConvolveScratch& scratch) {
    const double f_number = at.f_number, cx = at.cx, cy = at.cy;
    const int width = image.width, height = image.height;
    const FootprintSampler footprint{shape};
    const int factor = std::clamp(std::max(footprint.reach_x(1.0), footprint.reach_y(1.0)) / 8, 1, std::max(1, std::max(width, height) / 8));
    const int sw = reduced_side(width, factor), sh = reduced_side(height, factor);
    std::vector<float> small(static_cast<std::size_t>(sw) * static_cast<std::size_t>(sh) * 3, 0.0f);
    optics::draw_starburst_tail(sb, aperture, length_scale, {cx / factor, cy / factor, f_number, 0.0}, power,
                                {small.data(), sw, sh, image.pixel_w_mm * factor, image.pixel_h_mm * factor});
    // As the texture's: the pattern within the source's own radius is left out (bounds clamped in double,
    // so a light far outside the frame never reaches int arithmetic).
    const double inner = own_radius_px(shape) / factor, ux = cx / factor, uy = cy / factor;
    const auto clamp_to = [](double v, int n) { return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(n))); };
    for (int y = clamp_to(std::floor(uy - inner), sh); y < clamp_to(std::ceil(uy + inner) + 1.0, sh); ++y)
        for (int x = clamp_to(std::floor(ux - inner), sw); x < clamp_to(std::ceil(ux + inner) + 1.0, sw); ++x)
            if (std::hypot(x + 0.5 - ux, y + 0.5 - uy) < inner)
                std::fill_n(small.begin() + (static_cast<std::ptrdiff_t>(y) * sw + x) * 3, 3, 0.0f);
    convolve_footprint(small, sw, sh, reduced_footprint(shape, factor), 1.0, scratch);
    // Enlarged to the frame, pixel centres kept: reduced pixel i covers full pixels [i f, (i + 1) f); a band of
    // rows at a time (each pixel's value as the whole frame's enlargement gives it), so no frame-sized buffer is
    // made and zeroed (that cost ~50 ms a 1080p frame, mostly page faults).
    constexpr int kBandRows = 64;
    std::vector<float> band(static_cast<std::size_t>(width) * static_cast<std::size_t>(std::min(kBandRows, height)) * 3);
    for (int band_y = 0; band_y < height; band_y += kBandRows) {
        const int rows = std::min(kBandRows, height - band_y);
        std::fill_n(band.begin(), static_cast<std::ptrdiff_t>(width) * rows * 3, 0.0f);
        add_enlarged(RgbView{band.data(), 0, band_y, width, rows}, ConstRgbView{small.data(), 0, 0, sw, sh}, factor);
        add_tail_rows(band.data(), band_y, rows, footprint, cx, cy, image);
    }
}

}  // namespace

void add_extended_starburst(const optics::Starburst& sb, const optics::Aperture& aperture, double length_scale,
                            const optics::StarburstPlacement& at, const std::array<double, 3>& power,
                            const detect::Shape& shape, const optics::SensorImage& image, ConvolveScratch& scratch) {
    if (sb.size == 0 || !(at.f_number > 0.0) || !(length_scale > 0.0) || !std::isfinite(at.cx) || !std::isfinite(at.cy)) return;
    // As a point light's: the texture at the lens's f-number gives up the tail's share, and the tail,
    // lengthened by length_scale, runs to the frame edge.
    const optics::StarburstTail tail = optics::starburst_tail_share(sb, aperture, at.f_number, length_scale);
    std::array<double, 3> texture_power{};
    for (std::size_t c = 0; c < 3; ++c) texture_power[c] = power[c] * (1.0 - tail.share[c]);
    add_extended_texture(sb, at, texture_power, shape, image, scratch);
    add_extended_tail(sb, aperture, length_scale, at, power, shape, image, scratch);
}

std::vector<FootprintGroup> footprint_groups(const std::vector<optics::Ghost>& ghosts,
                                             const std::vector<optics::GhostImaging>& imaging,
                                             const std::vector<double>& axial_power, const detect::Shape& shape,
                                             double pixel_mm) {
    const double footprint_px = std::max(shape.width, shape.height) * shape.cell;
    double total = 0.0;
    for (double p : axial_power) total += p;
    std::map<int, FootprintGroup> by_step;  // key: signed sqrt(2) step of the magnification, 0 for points
    std::map<int, double> power;
    for (std::size_t g = 0; g < ghosts.size(); ++g) {
        const double m = imaging[g].magnification;
        const double size_px = std::abs(m) * footprint_px;
        int key = 0;
        if (size_px >= 1.0 && imaging[g].blur_mm / pixel_mm <= kBlurOverFootprint * size_px) {
            const int step = std::clamp(static_cast<int>(std::lround(2.0 * std::log2(std::abs(m)))), -8, 8);
            key = m < 0.0 ? -(step + 100) : step + 100;
        }
        FootprintGroup& group = by_step[key];
        group.magnification = key == 0 ? 0.0 : std::copysign(std::pow(2.0, 0.5 * (std::abs(key) - 100)), m);
        group.ghosts.emplace_back(ghosts[g].first, ghosts[g].second);
        power[key] += axial_power[g];
    }
    // The point group first, then the sharp groups by increasing key.
    std::vector<FootprintGroup> out(1, FootprintGroup{0.0, {}});
    for (auto& [key, group] : by_step) {
        if (key == 0 || !(power[key] >= kMinGroupShare * total)) {
            out.front().ghosts.insert(out.front().ghosts.end(), group.ghosts.begin(), group.ghosts.end());
        } else {
            out.push_back(group);
        }
    }
    if (out.front().ghosts.empty()) out.erase(out.begin());
    return out;
}

}  // namespace lensfx::flare
