#include <optics/aperture.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace lensfx::optics {

IrisSdf::IrisSdf(const Aperture& aperture) {
    if (aperture.blades < 3) return;
    if (aperture.blades > kMaxBlades)  // lens files and --blades refuse more
        throw std::invalid_argument("an iris has at most 64 blades, not " + std::to_string(aperture.blades));
    blades_ = aperture.blades;
    const double half = std::numbers::pi / blades_;
    apothem_ = std::cos(half);
    const double half_chord = std::sin(half);
    const double curvature = std::clamp(aperture.blade_curvature, 0.0, 1.0);
    const double first = (aperture.rotation_deg - 90.0) * std::numbers::pi / 180.0;
    // A curved edge is the arc through both corners, bulging outwards, with its centre on the edge's normal.
    double centre = 0.0;
    if (curvature >= 1e-9) {
        arc_radius_ = 1.0 / curvature;
        centre = apothem_ - std::sqrt(arc_radius_ * arc_radius_ - half_chord * half_chord);
    }
    for (int k = 0; k < blades_; ++k) {
        const double phi = first + 2.0 * half * k;
        Edge& e = edges_[static_cast<std::size_t>(k)];
        e.nx = std::cos(phi);
        e.ny = std::sin(phi);
        e.cx = centre * e.nx;
        e.cy = centre * e.ny;
    }
}

double IrisSdf::operator()(double u, double v) const {
    if (blades_ == 0) return std::hypot(u, v) - 1.0;
    double sdf = -1e300;
    for (int k = 0; k < blades_; ++k) {
        const Edge& e = edges_[static_cast<std::size_t>(k)];
        const double edge = arc_radius_ == 0.0 ? u * e.nx + v * e.ny - apothem_ : std::hypot(u - e.cx, v - e.cy) - arc_radius_;
        sdf = std::max(sdf, edge);
    }
    return sdf;
}

double aperture_sdf(const Aperture& aperture, double u, double v) { return IrisSdf(aperture)(u, v); }

namespace {

double coverage(const IrisSdf& sdf, double u, double v, double texel) {
    const double d = sdf(u, v);
    if (d < -texel) return 1.0;
    if (d > texel) return 0.0;
    int inside = 0;
    for (int sy = 0; sy < 4; ++sy)
        for (int sx = 0; sx < 4; ++sx) inside += sdf(u + (sx - 1.5) * 0.25 * texel, v - (sy - 1.5) * 0.25 * texel) <= 0.0;
    return inside / 16.0;
}

}  // namespace

double aperture_coverage(const Aperture& aperture, double u, double v, double texel) {
    return coverage(IrisSdf(aperture), u, v, texel);
}

void rasterise_aperture(const Aperture& aperture, int m, int r, double* out) {
    const double inv = 1.0 / r;
    const IrisSdf sdf(aperture);
    for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x)
            out[static_cast<std::size_t>(y) * static_cast<std::size_t>(m) + static_cast<std::size_t>(x)] =
                coverage(sdf, (x - m / 2) * inv, (m / 2 - y) * inv, inv);
}

}  // namespace lensfx::optics
