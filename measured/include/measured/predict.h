// Flare occurrence estimators (Walch et al. 2018, section 3.5) over a flare image: peak, total power,
// the log-average glare indicator against a scene, and the change of contrast; rated over a sweep.
#pragma once

#include <vector>

namespace lensfx::measured {

struct FlareEstimate {
    double angle_deg = 0.0;
    double peak = 0.0;      // the brightest pixel's luminance (sensor irradiance)
    double total = 0.0;     // luminance power: sum x pixel area (mm^2 per unit light)
    double glare = 0.0;     // log-average of (scene + flare) over log-average of the scene, minus 1
    double contrast = 0.0;  // 1 - (max - min) / (max + min) of scene + flare over that of the scene alone
};

// The estimators of one flare image (R, G, B floats) over a scene of luminance `scene` per pixel (flat
// grey when `scene` holds one value). `pixel_area_mm2`: for the total.
FlareEstimate estimate(const std::vector<float>& flare_rgb, int width, int height, const std::vector<float>& scene, double pixel_area_mm2);

// Each estimate's value rated against the sweep: 0 at the smallest of the range, 1 at the largest.
std::vector<double> rated(const std::vector<double>& values);

}  // namespace lensfx::measured
