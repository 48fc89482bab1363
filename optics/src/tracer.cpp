#include <optics/tracer.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

#include <optics/fresnel.h>

namespace lensfx::optics {

namespace {

constexpr int kAsphereIterations = 30;

struct Intersection {
    double t;
    Vec3 normal;  // unnormalised is fine for the callers that normalise; here it is unit length
};

enum class Hit { Ok, Miss, NonFinite };

double poly_sag(const TraceInterface& s, double u) {  // u = h^2
    const auto& a = s.aspheric;
    return u * u * (a[0] + u * (a[1] + u * (a[2] + u * a[3])));
}
double poly_sag_du(const TraceInterface& s, double u) {
    const auto& a = s.aspheric;
    return u * (2.0 * a[0] + u * (3.0 * a[1] + u * (4.0 * a[2] + u * 5.0 * a[3])));
}

// Conic sag and its derivative with respect to u = h^2; false outside the conic's domain.
bool conic_sag(const TraceInterface& s, double u, double& z, double& dz_du) {
    const double c = s.curvature;
    const double disc = 1.0 - (1.0 + s.conic) * c * c * u;
    if (disc < 0.0) return false;
    const double S = std::sqrt(disc);
    z = c * u / (1.0 + S);
    dz_du = S > 0.0 ? c / (2.0 * S) : std::copysign(HUGE_VAL, c);
    return true;
}

// Fixed-order intersection with the quadric c (x^2 + y^2 + (1+k) z^2) - 2 z = 0 (vertex at the origin of
// q): the root whose quadric gradient g satisfies g . d = -sign * sqrt(disc), i.e. the cap through the
// vertex for paraxial rays travelling in the step's nominal direction, continued smoothly to all rays.
Hit intersect_quadric(const TraceInterface& s, const Vec3& q, const Vec3& d, bool forward, double& t) {
    const double c = s.curvature;
    const double k1 = 1.0 + s.conic;
    const double a = c * (d.x * d.x + d.y * d.y + k1 * d.z * d.z);
    const double B = c * (q.x * d.x + q.y * d.y + k1 * q.z * d.z) - d.z;
    const double C = c * (q.x * q.x + q.y * q.y + k1 * q.z * q.z) - 2.0 * q.z;
    if (a == 0.0) {
        if (B == 0.0) return Hit::Miss;
        t = -C / (2.0 * B);
        return std::isfinite(t) ? Hit::Ok : Hit::NonFinite;
    }
    const double D = B * B - a * C;
    if (D < 0.0) return Hit::Miss;
    const double sq = std::sqrt(D);
    const double sgn = forward ? 1.0 : -1.0;
    if (-B * sgn >= 0.0) {
        const double den = -B + sgn * sq;
        t = den != 0.0 ? C / den : 0.0;
    } else {
        t = (-B - sgn * sq) / a;
    }
    return std::isfinite(t) ? Hit::Ok : Hit::NonFinite;
}

// Intersection point (lens coordinates) and unit normal of an interface along the step's direction.
Hit intersect(const TraceInterface& s, const Vec3& o, const Vec3& d, bool forward, double& t, Vec3& p, Vec3& n) {
    const Vec3 q{o.x, o.y, o.z - s.z};
    if (s.curvature == 0.0 && !s.has_aspheric) {
        if (d.z == 0.0) return Hit::Miss;
        t = -q.z / d.z;
        p = o + t * d;
        n = {0.0, 0.0, 1.0};
        return is_finite(p) ? Hit::Ok : Hit::NonFinite;
    }
    // Solve from the point of the ray nearest the vertex: a far origin would cost the quadratic's
    // discriminant its precision (cancellation between B^2 and a C).
    const double t0 = -dot(q, d);
    const Vec3 q_near = q + t0 * d;
    Hit h = intersect_quadric(s, q_near, d, forward, t);
    t += t0;
    if (h == Hit::Ok && !std::isfinite(t)) h = Hit::NonFinite;
    if (h != Hit::Ok) {
        if (!s.has_aspheric || h == Hit::NonFinite) return h;
        t = -q.z / d.z;  // start the asphere iteration from the tangent plane
        if (!std::isfinite(t)) return Hit::Miss;
    }
    if (s.has_aspheric) {
        // Newton on G(t) = sag(h(t)^2) - z(t), from the conic root.
        bool converged = false;
        for (int it = 0; it < kAsphereIterations; ++it) {
            const Vec3 x = q + t * d;
            const double u = x.x * x.x + x.y * x.y;
            double zc = 0.0, dzc = 0.0;
            if (!conic_sag(s, u, zc, dzc)) return Hit::Miss;
            const double G = zc + poly_sag(s, u) - x.z;
            const double dG = (dzc + poly_sag_du(s, u)) * 2.0 * (x.x * d.x + x.y * d.y) - d.z;
            if (dG == 0.0 || !std::isfinite(dG)) return Hit::Miss;
            const double step = G / dG;
            t -= step;
            if (!std::isfinite(t)) return Hit::NonFinite;
            if (std::abs(step) <= 1e-14 * (1.0 + std::abs(t))) {
                converged = true;
                break;
            }
        }
        if (!converged) return Hit::Miss;
        const Vec3 x = q + t * d;
        const double u = x.x * x.x + x.y * x.y;
        double zc = 0.0, dzc = 0.0;
        if (!conic_sag(s, u, zc, dzc)) return Hit::Miss;
        const double du = dzc + poly_sag_du(s, u);
        n = normalize(Vec3{2.0 * x.x * du, 2.0 * x.y * du, -1.0});
        p = o + t * d;
        return is_finite(p) && is_finite(n) ? Hit::Ok : Hit::NonFinite;
    }
    const Vec3 x = q + t * d;
    p = o + t * d;
    const double c = s.curvature;
    n = Vec3{c * x.x, c * x.y, c * (1.0 + s.conic) * x.z - 1.0};
    const double len = length(n);
    if (!(len > 0.0) || !std::isfinite(len)) return Hit::NonFinite;
    n = n * (1.0 / len);
    return is_finite(p) ? Hit::Ok : Hit::NonFinite;
}

TraceResult fail(TraceResult r, TraceStatus status, int step, int iface) {
    r.status = status;
    r.failed_step = step;
    r.failed_interface = iface;
    r.transmission = 0.0;
    return r;
}

}  // namespace

const char* to_string(TraceStatus status) {
    switch (status) {
        case TraceStatus::Ok: return "ok";
        case TraceStatus::NoIntersection: return "no intersection";
        case TraceStatus::TotalInternalReflection: return "total internal reflection";
        case TraceStatus::NonFinite: return "non-finite";
        case TraceStatus::BadPath: return "bad path";
    }
    return "unknown";
}

std::vector<Step> direct_path(const System& system) {
    std::vector<Step> path;
    path.reserve(system.interfaces.size());
    for (std::size_t i = 0; i < system.interfaces.size(); ++i) path.push_back({static_cast<int>(i), false, true});
    return path;
}

std::vector<Step> reversed_path(std::span<const Step> path) {
    std::vector<Step> out;
    out.reserve(path.size());
    for (auto it = path.rbegin(); it != path.rend(); ++it)
        out.push_back({it->interface, it->reflect, it->reflect ? it->forward : !it->forward});
    return out;
}

TraceSystem::TraceSystem(const System& system, double wavelength_nm)
    : stop_(system.stop), sensor_z_(system.sensor_z_mm), wavelength_nm_(wavelength_nm), name_(system.name) {
    if (!(wavelength_nm > 0.0) || !std::isfinite(wavelength_nm))
        throw std::invalid_argument(fmt::format("lens '{}': bad wavelength {} nm", system.name, wavelength_nm));
    interfaces_.reserve(system.interfaces.size());
    for (std::size_t i = 0; i < system.interfaces.size(); ++i) {
        const auto& in = system.interfaces[i];
        TraceInterface s;
        const auto where = [&] { return fmt::format("lens '{}', interface {}", system.name, i + 1); };
        if (!std::isfinite(in.radius_mm) || !std::isfinite(in.z_mm) || !std::isfinite(in.semi_diameter_mm) ||
            !std::isfinite(in.conic))
            throw std::invalid_argument(where() + ": non-finite radius, position, semi-diameter or conic");
        if (in.aspheric.size() > 4)
            throw std::invalid_argument(where() + ": more than 4 aspheric coefficients (a4..a10)");
        s.z = in.z_mm;
        s.curvature = in.radius_mm == 0.0 ? 0.0 : 1.0 / in.radius_mm;
        s.conic = in.conic;
        for (std::size_t k = 0; k < in.aspheric.size(); ++k) {
            if (!std::isfinite(in.aspheric[k])) throw std::invalid_argument(where() + ": non-finite aspheric coefficient");
            s.aspheric[k] = in.aspheric[k];
            s.has_aspheric = s.has_aspheric || in.aspheric[k] != 0.0;
        }
        s.semi_diameter = in.semi_diameter_mm;
        s.is_stop = in.is_stop;
        try {
            s.n_before = in.before.index(wavelength_nm);
            s.n_after = in.after.index(wavelength_nm);
            s.coating = resolve_coating(in.coating, in.before, in.after, wavelength_nm);
        } catch (const std::exception& e) {
            throw std::invalid_argument(where() + ": " + e.what());
        }
        interfaces_.push_back(std::move(s));
    }
}

TraceResult trace(const TraceSystem& system, const Ray& ray, std::span<const Step> path, const TraceOptions& options,
                  std::span<TraceHit> hits) {
    TraceResult r;
    r.position = ray.origin;
    r.direction = ray.direction;
    if (!is_finite(ray.origin) || !is_finite(ray.direction) || !(length(ray.direction) > 0.0)) {
        r.position = {};
        r.direction = {0.0, 0.0, 1.0};
        return fail(r, TraceStatus::NonFinite, 0, path.empty() ? -1 : path[0].interface);
    }
    const auto& ifs = system.interfaces();
    const int count = static_cast<int>(ifs.size());
    Vec3 o = ray.origin;
    Vec3 d = normalize(ray.direction);
    r.direction = d;
    double transmission = 1.0;
    double n_cur = path.empty() || path[0].interface < 0 || path[0].interface >= count
                       ? 1.0
                       : (path[0].forward ? ifs[path[0].interface].n_before : ifs[path[0].interface].n_after);
    double max_uv2 = -1.0;
    const bool record = hits.size() >= path.size();
    for (std::size_t k = 0; k < path.size(); ++k) {
        const Step& st = path[k];
        const int si = static_cast<int>(k);
        if (st.interface < 0 || st.interface >= count) return fail(r, TraceStatus::BadPath, si, st.interface);
        const TraceInterface& s = ifs[st.interface];
        if (s.is_stop && st.reflect) return fail(r, TraceStatus::BadPath, si, st.interface);
        double t = 0.0;
        Vec3 p, n;
        const Hit h = intersect(s, o, d, st.forward, t, p, n);
        if (h != Hit::Ok)
            return fail(r, h == Hit::Miss ? TraceStatus::NoIntersection : TraceStatus::NonFinite, si, st.interface);
        if (t < 0.0) r.virtual_path = true;
        const double opl = r.optical_path_mm + n_cur * t;
        const double rad = std::sqrt(p.x * p.x + p.y * p.y);
        double cos_i = std::min(1.0, std::abs(dot(d, n)));
        double factor = 1.0;
        Vec3 d_new = d;
        if (s.is_stop) {
            const double inv = s.semi_diameter > 0.0 ? 1.0 / s.semi_diameter : 1.0;
            const Vec2 uv{p.x * inv, p.y * inv};
            if (r.stop_count < static_cast<int>(r.stop_crossings.size())) r.stop_crossings[r.stop_count++] = uv;
            const double uv2 = uv.x * uv.x + uv.y * uv.y;
            if (uv2 > max_uv2) {
                max_uv2 = uv2;
                r.stop_uv = uv;
            }
        } else {
            if (s.semi_diameter > 0.0) r.r_rel = std::max(r.r_rel, rad / s.semi_diameter);
            const double n1 = st.forward ? s.n_before : s.n_after;
            const double n2 = st.forward ? s.n_after : s.n_before;
            const Reflectance rt = coated_reflectance(s.coating, n1, n2, cos_i, system.wavelength_nm(), st.forward);
            if (st.reflect) {
                d_new = reflect(d, n);
                factor = rt.R;
            } else {
                double ci = 0.0, ct = 0.0;
                if (!refract(d, n, n1, n2, d_new, ci, ct)) {
                    r.position = p;
                    return fail(r, TraceStatus::TotalInternalReflection, si, st.interface);
                }
                cos_i = ci;
                factor = rt.T;
                n_cur = n2;
            }
        }
        if (!is_finite(d_new) || !std::isfinite(opl)) return fail(r, TraceStatus::NonFinite, si, st.interface);
        transmission *= factor;
        o = p;
        d = d_new;
        r.position = p;
        r.direction = d;
        r.optical_path_mm = opl;
        if (record) hits[k] = TraceHit{p, d, t, cos_i, factor};
    }
    if (options.to_sensor) {
        const double t = (system.sensor_z() - o.z) / d.z;
        const Vec3 p = o + t * d;
        if (d.z == 0.0 || !std::isfinite(t) || !is_finite(p))
            return fail(r, TraceStatus::NonFinite, static_cast<int>(path.size()), -1);
        if (t < 0.0) r.virtual_path = true;
        r.position = p;
        r.optical_path_mm += n_cur * t;
    }
    r.transmission = transmission;
    return r;
}

TraceResult trace(const System& system, const Ray& ray, double wavelength_nm, std::span<const Step> path,
                  const TraceOptions& options) {
    return trace(TraceSystem(system, wavelength_nm), ray, path, options);
}

bool surface_sag(const TraceInterface& surface, double h, double& sag) {
    const double u = h * h;
    double z = 0.0, dz = 0.0;
    if (!conic_sag(surface, u, z, dz)) return false;
    sag = z + (surface.has_aspheric ? poly_sag(surface, u) : 0.0);
    return std::isfinite(sag);
}

MeridionalTrace trace_meridional(const System& system, double height_mm, double angle_deg, double wavelength_nm) {
    const TraceSystem ts(system, wavelength_nm);
    const auto path = direct_path(system);
    std::vector<TraceHit> hits(path.size());
    const double a = angle_deg * std::numbers::pi / 180.0;
    const double z0 = system.interfaces.empty() ? 0.0 : system.interfaces.front().z_mm;
    const Ray ray{{0.0, height_mm, z0}, {0.0, -std::sin(a), std::cos(a)}};
    MeridionalTrace out;
    out.result = trace(ts, ray, path, {}, hits);
    const std::size_t reached = out.result.ok() ? path.size()
                                : out.result.failed_step < 0 ? 0
                                                             : static_cast<std::size_t>(out.result.failed_step);
    for (std::size_t k = 0; k < reached && k < path.size(); ++k) {
        const auto& h = hits[k];
        out.surfaces.push_back({static_cast<int>(k) + 1,
                                {h.position.x, h.position.y, h.position.z - ts.interfaces()[k].z},
                                h.direction,
                                h.t});
    }
    if (out.result.ok() && !path.empty())
        out.sensor_path_mm = length(out.result.position - hits.back().position);
    return out;
}

Ray collimated_ray(double ax_deg, double ay_deg, double x, double y, double z_plane) {
    const double k = std::numbers::pi / 180.0;
    return {{x, y, z_plane}, normalize(Vec3{-std::tan(ax_deg * k), -std::tan(ay_deg * k), 1.0})};
}

}  // namespace lensfx::optics
