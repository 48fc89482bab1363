// Reading a named file of the optics library (lens files, flare looks): the check before, and the read.
#pragma once

#include <filesystem>
#include <string>

namespace lensfx::optics {

// Throws LensFileError when `path` exists but is no regular file (a named pipe or /dev/zero would block or
// never end the read).
void require_regular_file(const std::filesystem::path& path);
// The whole file as text; throws LensFileError naming the file when it cannot be opened or read.
std::string read_text(const std::filesystem::path& path);

}  // namespace lensfx::optics
