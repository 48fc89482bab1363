// Importers for foreign lens tables: pbrt-v4 RealisticCamera `.dat` and lentil / polynomial-optics `.fx`
// (formats documented in ../shared/reference/lenses/README.md). Both give a Lens in the project's terms.
#pragma once

#include <filesystem>
#include <string_view>

#include <optics/lens.h>

namespace lensfx::optics {

// pbrt `.dat`: radius, thickness, eta, aperture DIAMETER per row; radius 0 = stop, eta 0 = air.
// The last row's thickness (0 in pbrt's files) becomes the paraxial back focal distance at 587.56 nm.
// Media are constant-index glasses (the format has no dispersion).
Lens parse_pbrt_dat(std::string_view text, std::string_view origin);
// lentil `.fx`: `#!scale`, zoom `a/b/c` thicknesses, `iris` rows, nd/Vd media (glass_from_abbe), even
// aspheres (`#!aspheric=k,A4,A6,A8,A10`). Cylindrical `cx_` rows are rejected (not supported).
// Large flat radii (|r| >= 1e4) are read as planes. The `#EFL` comment fills stated_focal_mm.
Lens parse_lentil_fx(std::string_view text, std::string_view origin);

Lens read_pbrt_dat(const std::filesystem::path& path);
Lens read_lentil_fx(const std::filesystem::path& path);

}  // namespace lensfx::optics
