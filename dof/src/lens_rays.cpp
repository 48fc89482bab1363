// Lens rays through the prescription (see lens_rays.h).
#include <dof/lens_rays.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <thread>

#include <fmt/core.h>
#include <optics/aperture.h>
#include <optics/paraxial.h>
#include <optics/system.h>
#include <optics/tracer.h>

namespace lensfx::dof {

std::array<double, 2> r2(int i) {
    constexpr double g = 1.32471795724474602596;  // the plastic number
    const double u = std::fmod(0.5 + i / g, 1.0), v = std::fmod(0.5 + i / (g * g), 1.0);
    return {u, v};
}

Focus focus_of(const optics::System& system, double focus_m) {
    const optics::Paraxial p = optics::paraxial(system);
    Focus f;
    f.efl_mm = p.efl_mm;
    f.entrance_pupil_z_mm = p.entrance_pupil_mm;
    f.entrance_pupil_diameter_mm = p.entrance_pupil_diameter_mm;
    const double d_mm = focus_m * 1000.0;
    if (!(d_mm > 1.05 * p.efl_mm)) throw std::invalid_argument(fmt::format("focus {} m is inside the lens's focal length ({:.1f} mm)", focus_m, p.efl_mm));
    // A near-axial ray from the focused object point; the image lies where it crosses the axis.
    const double z_obj = p.entrance_pupil_mm - d_mm;
    const double slope = 0.01 * 0.5 * p.entrance_pupil_diameter_mm / d_mm;
    optics::Ray ray{{0.0, 0.0, z_obj}, optics::normalize(optics::Vec3{0.0, slope, 1.0})};
    optics::TraceOptions options;
    options.to_sensor = false;
    const optics::TraceResult r = optics::trace(system, ray, optics::kLambdaD_nm, optics::direct_path(system), options);
    if (!r.ok() || std::abs(r.direction.y) < 1e-15) throw std::invalid_argument(fmt::format("focus {} m: the axial ray fails", focus_m));
    f.sensor_z_mm = r.position.z - r.position.y * r.direction.z / r.direction.y;
    return f;
}

namespace {

struct Setup {
    const Camera& camera;
    Focus focus;
    double exit_pupil_z = 0.0, exit_pupil_r = 0.0;
    std::vector<optics::Step> back_path;
    std::vector<optics::TraceSystem> systems;  // per band
    optics::IrisSdf iris;
};

// The sensor point (lens coordinates) under raster position (px, py): the photograph is the sensor image
// turned 180 degrees; a tilted sensor leaves the plane z = sensor_z.
optics::Vec3 sensor_point(const Setup& s, double px, double py) {
    const double pitch = s.camera.pitch_mm();
    const double x = -(px - s.camera.centre_x) * pitch, y = -(s.camera.centre_y - py) * pitch;
    const double pi = std::acos(-1.0);
    const double focused = s.camera.focus_points.empty() ? s.focus.sensor_z_mm : focus_of(s.camera.system, focus_at(s.camera, px, py)).sensor_z_mm;
    const double z = focused + x * std::tan(s.camera.tilt_y_deg * pi / 180.0) + y * std::tan(s.camera.tilt_x_deg * pi / 180.0);
    return {x, y, z};
}

// The object-side line of a ray from sensor point p towards exit-pupil point (qx, qy), or nullopt when it
// is stopped (a clear aperture, the iris, total internal reflection).
bool trace_back(const Setup& s, int channel, const optics::Vec3& p, double qx, double qy, std::array<float, 4>& out) {
    const optics::Vec3 q{qx, qy, s.exit_pupil_z};
    optics::Ray ray{p, optics::normalize(q - p)};
    optics::TraceOptions options;
    options.to_sensor = false;
    const optics::TraceResult r = optics::trace(s.systems[static_cast<std::size_t>(channel)], ray, s.back_path, options);
    if (!r.ok() || r.r_rel > 1.0 || r.direction.z >= -1e-9) return false;
    if (s.iris(r.stop_uv.x, r.stop_uv.y) > 0.0) return false;
    // Lens x(D) = a + b D at depth D (mm) in front of the entrance pupil.
    const double ez = s.focus.entrance_pupil_z_mm;
    const double ax = r.position.x + r.direction.x * (ez - r.position.z) / r.direction.z;
    const double ay = r.position.y + r.direction.y * (ez - r.position.z) / r.direction.z;
    const double bx = -r.direction.x / r.direction.z, by = -r.direction.y / r.direction.z;
    const double f = s.focus.efl_mm, pitch = s.camera.pitch_mm();
    out = {static_cast<float>(s.camera.centre_x + f * bx / pitch), static_cast<float>(f * ax / (1000.0 * pitch)),
           static_cast<float>(s.camera.centre_y - f * by / pitch), static_cast<float>(-f * ay / (1000.0 * pitch))};
    return true;
}

// The part of the exit-pupil plane that rays from p get through, as a rectangle (coarse search over a disc
// twice the paraxial exit pupil).
std::array<double, 4> pupil_box(const Setup& s, int channel, const optics::Vec3& p) {
    constexpr int n = 24;
    const double r = 2.0 * s.exit_pupil_r, cell = 2.0 * r / n;
    double x0 = 1e30, y0 = 1e30, x1 = -1e30, y1 = -1e30;
    std::array<float, 4> line{};
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            const double qx = -r + (i + 0.5) * cell, qy = -r + (j + 0.5) * cell;
            if (!trace_back(s, channel, p, qx, qy, line)) continue;
            x0 = std::min(x0, qx), x1 = std::max(x1, qx), y0 = std::min(y0, qy), y1 = std::max(y1, qy);
        }
    }
    if (x0 > x1) return {0, 0, 0, 0};
    return {x0 - cell, y0 - cell, x1 + cell, y1 + cell};
}

// Where a stored ray line (cx, ax, cy, ay) lies at inverse depth w: pixel = c + a w.
std::array<double, 2> line_at(const std::array<float, 4>& l, double w) {
    return {static_cast<double>(l[0]) + static_cast<double>(l[1]) * w, static_cast<double>(l[2]) + static_cast<double>(l[3]) * w};
}

void fill_grid_point(const Setup& s, RayTable& t, int gx, int gy) {
    const optics::Vec3 p = sensor_point(s, gx * t.cell_w, gy * t.cell_h);
    for (int c = 0; c < t.channels; ++c) {
        const std::array<double, 4> box = pupil_box(s, c, p);
        for (int k = 0; k < t.samples; ++k) {
            const std::size_t i = t.at(c, gx, gy, k);
            const auto [u, v] = r2(k);
            const bool ok = box[2] > box[0] &&
                            trace_back(s, c, p, box[0] + u * (box[2] - box[0]), box[1] + v * (box[3] - box[1]), t.line[i]);
            t.weight[i] = ok ? 1.0f : 0.0f;
        }
    }
}

// Largest distance at focus depth between a grid point's rays and their mean there (tilt, a focal surface,
// aberrations); the mean itself may lie off the grid point (focus breathing, distortion), which the
// uniform-colour test's centre already follows.
double focus_spread(const RayTable& t) {
    double spread = 0.0;
    for (int c = 0; c < t.channels; ++c)
        for (int gy = 0; gy < t.grid_y; ++gy)
            for (int gx = 0; gx < t.grid_x; ++gx) {
                const auto at_focus = [&](int k) {
                    return line_at(t.line[t.at(c, gx, gy, k)], t.focus_w);
                };
                double mx = 0.0, my = 0.0, n = 0.0;
                for (int k = 0; k < t.samples; ++k)
                    if (t.weight[t.at(c, gx, gy, k)] > 0.0f) mx += at_focus(k)[0], my += at_focus(k)[1], n += 1.0;
                if (n == 0.0) continue;
                mx /= n, my /= n;
                for (int k = 0; k < t.samples; ++k)
                    if (t.weight[t.at(c, gx, gy, k)] > 0.0f) spread = std::max(spread, std::hypot(at_focus(k)[0] - mx, at_focus(k)[1] - my));
            }
    return spread;
}

}  // namespace

double focus_at(const Camera& camera, double px, double py) {
    if (camera.focus_points.empty()) return camera.focus_m;
    double sum = 0.0, weights = 0.0;
    for (const FocusPoint& p : camera.focus_points) {
        const double d = std::hypot(px - p.x, py - p.y);
        if (d < 1e-9) return p.metres;  // the constraint itself, exactly
        const double w = 1.0 / std::pow(d, camera.focus_power);
        sum += w / p.metres, weights += w;
    }
    return weights / sum;
}

std::vector<Band> bands_of(const Camera& camera) {
    if (!camera.bands.empty()) return camera.bands;
    std::vector<Band> rgb(3);
    for (std::size_t c = 0; c < 3; ++c) rgb[c].wavelength_nm = camera.wavelengths_nm[c], rgb[c].weight[c] = 1.0;
    return rgb;
}

RayTable make_ray_table(const Camera& camera, int samples, int grid) {
    if (camera.width < 1 || camera.height < 1 || samples < 1 || grid < 2) throw std::invalid_argument("lens rays: empty raster or table");
    const optics::Paraxial p = optics::paraxial(camera.system);
    const std::vector<Band> bands = bands_of(camera);
    Setup s{camera, focus_of(camera.system, camera.focus_m), 0.0, 0.0, optics::reversed_path(optics::direct_path(camera.system)), {},
            optics::IrisSdf(camera.system.aperture)};
    for (const Band& b : bands) s.systems.emplace_back(camera.system, b.wavelength_nm);
    s.exit_pupil_z = camera.system.interfaces.back().z_mm + p.exit_pupil_mm;
    s.exit_pupil_r = 0.5 * p.exit_pupil_diameter_mm;

    RayTable t;
    t.channels = static_cast<int>(bands.size());
    t.achromatic = 0;
    for (std::size_t b = 0; b < bands.size(); ++b) {
        t.channel_weight.push_back({static_cast<float>(bands[b].weight[0]), static_cast<float>(bands[b].weight[1]), static_cast<float>(bands[b].weight[2])});
        if (std::abs(bands[b].wavelength_nm - 550.0) < std::abs(bands[static_cast<std::size_t>(t.achromatic)].wavelength_nm - 550.0))
            t.achromatic = static_cast<int>(b);
    }
    if (camera.bands.empty()) t.achromatic = 1;  // RGB: green, whatever wavelengths_nm say
    t.samples = samples;
    t.grid_x = grid;
    t.cell_w = static_cast<double>(camera.width) / (grid - 1);
    t.grid_y = std::max(2, static_cast<int>(std::ceil(camera.height / t.cell_w)) + 1);
    t.cell_h = static_cast<double>(camera.height) / (t.grid_y - 1);
    const std::size_t n = static_cast<std::size_t>(t.channels) * static_cast<std::size_t>(t.grid_x) * static_cast<std::size_t>(t.grid_y) * static_cast<std::size_t>(samples);
    t.line.assign(n, std::array<float, 4>{});
    t.weight.assign(n, 0.0f);
    t.focus_w = 1.0 / camera.focus_m;

    const unsigned threads = std::max(1u, std::min(8u, std::thread::hardware_concurrency()));
    std::vector<std::thread> pool;
    for (unsigned w = 0; w < threads; ++w)
        pool.emplace_back([&, w] {
            for (int i = static_cast<int>(w); i < t.grid_x * t.grid_y; i += static_cast<int>(threads)) fill_grid_point(s, t, i % t.grid_x, i / t.grid_x);
        });
    for (auto& th : pool) th.join();
    for (std::size_t i = 0; i < n; ++i)
        if (t.weight[i] > 0.0f) t.max_slope = std::max({t.max_slope, static_cast<double>(std::abs(t.line[i][1])), static_cast<double>(std::abs(t.line[i][3]))});
    t.focus_spread = focus_spread(t);
    return t;
}

double convergence_offset_px(const RayTable& t) {
    double offset = 0.0;
    for (int c = 0; c < t.channels; ++c)
        for (int gy = 0; gy < t.grid_y; ++gy)
            for (int gx = 0; gx < t.grid_x; ++gx) {
                double mx = 0.0, my = 0.0, n = 0.0;
                for (int k = 0; k < t.samples; ++k) {
                    const std::size_t i = t.at(c, gx, gy, k);
                    if (t.weight[i] <= 0.0f) continue;
                    const auto [x, y] = line_at(t.line[i], t.focus_w);
                    mx += x, my += y, n += 1.0;
                }
                if (n > 0.0) offset = std::max(offset, std::hypot(mx / n - gx * t.cell_w, my / n - gy * t.cell_h));
            }
    return offset;
}

double scene_scale(const RayTable& t, int channel, double w) {
    const int gx = t.grid_x / 2 - (t.grid_x % 2 == 0 ? 1 : 0), gy = t.grid_y / 2;
    double sum = 0.0;
    int n = 0;
    for (int s = 0; s < t.samples; ++s) {
        const std::size_t a = t.at(channel, gx, gy, s), b = t.at(channel, gx + 1, gy, s);
        if (t.weight[a] <= 0.0f || t.weight[b] <= 0.0f) continue;
        sum += (line_at(t.line[b], w)[0] - line_at(t.line[a], w)[0]) / t.cell_w;
        ++n;
    }
    return n > 0 ? sum / n : 0.0;
}

ScreenRay ray_at(const RayTable& t, int channel, double px, double py, int s) {
    const double fx = std::clamp(px / t.cell_w, 0.0, t.grid_x - 1.0), fy = std::clamp(py / t.cell_h, 0.0, t.grid_y - 1.0);
    const int x0 = std::min(static_cast<int>(fx), t.grid_x - 2), y0 = std::min(static_cast<int>(fy), t.grid_y - 2);
    const double tx = fx - x0, ty = fy - y0;
    // Each corner's ray relative to its own grid point, moved to (px, py): where a sample passes at some
    // corners only, it still converges on this pixel, not on the corner's (up to a grid cell away). With
    // every corner valid this is the plain bilinear mix.
    ScreenRay r{0, 0, 0, 0, 0};
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            const std::size_t k = t.at(channel, x0 + i, y0 + j, s);
            const float w = static_cast<float>((i ? tx : 1.0 - tx) * (j ? ty : 1.0 - ty)) * t.weight[k];
            const auto gx = static_cast<float>((x0 + i) * t.cell_w), gy = static_cast<float>((y0 + j) * t.cell_h);
            r.cx += w * (t.line[k][0] - gx), r.ax += w * t.line[k][1], r.cy += w * (t.line[k][2] - gy), r.ay += w * t.line[k][3];
            r.weight += w;
        }
    }
    if (r.weight > 0.0f) {
        r.cx = r.cx / r.weight + static_cast<float>(fx * t.cell_w), r.ax /= r.weight;
        r.cy = r.cy / r.weight + static_cast<float>(fy * t.cell_h), r.ay /= r.weight;
    }
    return r;
}

}  // namespace lensfx::dof
