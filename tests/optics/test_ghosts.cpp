// Ghost enumeration: counts (all, aperture-culled), path structure, and the Fresnel/coating factors
// along a ghost against hand-computed products.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <optics/ghosts.h>
#include <optics/paraxial.h>

#include "physics_systems.h"

using namespace lensfx::optics;
using namespace lensfx::optics::testing;

TEST(Ghosts, CountsFollowThePaper) {
    const System dg = double_gauss();
    const auto refl = reflecting_interfaces(dg);
    ASSERT_EQ(refl.size(), 10u);  // 11 interfaces, the stop excluded
    EXPECT_EQ(std::count(refl.begin(), refl.end(), dg.stop), 0);
    EXPECT_EQ(enumerate_ghosts(dg).size(), 45u);
    EXPECT_EQ(ghost_count(dg), 45u);
    // Aperture culling: 5 reflecting interfaces in front of the stop, 5 behind -> (20 + 20) / 2.
    GhostOptions cull;
    cull.aperture_culling = true;
    EXPECT_EQ(enumerate_ghosts(dg, cull).size(), 20u);
    EXPECT_EQ(ghost_count(dg, cull), 20u);
    for (const auto& g : enumerate_ghosts(dg, cull)) EXPECT_FALSE(g.crosses_stop_three_times);
}

TEST(Ghosts, PathsHaveTwoReflectionsAndConsistentDirections) {
    const System dg = double_gauss();
    const int n = static_cast<int>(dg.interfaces.size());
    for (const auto& g : enumerate_ghosts(dg)) {
        ASSERT_LT(g.second, g.first);
        int reflections = 0, stop_visits = 0;
        bool forward = true;
        for (std::size_t k = 0; k < g.path.size(); ++k) {
            const Step& s = g.path[k];
            EXPECT_EQ(s.forward, forward) << "ghost " << g.first << "," << g.second << " step " << k;
            if (s.reflect) {
                ++reflections;
                forward = !forward;
            }
            if (s.interface == dg.stop) ++stop_visits;
            // Consecutive visits are neighbouring interfaces (or the same one after a reflection).
            if (k > 0) {
                const Step& prev = g.path[k - 1];
                const bool leaves_forward = prev.reflect ? !prev.forward : prev.forward;
                const int expected = prev.interface + (leaves_forward ? 1 : -1);
                EXPECT_EQ(s.interface, expected);
            }
        }
        EXPECT_EQ(reflections, 2);
        EXPECT_TRUE(forward);
        EXPECT_EQ(g.path.front().interface, 0);
        EXPECT_EQ(g.path.back().interface, n - 1);
        EXPECT_EQ(g.path.size(), static_cast<std::size_t>(n + 2 * (g.first - g.second)));
        EXPECT_EQ(stop_visits, g.crosses_stop_three_times ? 3 : 1);
    }
}

TEST(Ghosts, GlassPlateGhostFactor) {
    // An uncoated plate: the one ghost reflects at the back, then at the front (inside), T R R T.
    System plate;
    const Glass g = glass_from_abbe(1.5, 60.0);
    for (int k = 0; k < 2; ++k) {
        System::Interface in{};
        in.z_mm = 5.0 * k;
        in.semi_diameter_mm = 20.0;
        in.before = k == 0 ? Glass::air() : g;
        in.after = k == 0 ? g : Glass::air();
        plate.interfaces.push_back(in);
    }
    plate.sensor_z_mm = 50.0;
    const auto ghosts = enumerate_ghosts(plate);
    ASSERT_EQ(ghosts.size(), 1u);
    const TraceSystem ts(plate, 550.0);
    const double n = g.index(550.0);
    const double R = std::pow((n - 1) / (n + 1), 2);
    EXPECT_NEAR(ghost_axial_factor(ts, ghosts[0]), (1 - R) * R * R * (1 - R), 1e-15);
    // The traced ray at normal incidence carries the same factor and lands where it started laterally.
    const TraceResult r = trace(ts, Ray{{1.0, 2.0, -1.0}, {0.0, 0.0, 1.0}}, ghosts[0].path);
    ASSERT_TRUE(r.ok());
    EXPECT_NEAR(r.transmission, (1 - R) * R * R * (1 - R), 1e-15);
    EXPECT_NEAR(r.position.x, 1.0, 1e-12);
    // Its optical path is the direct one plus a round trip through the glass.
    const TraceResult d = trace(ts, Ray{{1.0, 2.0, -1.0}, {0.0, 0.0, 1.0}}, direct_path(plate));
    EXPECT_NEAR(r.optical_path_mm - d.optical_path_mm, 2 * 5.0 * n, 1e-12);
}

TEST(Ghosts, CoatingsDimGhosts) {
    System dg = double_gauss();
    const auto ghosts = enumerate_ghosts(dg);
    const TraceSystem bare(dg, 550.0);
    for (auto& in : dg.interfaces)
        if (!in.is_stop && !same_medium(in.before, in.after)) in.coating.kind = Coating::Kind::QuarterWave;
    const TraceSystem coated(dg, 550.0);
    for (const auto& g : ghosts) {
        const double a = ghost_axial_factor(bare, g);
        const double b = ghost_axial_factor(coated, g);
        EXPECT_GT(a, 0.0);
        // Air/glass interfaces gain from MgF2; a cemented glass/glass interface may lose: compare the
        // ghosts whose both reflections are at air/glass interfaces.
        const auto air_glass = [&](int i) {
            return dg.interfaces[static_cast<std::size_t>(i)].before.is_air() ||
                   dg.interfaces[static_cast<std::size_t>(i)].after.is_air();
        };
        if (air_glass(g.first) && air_glass(g.second)) {
            EXPECT_LT(b, a) << g.first << "," << g.second;
        }
    }
}

TEST(Ghosts, ImagingOfAPlateGhostInAConvergingBeam) {
    // The double Gauss (f/2, EFL 100) with a 3 mm plate 20 mm behind its last vertex, the sensor moved to
    // the new focus. The ghost reflecting inside the plate crosses it three times: it keeps the direct
    // image's scale but for the chief ray's extra sideways step in the glass, 2 t u / n for a chief ray at
    // slope u = h / d from the exit pupil d before the sensor; and its extra 2 t of glass (2 t / n in air)
    // bring its focus that much in front of the sensor, so at f/N its blur is 2 t / (n N).
    auto specs = double_gauss_specs();
    const double t = 3.0;
    const Glass plate_glass = medium("N-BK7");
    const double n = plate_glass.index(kLambdaD_nm);
    const double back = specs.back().thickness;
    specs.back().thickness = 20.0;
    specs.push_back({0.0, t, "N-BK7"});
    specs.push_back({0.0, back - 20.0 - t + t * (1.0 - 1.0 / n), ""});
    const System system = build_system("double Gauss + plate", specs, 50.0, 14.0);
    const std::vector<Ghost> ghosts = enumerate_ghosts(system);
    const std::vector<GhostImaging> imaging = ghost_imaging(system, ghosts);
    const int last = static_cast<int>(system.interfaces.size()) - 1;
    bool found = false;
    for (std::size_t g = 0; g < ghosts.size(); ++g) {
        EXPECT_TRUE(std::isfinite(imaging[g].magnification) && std::isfinite(imaging[g].blur_mm));
        EXPECT_GE(imaging[g].blur_mm, 0.0);
        if (ghosts[g].first != last || ghosts[g].second != last - 1) continue;
        found = true;
        const Paraxial first_order = paraxial(system);
        const double f_number = first_order.f_number;
        const double exit_pupil_to_sensor = system.sensor_z_mm - system.interfaces.back().z_mm - first_order.exit_pupil_mm;
        const double step = 2.0 * t / (n * exit_pupil_to_sensor);
        EXPECT_NEAR(imaging[g].magnification, 1.0 + step, 0.05 * step);
        EXPECT_NEAR(imaging[g].blur_mm, 2.0 * t / (n * f_number), 0.02 * 2.0 * t / (n * f_number));
    }
    EXPECT_TRUE(found);
    // A ghost between the lens's own surfaces images the light elsewhere, blurred and scaled.
    const auto lens_ghost = std::find_if(ghosts.begin(), ghosts.end(), [](const Ghost& g) { return g.first == 2 && g.second == 0; });
    ASSERT_NE(lens_ghost, ghosts.end());
    const GhostImaging& li = imaging[static_cast<std::size_t>(lens_ghost - ghosts.begin())];
    EXPECT_GT(li.blur_mm, 1.0);
    EXPECT_GT(std::abs(li.magnification - 1.0), 0.05);
}
