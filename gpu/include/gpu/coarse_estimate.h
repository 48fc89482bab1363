// What a coarse pass learns of one ghost from its traced grid of rays (the renderer's estimates, issue 5 and 17):
// where its light gets through and lands, its power, its peak irradiance and sensor box for scene culling, and the
// outline measures the level of detail reads. CPU only: the vertices come read back from ghost_trace_comp.
#pragma once

#include <gpu/acceleration.h>
#include <gpu/flare_model.h>

namespace lensfx::gpu {

// A ghost's estimate from a coarse pass's (res + 1)^2 traced vertices (12 floats each, ghost_trace_comp's layout)
// over `square` of the entrance plane, at the light's cos(angle): where the rays get through and land within
// sensor_radius_mm of the centre, their power, how uniform the whole cells' sensor areas are, the sensor extent, how
// much of the rectangle passes, the outlines the renderer resolves only at its grid's cells, and the peak
// irradiance and sensor box scene culling judges it by (a veil wider than the frame: measure_veil_cells).
GhostEstimate coarse_estimate(const float* vertices, int res, const PupilRect& square, int stop_crossings,
                              const Aperture& aperture, double cos_angle, double sensor_radius_mm);

// A ghost's peak and sensor box from a finer pass over its own rectangle (its coarse estimate had no whole
// cell): the finer pass's peak when it found one, the brighter of the two passes' rim rings and the union of the
// two boxes; the rest stays the coarse pass's. Scene culling judges the ghost by them; the level of detail reads the
// box too (its size, its mean triangle: acceleration.cpp's sensor_size_mm and mean_triangle_mm2).
void learn_peak(GhostEstimate& coarse, const GhostEstimate& fine);

}  // namespace lensfx::gpu
