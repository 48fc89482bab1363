// Ghost enumeration (flare paper section 4.1): every path with exactly two reflections — light travels
// towards the sensor, reflects at interface j, travels back, reflects at interface i < j and goes on to
// the sensor. Optional aperture culling (section 4.2) and the per-ghost reflectance factors.
#pragma once

#include <cstddef>
#include <vector>

#include <optics/lens.h>
#include <optics/system.h>
#include <optics/tracer.h>

namespace lensfx::optics {

// Interfaces that can reflect: all except the aperture stop (a plane in one medium, not a Fresnel
// interface) and uncoated planes/spheres with the same medium on both sides (R = 0 at every angle).
// The paper's count N = n(n-1)/2 uses exactly these n interfaces.
std::vector<int> reflecting_interfaces(const System& system);

struct Ghost {
    int first = 0;   // interface of the first reflection (j, nearer the sensor)
    int second = 0;  // interface of the second reflection (i < j)
    std::vector<Step> path;  // object side -> ... -> j (reflect) -> ... -> i (reflect) -> ... -> last interface
    bool crosses_stop_three_times = false;  // i in front of the stop, j behind it
};

struct GhostOptions {
    // Section 4.2 "aperture culling": drop the ghosts that cross the stop three times (i in front of the
    // stop and j behind it), leaving N = (f(f-1) + b(b-1))/2 for f reflecting interfaces in front of the
    // stop and b behind. Meant for small iris openings, where those ghosts are mostly blocked.
    bool aperture_culling = false;
};

// Ghosts ordered by first (ascending), then second (ascending).
std::vector<Ghost> enumerate_ghosts(const System& system, const GhostOptions& options = {});
std::size_t ghost_count(const System& system, const GhostOptions& options = {});

// Fresnel/coating factor of a ghost for the axial ray at normal incidence at the TraceSystem's wavelength:
// R_j * R_i * product of T at every other visit. A quick brightness estimate (intensity LOD, sorting);
// the per-ray value at any angle is TraceResult::transmission.
double ghost_axial_factor(const TraceSystem& system, const Ghost& ghost);

// First-order imaging of a ghost, for drawing the ghosts of extended sources: magnification is how far the
// ghost's centre moves on the sensor per unit movement of the light's direct image (negative: the other
// way, an inverted image of the source; the direct path has 1), for a light near the axis; blur_mm is the
// diameter of its defocused image of a point light with the whole entrance pupil open (unclipped).
struct GhostImaging {
    double magnification = 1.0;
    double blur_mm = 0.0;
};
// Per ghost, from real rays traced close to the axis (both 1 and 0 where a ghost's rays fail).
std::vector<GhostImaging> ghost_imaging(const System& system, const std::vector<Ghost>& ghosts,
                                        double wavelength_nm = kLambdaD_nm);

}  // namespace lensfx::optics
