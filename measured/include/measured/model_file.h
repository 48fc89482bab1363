// Measured lens presets as TOML (kind = "measured"; docs/measured-lenses.md): read, written and validated
// like the other lens files, errors naming the file, line and field.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include <measured/model.h>

namespace lensfx::measured {

// Whether a lens argument names a measured preset: a file whose TOML has kind = "measured".
bool is_measured_file(std::string_view name_or_path);

// Parses a measured preset; `origin` prefixes errors (optics::LensFileError "model.toml:12: ghost 2: left: ...").
MeasuredLens parse_measured_toml(std::string_view text, std::string_view origin);
MeasuredLens read_measured(const std::filesystem::path& path);
// The file's text; parse_measured_toml(write_measured_toml(m)) reproduces m.
std::string write_measured_toml(const MeasuredLens& lens);

// Finite values in range: focal length and sensor > 0, capture figures > 0, each ghost's angle range within
// 0..89 degrees, coefficients finite and under 1e6. Throws optics::LensFileError naming origin and field.
void validate_measured(const MeasuredLens& lens, std::string_view origin);

}  // namespace lensfx::measured
