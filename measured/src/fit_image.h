// Small float-image helpers of the fit: robust statistics, separable Gaussian blur, the smoothed
// Laplacian edge image (paper Fig. 7). Indices are clamped to the image.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <measured/model.h>

namespace lensfx::measured {

inline double luminance(double r, double g, double b) { return 0.2126 * r + 0.7152 * g + 0.0722 * b; }

template <typename T>
std::vector<double> luminance_of(const std::vector<T>& rgb, std::size_t n) {
    std::vector<double> lum(n);
    for (std::size_t i = 0; i < n; ++i)
        lum[i] = luminance(static_cast<double>(rgb[i * 3]), static_cast<double>(rgb[i * 3 + 1]), static_cast<double>(rgb[i * 3 + 2]));
    return lum;
}

inline double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return *mid;
}

// The standard deviation of the background from the median absolute deviation (ghosts are outliers).
inline double robust_sigma(const std::vector<double>& v) {
    const double m = median(v);
    std::vector<double> dev(v.size());
    for (std::size_t i = 0; i < v.size(); ++i) dev[i] = std::abs(v[i] - m);
    return 1.4826 * median(dev);
}

inline std::vector<double> gaussian_blur(const std::vector<double>& in, int w, int h, double sigma) {
    const int r = static_cast<int>(std::ceil(3.0 * sigma));
    std::vector<double> k(static_cast<std::size_t>(2 * r + 1));
    double sum = 0.0;
    for (int i = -r; i <= r; ++i) sum += k[static_cast<std::size_t>(i + r)] = std::exp(-0.5 * i * i / (sigma * sigma));
    for (double& v : k) v /= sum;
    std::vector<double> tmp(in.size()), out(in.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double s = 0.0;
            for (int i = -r; i <= r; ++i) s += k[static_cast<std::size_t>(i + r)] * in[static_cast<std::size_t>(y * w + std::clamp(x + i, 0, w - 1))];
            tmp[static_cast<std::size_t>(y * w + x)] = (s);
        }
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double s = 0.0;
            for (int i = -r; i <= r; ++i) s += k[static_cast<std::size_t>(i + r)] * tmp[static_cast<std::size_t>(std::clamp(y + i, 0, h - 1) * w + x)];
            out[static_cast<std::size_t>(y * w + x)] = (s);
        }
    return out;
}

// Gaussian, the 8-neighbour Laplacian, Gaussian again (so that near edges overlap).
inline std::vector<double> edge_image(const std::vector<double>& lum, int w, int h) {
    const std::vector<double> smooth = gaussian_blur(lum, w, h, 1.0);
    std::vector<double> lap(lum.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double s = -8.0 * smooth[static_cast<std::size_t>(y * w + x)];
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    if (dx != 0 || dy != 0) s += smooth[static_cast<std::size_t>(std::clamp(y + dy, 0, h - 1) * w + std::clamp(x + dx, 0, w - 1))];
            lap[static_cast<std::size_t>(y * w + x)] = (s);
        }
    return gaussian_blur(lap, w, h, 1.0);
}

// Adds one ghost (light on the +x meridian) over its pixel box into a full RGB image of `width` columns.
inline void add_box(std::vector<double>& rgb, int width, const std::array<int, 4>& box, const GhostParams& p, const MeasuredView& view) {
    const int bw = box[2] - box[0], bh = box[3] - box[1];
    std::vector<float> part(static_cast<std::size_t>(bw) * static_cast<std::size_t>(bh) * 3, 0.0f);
    render_ghost_box(p, 0.0, view, box[0], box[1], box[2], box[3], part.data());
    for (int y = 0; y < bh; ++y)
        for (int x = 0; x < bw; ++x)
            for (std::size_t c = 0; c < 3; ++c)
                rgb[static_cast<std::size_t>((y + box[1]) * width + x + box[0]) * 3 + c] += static_cast<double>(part[static_cast<std::size_t>(y * bw + x) * 3 + c]);
}

}  // namespace lensfx::measured
