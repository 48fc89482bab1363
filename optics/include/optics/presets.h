// The lens presets of presets/lenses/*.toml, embedded into the binary at build time so that they load
// from any directory; the files in the source tree are the same text.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <optics/lens.h>

namespace lensfx::optics {

std::vector<std::string> preset_names();                         // sorted
std::optional<std::string_view> preset_text(std::string_view name);  // the TOML source, or nullopt
Lens load_preset(std::string_view name);                         // throws LensFileError if unknown

}  // namespace lensfx::optics
