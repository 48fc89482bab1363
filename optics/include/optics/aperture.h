// The iris as a shape: a signed distance function in stop-normalised coordinates, shared by the GPU
// aperture texture, the CPU reference and the starburst's transmission function.
#pragma once

#include <optics/lens.h>

namespace lensfx::optics {

// Signed distance to the iris edge in units of the stop radius at stop coordinates (u, v) (lens x/y over
// the stop radius, the upright frame): negative inside. Round (blades < 3): |uv| - 1. With n >= 3 blades
// the polygon's corners lie on the unit circle; its first edge is horizontal at the bottom when
// rotation_deg = 0, then turned counter-clockwise; each edge is an arc of radius 1 / blade_curvature
// through its two corners (curvature 0: straight, 1: the circle itself).
double aperture_sdf(const Aperture& aperture, double u, double v);

}  // namespace lensfx::optics
