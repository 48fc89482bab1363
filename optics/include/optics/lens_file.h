// Lens prescriptions as files: the project's own TOML format (docs/lens-format.md), a writer that
// round-trips it, and load_lens(), which every command taking a lens calls (preset name or file path).
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

#include <optics/lens.h>

namespace lensfx::optics {

// A lens file that cannot be read; what() names the file, line and field ("canon.toml:12: surface 3: t: ...").
class LensFileError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Parses the project's TOML lens format; `origin` (a path or "preset:NAME") prefixes error messages.
Lens parse_lens_toml(std::string_view text, std::string_view origin);
Lens read_lens_toml(const std::filesystem::path& path);

// Writes the project's format; parse_lens_toml(write_lens_toml(l)) reproduces l (source_line aside).
std::string write_lens_toml(const Lens& lens);
void write_lens_file(const Lens& lens, const std::filesystem::path& path);

// Checks what every consumer relies on (one stop, finite values, semi-diameters > 0, one thickness per
// zoom position...); throws LensFileError naming `origin`, the line and the field.
void validate_lens(const Lens& lens, std::string_view origin);

enum class LensFormat { Toml, PbrtDat, LentilFx };
// By extension (.toml/.lens, .dat, .fx), else by content.
LensFormat detect_lens_format(const std::filesystem::path& path, std::string_view text);

// A preset name ("canon-70-200"), or a path to a file in any supported format.
Lens load_lens(std::string_view name_or_path);

}  // namespace lensfx::optics
