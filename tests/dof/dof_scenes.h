// Small synthetic scenes and measurements shared by the lens-blur tests.
#pragma once
#include <cmath>
#include <vector>

#include <dof/layers.h>
#include <dof/lens_rays.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/system.h>

namespace lensfx::dof::test {

// The thin-lens blur diameter on the sensor (mm): A f |z - zf| / (z (zf - f)), z and zf in mm.
inline double thin_lens_blur_mm(const optics::System& system, double z_m, double zf_m) {
    const optics::Paraxial p = optics::paraxial(system);
    const double z = z_m * 1000.0, zf = zf_m * 1000.0, f = p.efl_mm, a = p.entrance_pupil_diameter_mm;
    return a * f * std::abs(z - zf) / (z * (zf - f));
}

// A camera over a size x size raster whose pitch makes `blur_px` pixels of the thin-lens blur.
inline Camera camera_for(const char* lens, double fstop, double focus_m, double z_m, int size, double blur_px) {
    Camera c;
    c.system = optics::realize(optics::load_lens(lens), 0.0, fstop);
    c.focus_m = focus_m;
    c.width = c.height = size;
    c.centre_x = c.centre_y = 0.5 * size;
    c.sensor_width_mm = size * thin_lens_blur_mm(c.system, z_m, focus_m) / blur_px;
    return c;
}

// A plane at depth z_m, black but for one pixel of value `level` at (px, py).
inline LayerStack point_scene(int size, double z_m, int px, int py, float level) {
    std::vector<float> rgb(3 * static_cast<std::size_t>(size) * static_cast<std::size_t>(size), 0.0f);
    std::vector<float> depth(static_cast<std::size_t>(size) * static_cast<std::size_t>(size), static_cast<float>(z_m));
    for (int c = 0; c < 3; ++c) rgb[3 * (static_cast<std::size_t>(py) * static_cast<std::size_t>(size) + static_cast<std::size_t>(px)) + static_cast<std::size_t>(c)] = level;
    return layers_from_flat(rgb.data(), depth.data(), size, size);
}

// Left half: a black surface at 1 m; behind it all over, a plane of 100 at 10 m (flat, with Z).
inline LayerStack edge_scene(int size) {
    const std::size_t n = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
    std::vector<float> rgb(3 * n, 100.0f), depth(n, 10.0f);
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size / 2; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(size) + static_cast<std::size_t>(x);
            depth[i] = 1.0f;
            for (std::size_t c = 0; c < 3; ++c) rgb[3 * i + c] = 0.0f;
        }
    return layers_from_flat(rgb.data(), depth.data(), size, size);
}

// A premultiplied white square (alpha 1) over [lo, hi)^2 at z_m over nothing (alpha 0, no depth: at
// infinity), as a rendered foreground element comes (flat RGBA with Z).
inline LayerStack alpha_square_scene(int size, int lo, int hi, double z_m) {
    const std::size_t n = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
    std::vector<float> rgb(3 * n, 0.0f), depth(n, 0.0f), alpha(n, 0.0f);
    for (int y = lo; y < hi; ++y)
        for (int x = lo; x < hi; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(size) + static_cast<std::size_t>(x);
            depth[i] = static_cast<float>(z_m), alpha[i] = 1.0f;
            for (std::size_t c = 0; c < 3; ++c) rgb[3 * i + c] = 1.0f;
        }
    return layers_from_flat(rgb.data(), depth.data(), size, size, {}, alpha.data());
}

// Sum, centroid and second moment of channel c of an RGB raster.
struct Moments {
    double sum = 0, cx = 0, cy = 0, r2 = 0;
};
inline Moments moments(const std::vector<float>& rgb, int w, int h, int c) {
    Moments m;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double v = rgb[3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) + static_cast<std::size_t>(c)];
            m.sum += v, m.cx += v * (x + 0.5), m.cy += v * (y + 0.5);
        }
    m.cx /= m.sum, m.cy /= m.sum;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double v = rgb[3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) + static_cast<std::size_t>(c)];
            m.r2 += v * ((x + 0.5 - m.cx) * (x + 0.5 - m.cx) + (y + 0.5 - m.cy) * (y + 0.5 - m.cy));
        }
    m.r2 /= m.sum;
    return m;
}

// Diameter of a uniform disc with this second moment, less the blurred pixel's own (1/6 px^2).
inline double disc_diameter(const Moments& m) { return std::sqrt(8.0 * (m.r2 - 1.0 / 6.0)); }

}  // namespace lensfx::dof::test
