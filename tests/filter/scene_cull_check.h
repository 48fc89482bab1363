// Scene culling's error on a real frame (issue 17's bound), shared by the scene-culling tests: the program run
// with and without culling, compared in 8-bit sRGB codes.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace lensfx::test {

// `source` resized to width x height, written as `dir`/resized.exr (GoogleTest failure if it cannot be); its path.
std::filesystem::path resized_frame(const std::filesystem::path& source, int width, int height, const std::filesystem::path& dir);

// `input` through `lens` at each gain, with and without scene culling (sharing one cache folder): something
// culled, and the 8-bit sRGB view moved by at most 1 code at 99.9% of values and 4 anywhere (GoogleTest
// expectations).
void expect_within_a_code_of_drawing_every_ghost(const std::filesystem::path& input, const std::string& lens,
                                                 const std::vector<std::string>& gains);

}  // namespace lensfx::test
