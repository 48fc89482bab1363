// Fresnel reflection and transmission at a bare interface between two lossless dielectrics, for
// unpolarised light (the s and p intensities averaged, as in the flare paper's section 3.1), plus the
// vector laws of refraction and reflection that the tracer uses.
#pragma once

#include <optics/vec3.h>

namespace lensfx::optics {

// Intensity (power) reflectance and transmittance of one interface. For lossless media R + T = 1.
struct Reflectance {
    double R = 0.0;
    double T = 1.0;
};

// Light in medium n1 meets medium n2 with cos(angle of incidence) = cos_i in [0, 1] (values outside are
// clamped). Handles every angle: total internal reflection gives R = 1, T = 0; grazing incidence
// (cos_i = 0) gives R = 1 unless n1 == n2; n1 == n2 gives R = 0, T = 1 exactly. R and T are computed
// from their own amplitude formulas (not T = 1 - R) and agree with R + T = 1 to rounding. Never NaN.
Reflectance fresnel_unpolarized(double n1, double n2, double cos_i);

// The same for one polarisation: s (TE, electric field perpendicular to the plane of incidence) or p (TM).
Reflectance fresnel_s(double n1, double n2, double cos_i);
Reflectance fresnel_p(double n1, double n2, double cos_i);

// cos of the refraction angle for light from n1 into n2 at cos_i; negative when the light is totally
// internally reflected (no transmitted wave).
double cos_transmitted(double n1, double n2, double cos_i);

// Vector refraction (Snell's law). d: unit direction of the incident ray; normal: unit surface normal
// on either side (it is flipped to face the incident ray). Returns false (and leaves `out` untouched)
// on total internal reflection; otherwise `out` is the unit refracted direction and cos_i / cos_t the
// cosines of incidence and refraction.
bool refract(const Vec3& d, const Vec3& normal, double n1, double n2, Vec3& out, double& cos_i, double& cos_t);

// Vector reflection of unit direction d about the unit normal (either side).
Vec3 reflect(const Vec3& d, const Vec3& normal);

}  // namespace lensfx::optics
