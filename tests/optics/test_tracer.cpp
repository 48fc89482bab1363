// The exact sequential tracer: intersections, refraction, the paper's fixed-order rule, r_rel and stop
// coordinates, failure flags, aspheres, and focal lengths of the reference designs.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include <optics/paraxial.h>
#include <optics/presets.h>
#include <optics/system.h>
#include <optics/tracer.h>

#include "physics_systems.h"

using namespace lensfx::optics;
using namespace lensfx::optics::testing;

namespace {

// Effective and back focal lengths from a near-axis real ray (error O(h^2), here ~1e-12 relative).
struct Focal {
    double efl, bfl;
};
Focal focal_from_ray(const System& sys, double nm) {
    const double h = 1e-6;
    const auto path = direct_path(sys);
    const TraceResult r = trace(sys, Ray{{0.0, h, -1.0}, {0.0, 0.0, 1.0}}, nm, path, {false});
    EXPECT_TRUE(r.ok());
    const double slope = r.direction.y / r.direction.z;
    const double z_focus = r.position.z - r.position.y / slope;
    return {-h / slope, z_focus - sys.interfaces.back().z_mm};
}

System single_surface(double radius, const Glass& after, double semi = 10.0) {
    System s;
    System::Interface in{};
    in.radius_mm = radius;
    in.semi_diameter_mm = semi;
    in.before = Glass::air();
    in.after = after;
    s.interfaces.push_back(in);
    s.sensor_z_mm = 100.0;
    return s;
}

double deg(double a) { return a * std::numbers::pi / 180.0; }

}  // namespace

TEST(Tracer, DoubleGaussFocalLengthsMatchCodeV) {
    // CODE V (issue 3): EFL 100.0038, BFL 61.4875 at 587.6 nm, given to 4 decimals.
    const Focal f = focal_from_ray(double_gauss(), 587.6);
    EXPECT_NEAR(f.efl, 100.0038, 1e-4);
    EXPECT_NEAR(f.bfl, 61.4875, 1e-4);
    std::printf("double Gauss: EFL %.5f (CODE V 100.0038), BFL %.5f (61.4875)\n", f.efl, f.bfl);
}

TEST(Tracer, CookeTripletFocalLength) {
    const Focal f = focal_from_ray(cooke_triplet(), 550.0);
    EXPECT_NEAR(f.efl, 49.99978, 1e-5);
    std::printf("Cooke triplet: EFL %.5f (stated 49.99978)\n", f.efl);
}

TEST(Tracer, SnellAtASphereAndPlane) {
    const Glass g = glass_from_abbe(1.5, 60.0);
    const double n = g.index(587.56);
    for (double radius : {0.0, 50.0, -50.0, 1e9}) {
        const System s = single_surface(radius, g);
        const Ray ray = collimated_ray(0.0, 20.0, 0.0, 3.0, -5.0);
        std::vector<TraceHit> hits(1);
        const auto path = direct_path(s);
        const TraceResult r = trace(TraceSystem(s, 587.56), ray, path, {}, hits);
        ASSERT_TRUE(r.ok());
        // Surface normal at the hit (towards the object side) and Snell's law in vector form.
        const Vec3 p = hits[0].position;
        const Vec3 nrm = radius == 0.0 ? Vec3{0, 0, -1} : normalize(Vec3{p.x, p.y, p.z - radius}) * (radius > 0 ? 1.0 : -1.0);
        const Vec3 sin_in = cross(ray.direction, nrm);
        const Vec3 sin_out = cross(hits[0].direction, nrm);
        EXPECT_NEAR(sin_in.x, n * sin_out.x, 1e-13) << radius;
        EXPECT_NEAR(length(sin_in), n * length(sin_out), 1e-13);
        EXPECT_NEAR(r.transmission, fresnel_unpolarized(1.0, n, hits[0].cos_incidence).T, 1e-15);
        // The hit lies on the surface.
        if (radius != 0.0) {
            EXPECT_NEAR(length(Vec3{p.x, p.y, p.z - radius}), std::abs(radius), 1e-9 * std::max(1.0, std::abs(radius) * 1e-6));
        }
    }
}

TEST(Tracer, FixedOrderPicksTheVertexCapBothWays) {
    // Axial rays hit the vertex whichever side they come from and whatever the ray parameter's sign.
    for (double radius : {20.0, -20.0}) {
        System s = single_surface(radius, glass_from_abbe(1.5, 60.0));
        s.interfaces[0].z_mm = 5.0;
        const TraceSystem ts(s, 550.0);
        for (bool forward : {true, false}) {
            for (double z0 : {-10.0, 30.0}) {
                const Step step{0, true, forward};
                const Vec3 dir{0.0, 0.0, forward ? 1.0 : -1.0};
                const TraceResult r = trace(ts, Ray{{0.0, 0.0, z0}, dir}, {&step, 1}, {false});
                ASSERT_TRUE(r.ok());
                EXPECT_NEAR(r.position.z, 5.0, 1e-12) << radius << " " << forward << " " << z0;
                const bool behind = forward ? z0 > 5.0 : z0 < 5.0;
                EXPECT_EQ(r.virtual_path, behind);
            }
        }
    }
}

TEST(Tracer, FailuresAreFlaggedWithFiniteOutputs) {
    const Glass g = glass_from_abbe(1.5, 60.0);
    // Miss: a ray far outside a small sphere.
    {
        const System s = single_surface(5.0, g);
        const TraceResult r = trace(s, Ray{{0.0, 50.0, -10.0}, {0.0, 0.0, 1.0}}, 550.0, direct_path(s));
        EXPECT_EQ(r.status, TraceStatus::NoIntersection);
        EXPECT_EQ(r.failed_interface, 0);
        EXPECT_EQ(r.transmission, 0.0);
        EXPECT_TRUE(is_finite(r.position) && is_finite(r.direction));
    }
    // Parallel to a plane.
    {
        const System s = single_surface(0.0, g);
        const TraceResult r = trace(s, Ray{{0.0, 1.0, -10.0}, {0.0, 1.0, 0.0}}, 550.0, direct_path(s));
        EXPECT_NE(r.status, TraceStatus::Ok);
        EXPECT_TRUE(is_finite(r.position) && is_finite(r.direction));
    }
    // TIR leaving a glass block at 60 degrees.
    {
        System s = single_surface(0.0, g);
        System::Interface back = s.interfaces[0];
        back.z_mm = 10.0;
        back.before = g;
        back.after = Glass::air();
        s.interfaces.push_back(back);
        const Step path[] = {{1, false, true}};
        const TraceResult r = trace(s, Ray{{0.0, 0.0, 5.0}, {std::sin(deg(60.0)), 0.0, std::cos(deg(60.0))}}, 550.0, path);
        EXPECT_EQ(r.status, TraceStatus::TotalInternalReflection);
        EXPECT_EQ(r.failed_step, 0);
        EXPECT_TRUE(is_finite(r.position));
        // The same ray reflected there is a valid (total) reflection.
        const Step refl[] = {{1, true, true}};
        const TraceResult rr = trace(s, Ray{{0.0, 0.0, 5.0}, {std::sin(deg(60.0)), 0.0, std::cos(deg(60.0))}}, 550.0, refl, {false});
        EXPECT_TRUE(rr.ok());
        EXPECT_EQ(rr.transmission, 1.0);
    }
    // Bad paths and bad rays.
    {
        const System s = single_surface(10.0, g);
        const Step bad[] = {{3, false, true}};
        EXPECT_EQ(trace(s, Ray{{0, 0, -1}, {0, 0, 1}}, 550.0, bad).status, TraceStatus::BadPath);
        const TraceResult r = trace(s, Ray{{0, 0, -1}, {0, std::nan(""), 1}}, 550.0, direct_path(s));
        EXPECT_EQ(r.status, TraceStatus::NonFinite);
        EXPECT_TRUE(is_finite(r.position) && is_finite(r.direction));
    }
}

TEST(Tracer, RelativeRadiusAndStopCoordinates) {
    const System dg = double_gauss();
    const TraceSystem ts(dg, 587.56);
    const auto path = direct_path(dg);
    // The axial marginal ray of the EPD 50 defines the stop radius: |uv| = 1 there.
    const TraceResult m = trace(ts, Ray{{0.0, 25.0, -1.0}, {0.0, 0.0, 1.0}}, path);
    ASSERT_TRUE(m.ok());
    EXPECT_NEAR(m.stop_uv.y, 1.0, 1e-12);
    EXPECT_NEAR(m.stop_uv.x, 0.0, 1e-15);
    EXPECT_EQ(m.stop_count, 1);
    EXPECT_LE(m.r_rel, 1.0);
    // Twice the height: r_rel is still recorded, above 1, and the ray still arrives.
    const TraceResult big = trace(ts, Ray{{0.0, 32.0, -1.0}, {0.0, 0.0, 1.0}}, path);
    EXPECT_GT(big.r_rel, 1.0);
    EXPECT_GT(std::abs(big.stop_uv.y), 1.0);
    // Rays along x map to u, along y to v, same sign (lens coordinates, no flip).
    const TraceResult xr = trace(ts, Ray{{10.0, 0.0, -1.0}, {0.0, 0.0, 1.0}}, path);
    EXPECT_GT(xr.stop_uv.x, 0.0);
    EXPECT_NEAR(xr.stop_uv.y, 0.0, 1e-15);
    // Transmission of the uncoated direct path: about 0.96^10 for 10 air/glass interfaces at normal incidence.
    EXPECT_GT(m.transmission, 0.5);
    EXPECT_LT(m.transmission, 0.8);
}

TEST(Tracer, ImageOfADistantLightIsUpsideDownOnTheSensor) {
    // DESIGN.md: a light above the axis images below it on the sensor (the photograph is turned 180 degrees).
    const System dg = double_gauss();
    const TraceResult r = trace(dg, collimated_ray(0.0, 5.0, 0.0, 0.0, -20.0), 587.56, direct_path(dg));
    ASSERT_TRUE(r.ok());
    EXPECT_LT(r.position.y, 0.0);
    EXPECT_NEAR(r.position.y, -100.0 * std::tan(deg(5.0)), 0.2);  // distortion is small in a double Gauss
}

TEST(Tracer, AsphereHitLiesOnTheSurface) {
    System s = single_surface(30.0, glass_from_abbe(1.6, 50.0), 20.0);
    s.interfaces[0].conic = -0.7;
    s.interfaces[0].aspheric = {2e-5, -3e-8, 1e-11, 0.0};
    const TraceSystem ts(s, 550.0);
    std::vector<TraceHit> hits(1);
    for (double y = -15.0; y <= 15.0; y += 1.5) {
        for (double a : {-30.0, 0.0, 25.0}) {
            const TraceResult r = trace(ts, collimated_ray(0.0, a, 0.0, y, -5.0), direct_path(s), {}, hits);
            ASSERT_TRUE(r.ok()) << y << " " << a;
            const Vec3 p = hits[0].position;
            double sag = 0.0;
            ASSERT_TRUE(surface_sag(ts.interfaces()[0], std::hypot(p.x, p.y), sag));
            EXPECT_NEAR(p.z, sag, 1e-12);
        }
    }
    // A pure conic through the Newton path agrees with the closed-form quadric root.
    System c = s;
    c.interfaces[0].aspheric = {};
    System cn = s;
    cn.interfaces[0].aspheric = {0.0, 0.0, 0.0, 1e-30};
    const Ray ray = collimated_ray(3.0, 12.0, 1.0, 4.0, -5.0);
    const TraceResult a = trace(c, ray, 550.0, direct_path(c));
    const TraceResult b = trace(cn, ray, 550.0, direct_path(cn));
    EXPECT_NEAR(a.position.x, b.position.x, 1e-11);
    EXPECT_NEAR(a.position.y, b.position.y, 1e-11);
}

TEST(Tracer, MeridionalTraceReportsEverySurface) {
    const System dg = double_gauss();
    const MeridionalTrace mt = trace_meridional(dg, 10.0, 0.0, 587.56);
    ASSERT_TRUE(mt.result.ok());
    ASSERT_EQ(mt.surfaces.size(), dg.interfaces.size());
    const TraceSystem ts(dg, 587.56);
    for (std::size_t k = 0; k < mt.surfaces.size(); ++k) {
        const auto& s = mt.surfaces[k];
        EXPECT_EQ(s.surface, static_cast<int>(k) + 1);
        EXPECT_EQ(s.local.x, 0.0);
        double sag = 0.0;
        ASSERT_TRUE(surface_sag(ts.interfaces()[k], std::abs(s.local.y), sag));
        EXPECT_NEAR(s.local.z, sag, 1e-12);
        EXPECT_NEAR(length(s.direction), 1.0, 1e-14);
        EXPECT_GT(s.path_mm, 0.0);
    }
    EXPECT_NEAR(mt.surfaces[0].local.y, 10.0, 1e-12);  // parallel to the axis: enters at its height
    EXPECT_NEAR(mt.surfaces[5].local.z, 0.0, 0.0);      // the stop is a plane
    EXPECT_GT(mt.sensor_path_mm, 50.0);
}

TEST(Tracer, ReversedPathRetracesTheRay) {
    const System dg = double_gauss();
    const TraceSystem ts(dg, 486.13);
    const auto path = direct_path(dg);
    const auto back = reversed_path(path);
    ASSERT_EQ(back.size(), path.size());
    EXPECT_EQ(back.front().interface, static_cast<int>(dg.interfaces.size()) - 1);
    EXPECT_FALSE(back.front().forward);
    std::vector<TraceHit> hits(path.size());
    const TraceResult f = trace(ts, collimated_ray(3.0, -7.0, 4.0, 8.0, -10.0), path, {}, hits);
    ASSERT_TRUE(f.ok());
    const TraceResult b = trace(ts, Ray{f.position, -f.direction}, back, {false});
    ASSERT_TRUE(b.ok());
    EXPECT_NEAR(length(b.position - hits[0].position), 0.0, 1e-10);
    EXPECT_NEAR(b.transmission, f.transmission, 1e-14);
}

TEST(Tracer, NearAxisRaysAgreeWithParaxialAnalysisOnEveryPreset) {
    // Two independent computations of the same first-order data: this tracer's near-axis real ray and
    // the y-nu paraxial trace of optics/paraxial.h, at every zoom end and the middle.
    int checked = 0;
    for (const auto& name : preset_names()) {
        const Lens lens = load_preset(name);
        for (double zoom : lens.zoom_positions() > 1 ? std::vector<double>{0.0, 0.5, 1.0} : std::vector<double>{0.0}) {
            const System sys = realize(lens, zoom);
            for (double nm : {450.0, 587.56, 650.0}) {
                const Paraxial p = paraxial(sys, nm);
                const Focal f = focal_from_ray(sys, nm);
                EXPECT_NEAR(f.efl, p.efl_mm, 1e-6 * std::abs(p.efl_mm)) << name << " zoom " << zoom << " " << nm << " nm";
                EXPECT_NEAR(f.bfl, p.bfl_mm, 1e-6 * std::abs(p.efl_mm)) << name << " zoom " << zoom << " " << nm << " nm";
                ++checked;
            }
        }
    }
    EXPECT_GT(checked, 30);
}
