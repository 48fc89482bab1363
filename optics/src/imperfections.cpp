#include <optics/imperfections.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <fmt/core.h>

#include <optics/random.h>

namespace lensfx::optics {

namespace {

// A point in the unit disc, uniformly by area.
std::pair<double, double> in_disc(Random& rng) {
    const double r = std::sqrt(rng.uniform());
    const double a = 2.0 * std::numbers::pi * rng.uniform();
    return {r * std::cos(a), r * std::sin(a)};
}

// Multiplies the grid by (1 - opacity x coverage) over a shape's bounding box in stop units, coverage by
// 4 x 4 supersampling of `inside(u, v)`.
template <class Inside>
void stamp(int m, int r, double* t, double u0, double v0, double u1, double v1, double opacity, Inside inside) {
    const double inv = 1.0 / r;
    const int x0 = std::max(0, static_cast<int>(std::floor(u0 * r)) + m / 2 - 1);
    const int x1 = std::min(m - 1, static_cast<int>(std::ceil(u1 * r)) + m / 2 + 1);
    const int y0 = std::max(0, m / 2 - static_cast<int>(std::ceil(v1 * r)) - 1);
    const int y1 = std::min(m - 1, m / 2 - static_cast<int>(std::floor(v0 * r)) + 1);
    for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) {
            const double u = (x - m / 2) * inv;
            const double v = (m / 2 - y) * inv;
            int covered = 0;
            for (int sy = 0; sy < 4; ++sy)
                for (int sx = 0; sx < 4; ++sx)
                    covered += inside(u + (sx - 1.5) * 0.25 * inv, v - (sy - 1.5) * 0.25 * inv);
            if (covered == 0) continue;
            t[static_cast<std::size_t>(y) * static_cast<std::size_t>(m) + static_cast<std::size_t>(x)] *=
                1.0 - opacity * covered / 16.0;
        }
    }
}

void check(const PupilImperfections& d) {
    const auto bad = [](double v) { return !std::isfinite(v) || v < 0.0; };
    if (bad(d.dust_density) || d.dust_density > 1e6)
        throw std::invalid_argument(fmt::format("dust density {} outside 0..1e6 per unit pupil area", d.dust_density));
    if (bad(d.dust_radius) || bad(d.scratch_length) || bad(d.scratch_width) || !std::isfinite(d.scratch_angle_deg) ||
        bad(d.scratch_spread_deg))
        throw std::invalid_argument("dust and scratch sizes, lengths and angles must be finite and non-negative");
    if (bad(d.dust_opacity) || d.dust_opacity > 1.0 || bad(d.scratch_opacity) || d.scratch_opacity > 1.0)
        throw std::invalid_argument("dust and scratch opacity must lie in 0..1");
    if (d.scratches < 0 || d.scratches > 100000)
        throw std::invalid_argument(fmt::format("scratch count {} outside 0..100000", d.scratches));
}

}  // namespace

double ApertureImage::at(double u, double v) const {
    if (empty()) return 0.0;
    const double px = (u + 1.0) * 0.5 * width - 0.5;
    const double py = (1.0 - v) * 0.5 * height - 0.5;
    if (!(px > -1.0 && py > -1.0 && px < width && py < height)) return 0.0;
    const int x0 = static_cast<int>(std::floor(px)), y0 = static_cast<int>(std::floor(py));
    const double ax = px - x0, ay = py - y0;
    const auto get = [&](int x, int y) -> double {
        if (x < 0 || y < 0 || x >= width || y >= height) return 0.0;
        return std::clamp(static_cast<double>(value[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                                                     static_cast<std::size_t>(x)]),
                          0.0, 1.0);
    };
    return (1 - ay) * ((1 - ax) * get(x0, y0) + ax * get(x0 + 1, y0)) +
           ay * ((1 - ax) * get(x0, y0 + 1) + ax * get(x0 + 1, y0 + 1));
}

void apply_imperfections(const PupilImperfections& dirt, int m, int r, double* t) {
    check(dirt);
    if (dirt.empty()) return;
    Random rng(dirt.seed);
    // Dirt is scattered over the unit disc: the pupil a round iris at full opening would show.
    const int specks = static_cast<int>(std::lround(dirt.dust_density * std::numbers::pi));
    for (int i = 0; i < specks; ++i) {
        const auto centre = in_disc(rng);
        const double cu = centre.first, cv = centre.second;
        const double radius = dirt.dust_radius * std::exp2(rng.uniform(-1.0, 1.0));
        const double r2 = radius * radius;
        stamp(m, r, t, cu - radius, cv - radius, cu + radius, cv + radius, dirt.dust_opacity,
              [&](double u, double v) { return (u - cu) * (u - cu) + (v - cv) * (v - cv) <= r2; });
    }
    for (int i = 0; i < dirt.scratches; ++i) {
        const auto centre = in_disc(rng);
        const double cu = centre.first, cv = centre.second;
        const double angle = (dirt.scratch_angle_deg + dirt.scratch_spread_deg * rng.uniform(-0.5, 0.5)) *
                             std::numbers::pi / 180.0;
        const double half_length = 0.5 * dirt.scratch_length * rng.uniform(0.5, 1.5);
        const double half_width = 0.5 * dirt.scratch_width;
        const double du = std::cos(angle), dv = std::sin(angle);
        const double eu = std::abs(du) * half_length + half_width, ev = std::abs(dv) * half_length + half_width;
        stamp(m, r, t, cu - eu, cv - ev, cu + eu, cv + ev, dirt.scratch_opacity, [&](double u, double v) {
            const double along = (u - cu) * du + (v - cv) * dv;
            const double across = -(u - cu) * dv + (v - cv) * du;
            return std::abs(along) <= half_length && std::abs(across) <= half_width;
        });
    }
}

}  // namespace lensfx::optics
