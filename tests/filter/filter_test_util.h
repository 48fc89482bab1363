// Helpers of the filter's end-to-end tests: run the lensfx program, compare two image files exactly.
#pragma once

#include <filesystem>
#include <string>

namespace lensfx::test {

struct RunResult {
    int exit_code = -1;
    std::string stderr_text;
};

// Runs a shell command line (bash), capturing stderr.
RunResult run(const std::string& command);
// The lensfx binary, quoted for the shell.
std::string lensfx_cmd();
// A fresh empty directory under the system temp directory, unique to this process and name.
std::filesystem::path scratch_dir(const std::string& name);
// "" when the two files hold the same first part at mip level 0: channel names, types and order, data and
// display windows, pixels byte for byte, and every attribute of `expected` (the output may add DateTime);
// else what differs.
std::string compare_images(const std::string& expected, const std::string& actual, bool check_attributes = true);
// Regular files in a directory, hidden ones included.
std::size_t file_count(const std::filesystem::path& dir);

}  // namespace lensfx::test
