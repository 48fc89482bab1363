// OCIO building blocks shared by the built-in config, the config wrapper and the pipeline (internal to
// filter/src/colour/).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <filter/colour/config.h>
#include <filter/colour/matrix.h>

namespace lensfx::colour {

// The built-in config: ACES 1.x output transforms from OCIO's built-in transforms.
OCIO::ConstConfigRcPtr make_builtin_config();

// Names as a list for error messages ("(none)" when empty).
std::string join(const std::vector<std::string>& names);

OCIO::TransformRcPtr matrix_transform(const Mat3& m);

// A scene-linear RGB space -> ACES2065-1 (the built-in config's scene reference): RGB -> XYZ, Bradford
// to D65 when its white differs, then OCIO's AP0 <- XYZ-D65.
OCIO::TransformRcPtr rgb_to_aces_reference(const Chromaticities& c);

// A scene-linear colour space of the built-in config's kind.
OCIO::ColorSpaceRcPtr scene_space(std::string_view name, std::string_view family, std::string_view description,
                                  OCIO::ConstTransformRcPtr to_reference);

// The 3x3 matrix of `space` -> ACES2065-1 when the config can convert to ACES (aces_interchange role) and
// the conversion is linear (checked on test vectors); nullopt otherwise.
std::optional<Mat3> measure_to_ap0(const OCIO::ConstConfigRcPtr& config, const std::string& space);

// ACES2065-1 -> XYZ, Bradford-adapted to D65 (as OCIO's built-in transforms measure it).
Mat3 ap0_to_xyz_d65_matrix();

}  // namespace lensfx::colour
