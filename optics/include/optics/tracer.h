// The exact sequential ray tracer, the project's ground truth: a ray follows a prescribed sequence of
// interfaces (the direct path, or a ghost's path with its reflections) in double precision, with the
// flare paper's fixed-order intersection (section 4.1), Snell refraction, reflection, and per ray the
// largest relative height r_rel, the stop coordinates and the Fresnel/coating transmission product.
// Conventions: docs/DESIGN.md (mm, nm, +z object -> sensor, positive radius = centre towards the sensor).
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include <optics/coating.h>
#include <optics/lens.h>
#include <optics/vec3.h>

namespace lensfx::optics {

struct Ray {
    Vec3 origin;     // mm, lens coordinates (first vertex at z = 0 for a realised System)
    Vec3 direction;  // unit vector
};

// One interface visit of a path.
struct Step {
    int interface = 0;     // index into System::interfaces
    bool reflect = false;  // false: the ray is refracted through (transmitted); true: reflected back
    bool forward = true;   // the ray arrives travelling towards +z (from the object side)
};

// The direct (image-forming) path: every interface once, forward, transmitted.
std::vector<Step> direct_path(const System& system);
// The same visits in reverse order and opposite directions: tracing a ray's reversed outgoing direction
// through it retraces the ray back to where it started.
std::vector<Step> reversed_path(std::span<const Step> path);

// One interface of a System with everything wavelength-dependent evaluated: what the inner loop reads.
struct TraceInterface {
    double z = 0.0;              // vertex position
    double curvature = 0.0;      // 1 / radius, 0 for a plane
    double conic = 0.0;
    std::array<double, 4> aspheric{};  // a4, a6, a8, a10
    bool has_aspheric = false;
    double semi_diameter = 0.0;  // <= 0: no clear-aperture limit (does not contribute to r_rel)
    double n_before = 1.0;       // index on the object side at the wavelength
    double n_after = 1.0;        // index on the sensor side
    bool is_stop = false;
    ResolvedCoating coating;
};

// A System evaluated at one wavelength. Build once per (system, wavelength); trace() with it does not
// allocate, so it can be shared read-only between threads.
class TraceSystem {
public:
    TraceSystem(const System& system, double wavelength_nm);

    double wavelength_nm() const { return wavelength_nm_; }
    const std::vector<TraceInterface>& interfaces() const { return interfaces_; }
    int stop() const { return stop_; }
    double sensor_z() const { return sensor_z_; }
    const std::string& name() const { return name_; }

private:
    std::vector<TraceInterface> interfaces_;
    int stop_ = -1;
    double sensor_z_ = 0.0;
    double wavelength_nm_ = 0.0;
    std::string name_;
};

enum class TraceStatus {
    Ok,               // followed the whole path (r_rel may still exceed 1: the caller clips)
    NoIntersection,   // the line misses the surface's sphere/conic (or the asphere iteration failed)
    TotalInternalReflection,  // at a refracting step
    NonFinite,        // a value overflowed (e.g. a ray parallel to a plane); the outputs are the last finite ones
    BadPath,          // a step names an interface outside the system
};
const char* to_string(TraceStatus status);

// Per-step record, written when the caller passes a span to trace().
struct TraceHit {
    Vec3 position;         // hit point, lens coordinates
    Vec3 direction;        // unit direction after the interaction
    double t = 0.0;        // ray parameter from the previous point (mm; negative = the surface lay behind)
    double cos_incidence = 1.0;  // cos of the angle of incidence (0 = grazing)
    double factor = 1.0;   // R (reflect) or T (transmit) of this interface for this ray
};

struct TraceResult {
    TraceStatus status = TraceStatus::Ok;
    int failed_step = -1;       // index into the path where it failed, -1 when Ok
    int failed_interface = -1;  // System interface index of that step, -1 when Ok
    // Ok: on the sensor plane (or at the last interface when TraceOptions::to_sensor is false) with the
    // final direction. Failed: the last point and direction that were computed (always finite).
    Vec3 position;
    Vec3 direction;
    // max over the path's non-stop interface hits of r / semi_diameter (r = distance from the axis),
    // recorded even above 1 so that renderers can interpolate and clip; stops are left to stop_uv.
    double r_rel = 0.0;
    // Where the ray crosses the stop plane, divided by the stop radius (|uv| <= 1: inside a round iris),
    // at the crossing with the largest |uv| (the one that limits it), in lens x/y. A ghost may cross the
    // stop up to three times: all crossings are in stop_crossings[0 .. stop_count).
    Vec2 stop_uv;
    std::array<Vec2, 3> stop_crossings{};
    int stop_count = 0;
    double transmission = 0.0;   // product of the R/T factors along the path (0 when failed)
    double optical_path_mm = 0.0;  // sum of n * ray parameter, origin to the final position (signed: a
                                   // negative ray parameter, see virtual_path, subtracts)
    bool virtual_path = false;   // some step needed a negative ray parameter (the paper's extension)

    bool ok() const { return status == TraceStatus::Ok; }
};

struct TraceOptions {
    bool to_sensor = true;   // after the last step, propagate to the sensor plane
};

// Traces `ray` (in the medium before path[0]) along `path` at the TraceSystem's wavelength. Intersections
// follow the path order whatever the ray parameter's sign; the sphere/conic root is chosen by the
// step's travel direction (the cap through the vertex for paraxial rays, continuous for all others).
// hits, when non-empty, must hold path.size() entries and receives one record per completed step.
// Never throws for bad rays; no output is ever NaN or Inf.
TraceResult trace(const TraceSystem& system, const Ray& ray, std::span<const Step> path,
                  const TraceOptions& options = {}, std::span<TraceHit> hits = {});

// Convenience for one-off rays (builds a TraceSystem: allocates).
TraceResult trace(const System& system, const Ray& ray, double wavelength_nm, std::span<const Step> path,
                  const TraceOptions& options = {});

// Surface sag z(h) of an interface at radial distance h from the axis (relative to its vertex), and
// whether h is inside the surface's domain (a conic beyond its rim has no sag).
bool surface_sag(const TraceInterface& surface, double h, double& sag);

// A meridional ray for `lensfx lens trace`: from infinity at field angle angle_deg (direction
// (0, -sin A, cos A), a light above the axis for A > 0), crossing the first vertex's tangent plane at
// height height_mm, traced along the direct path.
struct MeridionalSurface {
    int surface = 0;       // 1-based, the stop counted as a surface
    Vec3 local;            // hit point relative to the surface vertex (z = sag)
    Vec3 direction;        // direction cosines after the surface
    double path_mm = 0.0;  // geometric distance from the previous hit (surface 1: from the tangent plane point)
};
struct MeridionalTrace {
    std::vector<MeridionalSurface> surfaces;  // the surfaces reached (all of them when result.ok())
    TraceResult result;                       // final state; position on the sensor plane when ok
    double sensor_path_mm = 0.0;              // last surface -> sensor plane distance
};
MeridionalTrace trace_meridional(const System& system, double height_mm, double angle_deg,
                                 double wavelength_nm);

// Ray from a distant light at field angles (ax, ay) in degrees (DESIGN.md: direction along
// (-tan ax, -tan ay, 1), normalised) through the point (x, y) of the plane z = z_plane.
Ray collimated_ray(double ax_deg, double ay_deg, double x, double y, double z_plane);

}  // namespace lensfx::optics
