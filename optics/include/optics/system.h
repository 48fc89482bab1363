// Realisation of a Lens at one zoom and iris setting: the System the tracers and renderers consume
// (vertex positions, media on both sides, stop radius, sensor plane).
#pragma once

#include <optional>
#include <string_view>
#include <vector>

#include <optics/lens.h>

namespace lensfx::optics {

inline constexpr double kLambdaD_nm = 587.56;

// Thickness of every surface at zoom z in [0,1]: piecewise linear across the zoom columns, column k
// at z = k / (columns - 1). Throws std::invalid_argument when z is outside [0,1] or not finite.
std::vector<double> thicknesses_at(const Lens& lens, double zoom);

// The zoom parameter of a focal-length label (Lens::zoom_focal_labels, piecewise linear), e.g. 135 -> 0.5.
double zoom_for_label(const Lens& lens, double focal_label_mm);
// "0.5" (zoom parameter) or "135mm" (label); throws std::invalid_argument naming the lens.
double parse_zoom(const Lens& lens, std::string_view text);

// Lays the lens out: first vertex at z = 0, stop radius set so that the paraxial f-number at 587.56 nm
// equals f_number (nullopt: the stop open to its clear semi-diameter; throws std::invalid_argument when
// f_number asks for more than the clear stop), sensor at the paraxial back focal distance at 587.56 nm
// unless lens.sensor_as_written.
System realize(const Lens& lens, double zoom = 0.0, std::optional<double> f_number = std::nullopt);

// The same system with the stop radius set for a given entrance pupil diameter at `wavelength_nm`.
System with_entrance_pupil_diameter(System system, double epd_mm, double wavelength_nm = kLambdaD_nm);

}  // namespace lensfx::optics
