// What a real iris lets through besides its shape (flare paper section 5): procedural dust and scratches
// by user statistics, or any greyscale image as the aperture. Applied to the pupil's transmission before
// the starburst's Fourier transform: scratches add streaks across their direction, dust rainbow speckle.
#pragma once

#include <cstdint>
#include <vector>

namespace lensfx::optics {

// Procedural dirt on the pupil, in stop radii (the iris's circumscribed radius is 1). Zero counts: clean.
struct PupilImperfections {
    double dust_density = 0.0;         // dust particles per unit area of the pupil (the unit disc holds pi)
    double dust_radius = 0.01;         // mean particle radius; radii spread log-uniformly over x0.5..x2
    double dust_opacity = 1.0;         // 1 = opaque specks
    int scratches = 0;                 // number of scratches
    double scratch_length = 0.5;       // mean length; lengths spread uniformly over x0.5..x1.5
    double scratch_width = 0.004;
    double scratch_angle_deg = 0.0;    // mean direction, counter-clockwise from the x axis
    double scratch_spread_deg = 180.0; // directions spread uniformly over +-spread/2 (180: any)
    double scratch_opacity = 1.0;
    std::uint64_t seed = 1;            // the same seed gives the same dirt on every machine

    bool empty() const { return !(dust_density > 0.0) && scratches <= 0; }
};

// A greyscale transmission image (0 = opaque, 1 = clear) spanning the square [-1, 1]^2 of stop radii,
// row 0 at the top; it replaces the iris shape.
struct ApertureImage {
    int width = 0;
    int height = 0;
    std::vector<float> value;  // width * height

    bool empty() const { return width <= 0 || height <= 0; }
    // Bilinear transmission at stop coordinates (u, v), v up; 0 outside the square.
    double at(double u, double v) const;
};

// Multiplies an m x m transmission grid (centred on sample (m/2, m/2), r samples per stop radius, row 0 at
// the top, v up) by the dirt's transmission, with 4 x 4 supersampling on each particle's footprint.
// Cost grows with the dirt's area on the grid, not with m^2 x particle count.
void apply_imperfections(const PupilImperfections& dirt, int m, int r, double* transmission);

}  // namespace lensfx::optics
