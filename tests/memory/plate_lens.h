// A lens of many surfaces for the memory tests and bench/memory: flat N-BK7 plates (two surfaces each) in
// front of the Cooke triplet of presets/ (7 surfaces). Its ghosts grow with the square of the surfaces.
#pragma once

#include <string>

namespace lensfx::test {

// The lens file's text (docs/lens-format.md) for about `surfaces` surfaces (7 + 2k).
inline std::string plate_lens_toml(int surfaces) {
    std::string rows;
    for (int k = 0; k < (surfaces - 7) / 2; ++k)
        rows += "  { r = 0, t = 1, sd = 12, glass = \"schott:N-BK7\" },\n  { r = 0, t = 1, sd = 12 },\n";
    return "name = \"plates and a triplet\"\nsource = \"lensfx memory tests\"\nsurfaces = [\n" + rows +
           "  { r = 22.01359, t = 3.25896, sd = 9.5, glass = \"hikari:SK16\" },\n"
           "  { r = -435.76044, t = 6.00755, sd = 8 },\n"
           "  { r = -22.21328, t = 0.99997, sd = 4.5, glass = \"schott:F2\" },\n"
           "  { r = 20.29192, t = 0, sd = 4 },\n"
           "  { stop = true, t = 4.75041, sd = 3.805 },\n"
           "  { r = 79.6836, t = 2.95208, sd = 6.5, glass = \"hikari:SK16\" },\n"
           "  { r = -18.39533, t = 42.20778, sd = 7.5 },\n]\n";
}

}  // namespace lensfx::test
