// Test systems for the physics suites, built by hand from the numbers in issue 3 (the CODE V double Gauss
// of Modern Lens Design and a Cooke triplet), independent of the lens-file code. Semi-diameters are set
// from real rays (axial marginal and full-field rim rays) with a 5% margin.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <optics/glass.h>
#include <optics/lens.h>
#include <optics/tracer.h>

namespace lensfx::optics::testing {

struct SurfaceSpec {
    double radius;       // 0 = plane
    double thickness;    // to the next surface (last: to the sensor)
    const char* glass;   // medium after, "" = air
    bool stop = false;
};

inline Glass medium(const char* name) {
    if (name[0] == '\0') return Glass::air();
    auto g = catalog_glass(name);
    if (!g) throw std::runtime_error(std::string("test glass not in catalog: ") + name);
    return *g;
}

// Lays out the surfaces, sets the stop radius from the axial marginal ray of the given entrance pupil
// diameter and every other semi-diameter from rays of that pupil at 0 and +-field_deg.
inline System build_system(const std::string& name, const std::vector<SurfaceSpec>& specs, double epd,
                           double field_deg, double wavelength_nm = 587.56) {
    System sys;
    sys.name = name;
    double z = 0.0;
    Glass before = Glass::air();
    for (std::size_t i = 0; i < specs.size(); ++i) {
        System::Interface in{};
        in.radius_mm = specs[i].radius;
        in.z_mm = z;
        in.before = before;
        in.after = medium(specs[i].glass);
        in.is_stop = specs[i].stop;
        if (specs[i].stop) sys.stop = static_cast<int>(i);
        before = in.after;
        sys.interfaces.push_back(in);
        z += specs[i].thickness;
    }
    sys.sensor_z_mm = z;
    const TraceSystem ts(sys, wavelength_nm);
    const auto path = direct_path(sys);
    std::vector<TraceHit> hits(path.size());
    std::vector<double> semi(path.size(), 0.0);
    // The axial marginal ray sets the stop.
    trace(ts, Ray{{0.0, epd / 2, -1.0}, {0.0, 0.0, 1.0}}, path, {}, hits);
    sys.interfaces[static_cast<std::size_t>(sys.stop)].semi_diameter_mm = std::abs(hits[static_cast<std::size_t>(sys.stop)].position.y);
    for (double field : {0.0, field_deg, -field_deg}) {
        for (double y : {-epd / 2, 0.0, epd / 2}) {
            // Aim at the entrance pupil height y: close enough for semi-diameters.
            const Ray ray = collimated_ray(0.0, field, 0.0, y, 0.0);
            const TraceResult r = trace(ts, ray, path, {}, hits);
            if (!r.ok()) continue;
            for (std::size_t k = 0; k < path.size(); ++k)
                semi[k] = std::max(semi[k], std::hypot(hits[k].position.x, hits[k].position.y));
        }
    }
    for (std::size_t k = 0; k < path.size(); ++k)
        if (!sys.interfaces[k].is_stop) sys.interfaces[k].semi_diameter_mm = 1.05 * semi[k];
    return sys;
}

// Issue 3: the double Gauss of Modern Lens Design as traced by CODE V (EPD 50, EFL 100.0038 at 587.6 nm).
inline std::vector<SurfaceSpec> double_gauss_specs() {
    return {{56.20238, 8.75, "N-SSK2"}, {152.28580, 0.5, ""},      {37.68262, 12.5, "N-SK2"},
            {0.0, 3.8, "F5"},          {24.23130, 16.369445, ""}, {0.0, 13.747957, "", true},
            {-28.37731, 3.8, "F5"},    {0.0, 11.0, "N-SK16"},     {-37.92546, 0.5, ""},
            {177.41176, 7.0, "N-SK16"}, {-79.41143, 61.487536, ""}};
}
inline System double_gauss() { return build_system("double Gauss (MLD)", double_gauss_specs(), 50.0, 14.0); }

// Issue 3: a Cooke triplet (EPD 10, EFL 49.99978 at 550 nm; SK16 Hikari's, F2 Schott's). The issue marks the
// stop after surface 4; here it is a plane in that air gap, 2 mm behind surface 4.
inline std::vector<SurfaceSpec> cooke_specs() {
    return {{22.01359, 3.25896, "hikari:SK16"}, {-435.76044, 6.00755, ""}, {-22.21328, 0.99997, "schott:F2"},
            {20.29192, 2.0, ""},               {0.0, 2.75041, "", true},  {79.68360, 2.95208, "hikari:SK16"},
            {-18.39533, 42.20778, ""}};
}
inline System cooke_triplet() { return build_system("Cooke triplet", cooke_specs(), 10.0, 20.0, 550.0); }

}  // namespace lensfx::optics::testing
