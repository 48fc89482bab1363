// Shared flare definitions (view, image, iris SDF, ghost pupil bounds) and the dense CPU reference.
#include <flare/flare.h>

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <thread>

#include <fmt/core.h>
#include <optics/paraxial.h>

namespace lensfx::flare {

using optics::Coating;
using optics::Ray;
using optics::TraceInterface;
using optics::Vec2;
using optics::collimated_ray;
using optics::enumerate_ghosts;
using optics::surface_sag;
using optics::trace;

std::vector<SpectralPass> spectral_passes(int bands, const optics::Mat3& xyz_to_rgb) {
    if (bands < kMinBands || bands > kMaxBands) {
        throw std::invalid_argument(
            fmt::format("--bands {}: give 0 (RGB, three wavelengths) or {}..{} spectral bands", bands, kMinBands, kMaxBands));
    }
    const double width = (kSpectrumLast_nm - kSpectrumFirst_nm) / bands;
    std::vector<SpectralPass> passes(static_cast<std::size_t>(bands));
    std::array<double, 3> sum{};
    for (int i = 0; i < bands; ++i) {
        SpectralPass& p = passes[static_cast<std::size_t>(i)];
        p.wavelength_nm = kSpectrumFirst_nm + (i + 0.5) * width;
        const std::array<double, 3> xyz = optics::cie1931_xyz(p.wavelength_nm);
        for (std::size_t c = 0; c < 3; ++c) {
            p.weight[c] = optics::row_times(xyz_to_rgb, c, xyz);
            sum[c] += p.weight[c];
        }
    }
    for (std::size_t c = 0; c < 3; ++c) {
        if (!(sum[c] > 0.0)) {
            throw std::invalid_argument(fmt::format(
                "spectral weights: a flat spectrum has no positive {} in this working space", "RGB"[c]));
        }
        for (SpectralPass& p : passes) p.weight[c] /= sum[c];
    }
    return passes;
}

std::array<double, 2> SensorView::angles_at(double x, double y) const {
    constexpr double kDegrees = 180.0 / std::numbers::pi;
    const double xs = (x / width - 0.5) * sensor_width_mm;
    const double ys = (0.5 - y / height) * sensor_height_mm;
    return {std::atan(xs / focal_mm) * kDegrees, std::atan(ys / focal_mm) * kDegrees};
}

std::vector<SpectralPass> FlareView::passes() const {
    if (wavelength_nm && bands != 0) {
        throw std::invalid_argument("--wavelength and --bands exclude each other");
    }
    if (wavelength_nm) return {{*wavelength_nm, {1.0, 1.0, 1.0}}};
    if (bands != 0) return spectral_passes(bands, xyz_to_rgb);
    return {{kRgbWavelengths_nm[0], {1.0, 0.0, 0.0}},
            {kRgbWavelengths_nm[1], {0.0, 1.0, 0.0}},
            {kRgbWavelengths_nm[2], {0.0, 0.0, 1.0}}};
}

std::array<double, 3> FlareImage::total_power(const FlareView& view) const {
    std::array<double, 3> sum{};
    for (std::size_t i = 0; i < rgb.size(); ++i) sum[i % 3] += static_cast<double>(rgb[i]);
    for (double& s : sum) s *= view.pixel_area_mm2();
    return sum;
}

double FlareImage::edge_measure() const {
    double tv = 0.0, total = 0.0;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            for (int c = 0; c < 3; ++c) {
                const auto v = static_cast<double>(at(x, y, c));
                total += std::abs(v);
                if (x + 1 < width) tv += std::abs(static_cast<double>(at(x + 1, y, c)) - v);
                if (y + 1 < height) tv += std::abs(static_cast<double>(at(x, y + 1, c)) - v);
            }
    return total > 0.0 ? tv / total : 0.0;
}

System without_coatings(System system) {
    for (System::Interface& surface : system.interfaces) surface.coating = Coating{};
    return system;
}

std::vector<Ghost> selected_ghosts(const System& system, const FlareView& view) {
    std::vector<Ghost> all = enumerate_ghosts(system);
    if (view.only_ghosts.empty()) return all;
    std::vector<Ghost> chosen;
    for (const auto& [a, b] : view.only_ghosts) {
        const int first = std::max(a, b);
        const int second = std::min(a, b);
        auto it = std::find_if(all.begin(), all.end(),
                               [&](const Ghost& g) { return g.first == first && g.second == second; });
        if (it == all.end()) {
            throw std::invalid_argument(fmt::format(
                "{}: no ghost reflects at interfaces {} and {} (stop and index-matched interfaces do not reflect)",
                system.name, second, first));
        }
        chosen.push_back(*it);
    }
    return chosen;
}

PupilRect entrance_square(const TraceSystem& system, const FlareView& view) {
    const TraceInterface& front = system.interfaces().front();
    double sag = 0.0;
    if (!surface_sag(front, front.semi_diameter, sag)) sag = front.semi_diameter;
    const double tan_x = std::tan(view.angle_x_deg * std::numbers::pi / 180.0);
    const double tan_y = std::tan(view.angle_y_deg * std::numbers::pi / 180.0);
    // A ray hitting the front surface at height h crosses z = 0 displaced by tan * sag (sag >= 0 ahead).
    const double reach = front.semi_diameter * 1.01;
    const double shift_x = -tan_x * sag;
    const double shift_y = -tan_y * sag;
    return {std::min(-reach, -reach - shift_x), std::min(-reach, -reach - shift_y),
            std::max(reach, reach - shift_x), std::max(reach, reach - shift_y)};
}

bool ray_passes(const TraceResult& result, const Aperture& aperture) {
    if (!result.ok() || result.r_rel > 1.0) return false;
    for (int k = 0; k < result.stop_count; ++k) {
        const Vec2& uv = result.stop_crossings[static_cast<std::size_t>(k)];
        if (aperture_sdf(aperture, uv.x, uv.y) > 0.0) return false;
    }
    return true;
}

PupilRect ghost_pupil_bounds(const TraceSystem& system, const Ghost& ghost, const Aperture& aperture,
                             const FlareView& view, double entrance_pupil_diameter_mm) {
    const PupilRect square = entrance_square(system, view);
    const double side = std::max(square.x1 - square.x0, square.y1 - square.y0);
    // At least 8 coarse rays across the entrance pupil, so that a small iris is not stepped over.
    const double spacing = std::min(side / 48.0, std::max(entrance_pupil_diameter_mm, 1e-3) / 8.0);
    const int res = std::clamp(static_cast<int>(std::ceil(side / spacing)), 48, 320);
    const double dx = (square.x1 - square.x0) / res;
    const double dy = (square.y1 - square.y0) / res;
    PupilRect box{1e300, 1e300, -1e300, -1e300};
    bool any = false;
    for (int iy = 0; iy <= res; ++iy) {
        for (int ix = 0; ix <= res; ++ix) {
            const double x = square.x0 + dx * ix;
            const double y = square.y0 + dy * iy;
            const Ray ray = collimated_ray(view.angle_x_deg, view.angle_y_deg, x, y, 0.0);
            if (!ray_passes(trace(system, ray, ghost.path), aperture)) continue;
            any = true;
            box.x0 = std::min(box.x0, x);
            box.y0 = std::min(box.y0, y);
            box.x1 = std::max(box.x1, x);
            box.y1 = std::max(box.y1, y);
        }
    }
    if (!any) return {};
    return {std::max(square.x0, box.x0 - dx), std::max(square.y0, box.y0 - dy), std::min(square.x1, box.x1 + dx),
            std::min(square.y1, box.y1 + dy)};
}

std::array<double, 2> sensor_to_pixel(const FlareView& view, double x_mm, double y_mm) {
    // The photograph is the sensor image turned 180 degrees.
    const double xu = -x_mm;
    const double yu = -y_mm;
    return {(xu / view.sensor_width_mm + 0.5) * view.width, (0.5 - yu / view.sensor_height_mm) * view.height};
}

namespace {

// Stratified sampling: one ray at a fixed pseudo-random point of each grid cell (a hash of the cell and
// the ghost), so the regular ray grid does not alias against the pixel grid, and runs repeat exactly.
std::pair<double, double> jitter(int ix, int iy, std::size_t ghost) {
    std::uint64_t h = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(ix)) << 32) ^
                      static_cast<std::uint32_t>(iy) ^ (static_cast<std::uint64_t>(ghost) * 0x9e3779b97f4a7c15ull);
    auto next = [&h] {
        h += 0x9e3779b97f4a7c15ull;  // splitmix64
        std::uint64_t z = h;
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
        z ^= z >> 31;
        return static_cast<double>(z >> 11) * 0x1.0p-53;
    };
    const double a = next();
    return {a, next()};
}

}  // namespace

FlareImage render_reference(const System& system, const FlareView& view, const ReferenceOptions& options) {
    if (options.rays < 2) throw std::invalid_argument(fmt::format("--rays {}: at least 2 needed", options.rays));
    if (view.width <= 0 || view.height <= 0) {
        throw std::invalid_argument(fmt::format("image size {}x{} is not positive", view.width, view.height));
    }
    const std::vector<Ghost> ghosts = selected_ghosts(system, view);
    const std::size_t pixels = static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height);
    const int threads = std::max(1, options.threads);
    const double inv_area = 1.0 / view.pixel_area_mm2();
    const int n = options.rays;

    std::vector<double> image(pixels * 3, 0.0);
    std::vector<GhostPower> powers;
    for (const SpectralPass& pass : view.passes()) {
        const double wavelength = pass.wavelength_nm;
        const TraceSystem traced(system, wavelength);
        const PupilRect whole = entrance_square(traced, view);
        const Ray axis_ray = collimated_ray(view.angle_x_deg, view.angle_y_deg, 0.0, 0.0, 0.0);
        const double epd = options.ghost_bounds ? optics::paraxial(system, wavelength).entrance_pupil_diameter_mm : 0.0;
        for (std::size_t g = 0; g < ghosts.size(); ++g) {
            const Ghost& ghost = ghosts[g];
            if (powers.size() <= g) powers.push_back({ghost.first, ghost.second, {}});
            PupilRect square = whole;
            if (options.ghost_bounds) {
                const PupilRect b = ghost_pupil_bounds(traced, ghost, system.aperture, view, epd);
                if (b.empty()) continue;
                const double gx = 0.1 * (b.x1 - b.x0);
                const double gy = 0.1 * (b.y1 - b.y0);
                square = {std::max(whole.x0, b.x0 - gx), std::max(whole.y0, b.y0 - gy), std::min(whole.x1, b.x1 + gx),
                          std::min(whole.y1, b.y1 + gy)};
            }
            const double dx = (square.x1 - square.x0) / n;
            const double dy = (square.y1 - square.y0) / n;
            const double cell_power = dx * dy * std::abs(axis_ray.direction.z);
            // Contiguous bands of ray rows per thread, summed in thread order: deterministic for a thread count.
            std::vector<std::vector<double>> partial(static_cast<std::size_t>(threads), std::vector<double>(pixels, 0.0));
            std::vector<std::jthread> workers;
            for (int t = 0; t < threads; ++t) {
                workers.emplace_back([&, t] {
                    std::vector<double>& acc = partial[static_cast<std::size_t>(t)];
                    const int row0 = n * t / threads;
                    const int row1 = n * (t + 1) / threads;
                    for (int iy = row0; iy < row1; ++iy) {
                        for (int ix = 0; ix < n; ++ix) {
                            const auto [jx, jy] = jitter(ix, iy, g);
                            const double x = square.x0 + dx * (ix + jx);
                            const double y = square.y0 + dy * (iy + jy);
                            const Ray ray = collimated_ray(view.angle_x_deg, view.angle_y_deg, x, y, 0.0);
                            const TraceResult r = trace(traced, ray, ghost.path);
                            if (!ray_passes(r, system.aperture)) continue;
                            const auto [px, py] = sensor_to_pixel(view, r.position.x, r.position.y);
                            if (!(px >= 0.0 && py >= 0.0 && px < view.width && py < view.height)) continue;
                            const std::size_t idx = static_cast<std::size_t>(py) * static_cast<std::size_t>(view.width) +
                                                    static_cast<std::size_t>(px);
                            acc[idx] += cell_power * r.transmission;
                        }
                    }
                });
            }
            workers.clear();
            for (std::size_t i = 0; i < pixels; ++i) {
                double sum = 0.0;
                for (const auto& p : partial) sum += p[i];
                if (sum == 0.0) continue;
                for (std::size_t c = 0; c < 3; ++c) {
                    if (pass.weight[c] == 0.0) continue;
                    image[i * 3 + c] += pass.weight[c] * sum * inv_area;
                    powers[g].power[c] += pass.weight[c] * sum;
                }
            }
        }
    }
    FlareImage out;
    out.width = view.width;
    out.height = view.height;
    out.rgb.assign(image.begin(), image.end());
    if (options.per_ghost_power) out.ghosts = std::move(powers);
    return out;
}

FlareError compare_flare(const FlareImage& image, const FlareImage& reference, const FlareView& view, int block) {
    if (image.width != reference.width || image.height != reference.height || block < 1) {
        throw std::invalid_argument(fmt::format("compare_flare: {}x{} against {}x{} (block {})", image.width,
                                                image.height, reference.width, reference.height, block));
    }
    FlareError error;
    const auto power = image.total_power(view);
    const auto reference_power = reference.total_power(view);
    for (std::size_t c = 0; c < 3; ++c) {
        if (reference_power[c] <= 0.0) continue;
        error.total = std::max(error.total, std::abs(power[c] - reference_power[c]) / reference_power[c]);
        double l1 = 0.0;
        for (int by = 0; by < image.height; by += block) {
            for (int bx = 0; bx < image.width; bx += block) {
                double a = 0.0;
                double b = 0.0;
                for (int y = by; y < std::min(by + block, image.height); ++y) {
                    for (int x = bx; x < std::min(bx + block, image.width); ++x) {
                        a += static_cast<double>(image.at(x, y, static_cast<int>(c)));
                        b += static_cast<double>(reference.at(x, y, static_cast<int>(c)));
                    }
                }
                l1 += std::abs(a - b);
            }
        }
        error.block_l1 = std::max(error.block_l1, l1 * view.pixel_area_mm2() / reference_power[c]);
        for (const GhostPower& ref : reference.ghosts) {
            if (ref.power[c] <= 0.01 * reference_power[c]) continue;
            auto it = std::find_if(image.ghosts.begin(), image.ghosts.end(), [&](const GhostPower& g) {
                return g.first == ref.first && g.second == ref.second;
            });
            const double p = it == image.ghosts.end() ? 0.0 : it->power[c];
            const double e = std::abs(p - ref.power[c]) / ref.power[c];
            if (e > error.worst_ghost) {
                error.worst_ghost = e;
                error.worst = {ref.first, ref.second};
            }
            if (c == 0) ++error.compared_ghosts;
        }
    }
    return error;
}

double gradient_error(const FlareImage& image, const FlareImage& reference) {
    if (image.width != reference.width || image.height != reference.height)
        throw std::invalid_argument(fmt::format("gradient_error: {}x{} against {}x{}", image.width, image.height,
                                                reference.width, reference.height));
    double difference = 0.0;
    double total = 0.0;
    for (int y = 0; y < image.height; ++y) {
        for (int x = 0; x < image.width; ++x) {
            for (int c = 0; c < 3; ++c) {
                const auto a = [&](int i, int j) { return static_cast<double>(image.at(i, j, c)); };
                const auto b = [&](int i, int j) { return static_cast<double>(reference.at(i, j, c)); };
                if (x + 1 < image.width) {
                    const double gb = b(x + 1, y) - b(x, y);
                    difference += std::abs(a(x + 1, y) - a(x, y) - gb);
                    total += std::abs(gb);
                }
                if (y + 1 < image.height) {
                    const double gb = b(x, y + 1) - b(x, y);
                    difference += std::abs(a(x, y + 1) - a(x, y) - gb);
                    total += std::abs(gb);
                }
            }
        }
    }
    return total > 0.0 ? difference / total : 0.0;
}

}  // namespace lensfx::flare
