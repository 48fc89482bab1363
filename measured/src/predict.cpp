// Flare occurrence estimators (paper section 3.5).
#include <measured/predict.h>

#include <algorithm>
#include <cmath>

#include "fit_image.h"

namespace lensfx::measured {

namespace {

double percentile(std::vector<double> v, double q) {
    if (v.empty()) return 0.0;
    const auto at = v.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), at, v.end());
    return *at;
}

}  // namespace

FlareEstimate estimate(const std::vector<float>& flare_rgb, int width, int height, const std::vector<float>& scene, double pixel_area_mm2) {
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    const std::vector<double> flare = luminance_of(flare_rgb, n);
    auto scene_at = [&](std::size_t i) { return static_cast<double>(scene.size() == 1 ? scene[0] : scene[i]); };
    FlareEstimate e;
    double log_with = 0.0, log_without = 0.0, sum = 0.0;
    constexpr double kFloor = 1e-12;
    for (std::size_t i = 0; i < n; ++i) {
        const double f = std::max(0.0, flare[i]);
        e.peak = std::max(e.peak, f);
        sum += f;
        log_with += std::log(std::max(scene_at(i) + f, kFloor));
        log_without += std::log(std::max(scene_at(i), kFloor));
    }
    e.total = sum * pixel_area_mm2;
    e.glare = std::exp((log_with - log_without) / static_cast<double>(std::max<std::size_t>(n, 1))) - 1.0;
    // Contrast: the scene's 1st to 99th percentile (a flat scene: its level against a black of 1/100 of
    // it), ideal over with the mean flare veiling both ends.
    double low = 0.0, high = 0.0;
    if (scene.size() == 1) {
        high = static_cast<double>(scene[0]), low = 0.01 * high;
    } else {
        const std::vector<double> values(scene.begin(), scene.end());
        high = percentile(values, 0.99), low = percentile(values, 0.01);
    }
    low = std::max(low, kFloor), high = std::max(high, low);
    const double veil = sum / static_cast<double>(std::max<std::size_t>(n, 1));
    e.contrast = (high / low) / ((high + veil) / (low + veil));
    return e;
}

std::vector<double> rated(const std::vector<double>& values) {
    if (values.empty()) return {};
    const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
    std::vector<double> out;
    for (double v : values) out.push_back(*hi > *lo ? (v - *lo) / (*hi - *lo) : 0.0);
    return out;
}

}  // namespace lensfx::measured
