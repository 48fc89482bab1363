// Colour maths: 3x3 matrices, primaries, RGB -> XYZ, Bradford adaptation (filter/colour/matrix.h).
#include <filter/colour/matrix.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/core.h>

namespace lensfx::colour {

namespace {

std::array<double, 3> xy_to_xyz(double x, double y) { return {x / y, 1.0, (1.0 - x - y) / y}; }

// The chromaticities in the attribute's order, in double.
std::array<double, 8> as_array(const Chromaticities& c) { return {c.rx, c.ry, c.gx, c.gy, c.bx, c.by, c.wx, c.wy}; }

}  // namespace

Chromaticities widened(const std::array<float, 8>& c) {
    const auto d = [&](std::size_t i) { return static_cast<double>(c[i]); };
    return {d(0), d(1), d(2), d(3), d(4), d(5), d(6), d(7)};
}

std::array<float, 8> packed(const Chromaticities& c) {
    std::array<float, 8> out{};
    const auto d = as_array(c);
    for (std::size_t i = 0; i < 8; ++i) out[i] = static_cast<float>(d[i]);
    return out;
}

std::string describe(const std::array<float, 8>& c) {
    return fmt::format("r ({}, {}) g ({}, {}) b ({}, {}) w ({}, {})", c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]);
}

Chromaticities chromaticities(KnownPrimaries p) {
    switch (p) {
        case KnownPrimaries::Rec709: return {0.64, 0.33, 0.30, 0.60, 0.15, 0.06, d65_x, d65_y};
        case KnownPrimaries::AcesAP0: return {0.7347, 0.2653, 0.0, 1.0, 0.0001, -0.0770, 0.32168, 0.33767};
        case KnownPrimaries::AcesAP1: return {0.713, 0.293, 0.165, 0.830, 0.128, 0.044, 0.32168, 0.33767};
        case KnownPrimaries::Rec2020: return {0.708, 0.292, 0.170, 0.797, 0.131, 0.046, d65_x, d65_y};
        case KnownPrimaries::P3D65: return {0.680, 0.320, 0.265, 0.690, 0.150, 0.060, d65_x, d65_y};
    }
    throw std::invalid_argument("colour: unknown primaries");
}

std::string_view name(KnownPrimaries p) {
    switch (p) {
        case KnownPrimaries::Rec709: return "Rec.709";
        case KnownPrimaries::AcesAP0: return "ACES AP0";
        case KnownPrimaries::AcesAP1: return "ACES AP1";
        case KnownPrimaries::Rec2020: return "Rec.2020";
        case KnownPrimaries::P3D65: return "P3-D65";
    }
    return "?";
}

std::optional<KnownPrimaries> identify_primaries(const std::array<float, 8>& c, double tolerance) {
    for (auto p : {KnownPrimaries::Rec709, KnownPrimaries::AcesAP0, KnownPrimaries::AcesAP1,
                   KnownPrimaries::Rec2020, KnownPrimaries::P3D65}) {
        const std::array<double, 8> ref = as_array(chromaticities(p));
        bool match = true;
        for (std::size_t i = 0; i < 8 && match; ++i)
            match = std::abs(static_cast<double>(c[i]) - ref[i]) <= tolerance;
        if (match) return p;
    }
    return std::nullopt;
}

Mat3 rgb_to_xyz(const Chromaticities& c) {
    if (!(std::abs(c.wy) > 1e-9))
        throw std::invalid_argument(fmt::format("colour: white point with y = 0 (x {}, y {})", c.wx, c.wy));
    auto col = [](double x, double y) { return std::array<double, 3>{x, y, 1.0 - x - y}; };
    const auto r = col(c.rx, c.ry), g = col(c.gx, c.gy), b = col(c.bx, c.by);
    const Mat3 p{r[0], g[0], b[0], r[1], g[1], b[1], r[2], g[2], b[2]};
    const auto s = apply_matrix(inverse(p), xy_to_xyz(c.wx, c.wy));
    return {p[0] * s[0], p[1] * s[1], p[2] * s[2], p[3] * s[0], p[4] * s[1],
            p[5] * s[2], p[6] * s[0], p[7] * s[1], p[8] * s[2]};
}

Mat3 bradford(double src_wx, double src_wy, double dst_wx, double dst_wy) {
    const Mat3 m{0.8951, 0.2664, -0.1614, -0.7502, 1.7135, 0.0367, 0.0389, -0.0685, 1.0296};
    const auto s = apply_matrix(m, xy_to_xyz(src_wx, src_wy));
    const auto d = apply_matrix(m, xy_to_xyz(dst_wx, dst_wy));
    const Mat3 scale{d[0] / s[0], 0, 0, 0, d[1] / s[1], 0, 0, 0, d[2] / s[2]};
    return multiply(inverse(m), multiply(scale, m));
}

std::array<double, 3> wavelength_to_rgb(double wavelength_nm, const Mat3& rgb_to_xyz_matrix) {
    return apply_matrix(inverse(rgb_to_xyz_matrix), cie1931_xyz(wavelength_nm));
}

Chromaticities primaries_of(const Mat3& m) {
    auto xy = [](double x, double y, double z) {
        const double s = x + y + z;
        return std::array<double, 2>{x / s, y / s};
    };
    const auto r = xy(m[0], m[3], m[6]), g = xy(m[1], m[4], m[7]), b = xy(m[2], m[5], m[8]);
    const auto w = xy(m[0] + m[1] + m[2], m[3] + m[4] + m[5], m[6] + m[7] + m[8]);
    return {r[0], r[1], g[0], g[1], b[0], b[1], w[0], w[1]};
}

}  // namespace lensfx::colour
