// Issue 19's accuracy measures of a fitted flare against a reference.
#include <measured/accuracy.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace lensfx::measured {

namespace {

double sum_of(const std::vector<float>& v) {
    return std::accumulate(v.begin(), v.end(), 0.0, [](double s, float x) { return s + static_cast<double>(x); });
}

// One block's sum of channel c, the block clipped to the image.
double block_sum(const std::vector<float>& rgb, int width, int height, int bx, int by, int block, int c) {
    double s = 0.0;
    for (int y = by; y < std::min(by + block, height); ++y)
        for (int x = bx; x < std::min(bx + block, width); ++x) s += static_cast<double>(rgb[static_cast<std::size_t>((y * width + x) * 3 + c)]);
    return s;
}

std::vector<double> ranks(const std::vector<double>& v) {
    std::vector<std::size_t> order(v.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
    std::vector<double> r(v.size());
    for (std::size_t i = 0; i < order.size(); ++i) r[order[i]] = static_cast<double>(i);
    return r;
}

}  // namespace

double block_l1(const std::vector<float>& fit, const std::vector<float>& truth, int width, int height, int block) {
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3;
    if (fit.size() != n || truth.size() != n || block < 1) throw std::invalid_argument("block_l1: images of different sizes");
    double diff = 0.0, total = 0.0;
    for (int by = 0; by < height; by += block)
        for (int bx = 0; bx < width; bx += block)
            for (int c = 0; c < 3; ++c) {
                const double b = block_sum(truth, width, height, bx, by, block, c);
                diff += std::abs(block_sum(fit, width, height, bx, by, block, c) - b), total += b;
            }
    return diff / total;
}

double power_error(const std::vector<float>& fit, const std::vector<float>& truth) {
    const double t = sum_of(truth);
    return std::abs(sum_of(fit) - t) / t;
}

double spearman(const std::vector<double>& a, const std::vector<double>& b) {
    if (a.size() != b.size() || a.size() < 2) throw std::invalid_argument("spearman: two series of the same length, at least 2");
    const std::vector<double> ra = ranks(a), rb = ranks(b);
    double d2 = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) d2 += (ra[i] - rb[i]) * (ra[i] - rb[i]);
    const double n = static_cast<double>(a.size());
    return 1.0 - 6.0 * d2 / (n * (n * n - 1.0));
}

}  // namespace lensfx::measured
