// The check before reading a named file of the optics library (lens files, flare looks).
#pragma once

#include <filesystem>

namespace lensfx::optics {

// Throws LensFileError when `path` exists but is no regular file (a named pipe or /dev/zero would block or
// never end the read).
void require_regular_file(const std::filesystem::path& path);

}  // namespace lensfx::optics
