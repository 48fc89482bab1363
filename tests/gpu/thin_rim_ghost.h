// The ghost of pbrt's double Gauss whose rim is a thin bright line (pbrt-dgauss-50, surfaces 5 and 7 lit from
// (-5.5, 0.1) degrees: the large ghost of CandleGlass.exr's flame), at CandleGlass's 1000 x 810 and 550 nm. The
// default grid's cells crowd into slivers and sub-pixel triangles along its rim: the renderer tests of small
// triangles draw it.
#pragma once

#include <flare/flare.h>

namespace lensfx::gpu::test {

inline constexpr const char* kThinRimLens = "pbrt-dgauss-50";

inline flare::FlareView thin_rim_view() {
    flare::FlareView view;
    view.angle_x_deg = -5.5;
    view.angle_y_deg = 0.1;
    view.width = 1000;
    view.height = 810;
    view.sensor_height_mm = 36.0 * 810 / 1000;
    view.wavelength_nm = 550.0;
    view.only_ghosts = {{6, 4}};
    return view;
}

}  // namespace lensfx::gpu::test
