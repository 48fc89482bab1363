#include <optics/aperture.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lensfx::optics {

double aperture_sdf(const Aperture& aperture, double u, double v) {
    const double radius = std::hypot(u, v);
    if (aperture.blades < 3) return radius - 1.0;
    const int n = aperture.blades;
    const double half = std::numbers::pi / n;
    const double apothem = std::cos(half);
    const double half_chord = std::sin(half);
    const double curvature = std::clamp(aperture.blade_curvature, 0.0, 1.0);
    const double first = (aperture.rotation_deg - 90.0) * std::numbers::pi / 180.0;
    double sdf = -1e300;
    for (int k = 0; k < n; ++k) {
        const double phi = first + 2.0 * half * k;
        const double nx = std::cos(phi);
        const double ny = std::sin(phi);
        double edge;
        if (curvature < 1e-9) {
            edge = u * nx + v * ny - apothem;
        } else {
            // The arc through both corners, bulging outwards, with its centre on the edge's normal.
            const double arc_radius = 1.0 / curvature;
            const double centre = apothem - std::sqrt(arc_radius * arc_radius - half_chord * half_chord);
            edge = std::hypot(u - centre * nx, v - centre * ny) - arc_radius;
        }
        sdf = std::max(sdf, edge);
    }
    return sdf;
}

double aperture_coverage(const Aperture& aperture, double u, double v, double texel) {
    const double d = aperture_sdf(aperture, u, v);
    if (d < -texel) return 1.0;
    if (d > texel) return 0.0;
    int inside = 0;
    for (int sy = 0; sy < 4; ++sy)
        for (int sx = 0; sx < 4; ++sx)
            inside += aperture_sdf(aperture, u + (sx - 1.5) * 0.25 * texel, v - (sy - 1.5) * 0.25 * texel) <= 0.0;
    return inside / 16.0;
}

void rasterise_aperture(const Aperture& aperture, int m, int r, double* out) {
    const double inv = 1.0 / r;
    for (int y = 0; y < m; ++y)
        for (int x = 0; x < m; ++x)
            out[static_cast<std::size_t>(y) * static_cast<std::size_t>(m) + static_cast<std::size_t>(x)] =
                aperture_coverage(aperture, (x - m / 2) * inv, (m / 2 - y) * inv, inv);
}

}  // namespace lensfx::optics
