#include <optics/fresnel.h>

#include <algorithm>
#include <cmath>

namespace lensfx::optics {

namespace {

double clamp_cos(double c) { return std::isnan(c) ? 0.0 : std::clamp(c, 0.0, 1.0); }

// Shared front end: the cosine of refraction, or a decided result (TIR, grazing, matched media).
struct Setup {
    double ci, ct;
    bool decided;
    Reflectance result;
};

Setup setup(double n1, double n2, double cos_i) {
    const double ci = clamp_cos(cos_i);
    if (n1 == n2) return {ci, ci, true, {0.0, 1.0}};
    const double ct = cos_transmitted(n1, n2, ci);
    if (ct < 0.0 || ci == 0.0) return {ci, 0.0, true, {1.0, 0.0}};
    return {ci, ct, false, {}};
}

// Amplitude formulas: a = n1 cos(first), b = n2 cos(second) for s (first = incidence) or swapped
// cosines for p. r = (a - b) / (a + b), T = 4 a b / (a + b)^2: both finite since a + b > 0 here.
Reflectance from_amplitudes(double a, double b) {
    const double s = a + b;
    const double r = (a - b) / s;
    return {r * r, 4.0 * a * b / (s * s)};
}

}  // namespace

double cos_transmitted(double n1, double n2, double cos_i) {
    const double ci = clamp_cos(cos_i);
    const double eta = n1 / n2;
    const double sin2_t = eta * eta * std::max(0.0, (1.0 - ci) * (1.0 + ci));
    if (sin2_t > 1.0) return -1.0;
    return std::sqrt((1.0 - sin2_t));
}

Reflectance fresnel_s(double n1, double n2, double cos_i) {
    const Setup su = setup(n1, n2, cos_i);
    if (su.decided) return su.result;
    return from_amplitudes(n1 * su.ci, n2 * su.ct);
}

Reflectance fresnel_p(double n1, double n2, double cos_i) {
    const Setup su = setup(n1, n2, cos_i);
    if (su.decided) return su.result;
    return from_amplitudes(n2 * su.ci, n1 * su.ct);
}

Reflectance fresnel_unpolarized(double n1, double n2, double cos_i) {
    const Setup su = setup(n1, n2, cos_i);
    if (su.decided) return su.result;
    const Reflectance s = from_amplitudes(n1 * su.ci, n2 * su.ct);
    const Reflectance p = from_amplitudes(n2 * su.ci, n1 * su.ct);
    return {0.5 * (s.R + p.R), 0.5 * (s.T + p.T)};
}

bool refract(const Vec3& d, const Vec3& normal, double n1, double n2, Vec3& out, double& cos_i, double& cos_t) {
    Vec3 n = normal;
    double ci = -dot(n, d);
    if (ci < 0.0) {
        n = -n;
        ci = -ci;
    }
    ci = std::min(ci, 1.0);
    const double eta = n1 / n2;
    const double sin2_t = eta * eta * std::max(0.0, (1.0 - ci) * (1.0 + ci));
    if (sin2_t > 1.0) return false;
    const double ct = std::sqrt(1.0 - sin2_t);
    Vec3 t = eta * d + (eta * ci - ct) * n;
    out = normalize(t);
    cos_i = ci;
    cos_t = ct;
    return true;
}

Vec3 reflect(const Vec3& d, const Vec3& normal) {
    return normalize(d - 2.0 * dot(d, normal) * normal);
}

}  // namespace lensfx::optics
