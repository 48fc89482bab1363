// First-order (paraxial, y-nu) analysis of a realised System at any wavelength: focal lengths, focal
// distances, pupils and f-number. Positions follow DESIGN.md: along +z, the entrance pupil and the front
// focal point from the first vertex, the exit pupil and the back focal point from the last vertex.
#pragma once

#include <optics/lens.h>
#include <optics/system.h>

namespace lensfx::optics {

struct Paraxial {
    double wavelength_nm = kLambdaD_nm;
    double efl_mm = 0.0;                   // 1 / power (object and image space in air)
    double bfl_mm = 0.0;                   // last vertex -> back focal point
    double ffl_mm = 0.0;                   // first vertex -> front focal point (negative: in front)
    double entrance_pupil_mm = 0.0;        // first vertex -> entrance pupil
    double entrance_pupil_diameter_mm = 0.0;
    double exit_pupil_mm = 0.0;            // last vertex -> exit pupil
    double exit_pupil_diameter_mm = 0.0;
    double f_number = 0.0;                 // efl / entrance pupil diameter (infinite conjugate)
};

// Throws std::invalid_argument when the system has no stop or no optical power (afocal).
Paraxial paraxial(const System& system, double wavelength_nm = kLambdaD_nm);

// The stop radius that gives an entrance pupil diameter of epd_mm.
double stop_radius_for_epd(const System& system, double epd_mm, double wavelength_nm = kLambdaD_nm);

// Full field of view in degrees of a rectilinear (paraxial) mapping on a sensor of width x height mm.
struct FieldOfView {
    double horizontal_deg, vertical_deg, diagonal_deg;
};
FieldOfView field_of_view(const Paraxial& p, double sensor_width_mm = 36.0, double sensor_height_mm = 24.0);

}  // namespace lensfx::optics
