// The iris as a shape: a signed distance function in stop-normalised coordinates, shared by the GPU
// aperture texture, the CPU reference and the starburst's transmission function.
#pragma once

#include <array>

#include <optics/lens.h>

namespace lensfx::optics {

// Signed distance to the iris edge in units of the stop radius at stop coordinates (u, v) (lens x/y over
// the stop radius, the upright frame): negative inside. Round (blades < 3): |uv| - 1. With n >= 3 blades
// the polygon's corners lie on the unit circle; its first edge is horizontal at the bottom when
// rotation_deg = 0, then turned counter-clockwise; each edge is an arc of radius 1 / blade_curvature
// through its two corners (curvature 0: straight, 1: the circle itself).
double aperture_sdf(const Aperture& aperture, double u, double v);

// aperture_sdf with the blades' edges worked out once, for evaluating many points of one iris.
class IrisSdf {
public:
    explicit IrisSdf(const Aperture& aperture);
    double operator()(double u, double v) const;

private:
    static constexpr int kMaxBlades = 64;
    struct Edge {
        double nx, ny;  // outward normal
        double cx, cy;  // centre of the edge's arc (curved blades)
    };
    std::array<Edge, kMaxBlades> edges_{};
    int blades_ = 0;  // 0: round
    double apothem_ = 0.0;
    double arc_radius_ = 0.0;  // 0: straight edges
};

// Share of a texel of side `texel` centred at (u, v) inside the iris, 4 x 4 supersampled near the edge.
double aperture_coverage(const Aperture& aperture, double u, double v, double texel);

// The iris's transmission on an m x m grid, r samples per stop radius, centred on sample (m/2, m/2), row 0
// at the top (v up); edge samples 4 x 4 supersampled. The starburst's and the ringing's input.
void rasterise_aperture(const Aperture& aperture, int m, int r, double* out);

}  // namespace lensfx::optics
