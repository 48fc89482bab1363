// The lens as data: a sequential prescription of spherical (optionally aspheric) surfaces, their media,
// coatings, the aperture stop and the iris shape. Plain value types; parsing lives in lens_file.h,
// physics in the other optics headers. Conventions: ../docs/DESIGN.md (mm, nm, +z object -> sensor).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <optics/glass.h>

namespace lensfx::optics {

// Anti-reflection coating on one interface.
struct Coating {
    enum class Kind { None, QuarterWave, Stack, Design };
    // Standard thin-film designs (optics/coating.h says what each is), laid on the glass side of an
    // air-glass interface, made for the design wavelength and the glass they sit on.
    enum class Design { VCoat, QuarterHalfQuarter, Broadband4 };
    struct Layer {
        Glass material;       // layer medium
        double thickness_nm;  // physical thickness
    };
    Kind kind = Kind::None;
    // QuarterWave: a single layer of index `layer_index` whose optical thickness is a quarter of
    // `design_wavelength_nm`, scaled by (1 + thickness_offset) (the Stingray notes' offset).
    double design_wavelength_nm = 550.0;
    double layer_index = 1.38;  // MgF2
    double thickness_offset = 0.0;
    // Stack: layers listed from the incident (object) side.
    std::vector<Layer> layers;
    Design design = Design::Broadband4;  // Design: which, at design_wavelength_nm
    // Relative thickness error of each layer (in the order the layers are listed; missing ones 0): real
    // layers are never exactly at their design thickness (optics::choose_coatings spreads them).
    std::vector<double> layer_errors;
};

struct Surface {
    double radius_mm = 0.0;              // signed; 0 = plane. Positive: centre of curvature towards the sensor
    std::vector<double> thickness_mm;    // axial distance to the next surface (last: to the sensor); one per zoom position
    Glass medium = Glass::air();         // medium after this surface
    double semi_diameter_mm = 0.0;       // clear semi-aperture
    Coating coating;
    bool is_stop = false;                // the aperture stop (a plane, medium continues)
    // Even asphere: z = c h^2 / (1 + sqrt(1 - (1+k) c^2 h^2)) + a4 h^4 + a6 h^6 + a8 h^8 + a10 h^10.
    double conic = 0.0;
    std::vector<double> aspheric;        // a4, a6, a8, a10 (empty = spherical)
    int source_line = 0;                 // line in the file it came from, for error messages (0 = unknown)
};

// Iris shape, stated in the upright photograph frame (DESIGN.md).
struct Aperture {
    int blades = 0;                 // 0 = round
    double rotation_deg = 0.0;      // rotation of the first blade edge, counter-clockwise
    double blade_curvature = 0.0;   // 0 = straight blades, 1 = circular arcs of the stop radius
};

struct Lens {
    std::string name;
    std::string source;                       // patent number and example, book and page
    std::vector<double> stated_focal_mm;      // one per zoom position (may be empty)
    double stated_f_number = 0.0;             // 0 = not stated
    std::vector<double> zoom_focal_labels;    // optional labels of the zoom positions (e.g. 70, 135, 200)
    std::vector<Surface> surfaces;            // object side first; the stop is one of them
    Aperture aperture;
    std::string notes;
    // false: realize() puts the sensor at the paraxial back focal distance (infinity focus, 587.56 nm);
    // true: at the last surface's thickness as written.
    bool sensor_as_written = false;

    int zoom_positions() const;               // number of thickness columns (1 for a prime)
    int stop_index() const;                   // index of the stop surface, -1 if none
};

// A lens at one zoom and iris setting, laid out along the axis: what the tracers and renderers consume.
struct System {
    struct Interface {
        double radius_mm;         // 0 = plane
        double z_mm;              // vertex position along +z, first surface at 0
        double semi_diameter_mm;  // for the stop: the current stop radius set by the f-number
        Glass before;             // medium on the object side
        Glass after;              // medium on the sensor side
        Coating coating;
        bool is_stop;
        double conic;
        std::vector<double> aspheric;
    };
    std::vector<Interface> interfaces;  // object side first, the stop included
    int stop = -1;                      // index into interfaces
    double sensor_z_mm = 0.0;           // sensor plane position
    Aperture aperture;
    std::string name;
};

}  // namespace lensfx::optics
