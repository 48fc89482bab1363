// Synthetic frames for the detection and tracking tests: Gaussian blobs and rectangles on a flat background.
#pragma once

#include <array>
#include <cmath>

#include <opencv2/core.hpp>

namespace lensfx::detect::test {

inline cv::Mat flat_frame(int w, int h, float level) { return cv::Mat(h, w, CV_32FC3, cv::Scalar(level, level, level)); }

// An elliptical Gaussian of peak `peak` (in every channel, times `tint`), centre (cx, cy) in pixel
// coordinates (pixel centres at i + 0.5), sigmas along its axes, major axis at `angle_deg` counter-clockwise
// with +y up; each pixel gets the value at its centre.
inline void add_gaussian(cv::Mat& img, double cx, double cy, double peak, double sx, double sy = -1.0, double angle_deg = 0.0,
                         std::array<double, 3> tint = {1.0, 1.0, 1.0}) {
    if (sy <= 0.0) sy = sx;
    const double a = angle_deg * 3.14159265358979323846 / 180.0;
    const double ca = std::cos(a), sa = std::sin(a);
    const int r = static_cast<int>(std::ceil(6.0 * std::max(sx, sy)));
    for (int y = std::max(0, static_cast<int>(cy) - r); y < std::min(img.rows, static_cast<int>(cy) + r + 1); ++y)
        for (int x = std::max(0, static_cast<int>(cx) - r); x < std::min(img.cols, static_cast<int>(cx) + r + 1); ++x) {
            const double dx = x + 0.5 - cx, dyu = -(y + 0.5 - cy);  // +y up
            const double u = dx * ca + dyu * sa, v = -dx * sa + dyu * ca;
            const double g = peak * std::exp(-0.5 * (u * u / (sx * sx) + v * v / (sy * sy)));
            auto& p = img.at<cv::Vec3f>(y, x);
            for (int c = 0; c < 3; ++c) p[c] += static_cast<float>(g * tint[static_cast<std::size_t>(c)]);
        }
}

// Total energy of add_gaussian's continuous profile.
inline double gaussian_energy(double peak, double sx, double sy = -1.0) {
    if (sy <= 0.0) sy = sx;
    return 2.0 * 3.14159265358979323846 * sx * sy * peak;
}

}  // namespace lensfx::detect::test
