#include <optics/starburst.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <thread>
#include <vector>

#include <fftw3.h>
#include <fmt/core.h>

#include <optics/aperture.h>

namespace lensfx::optics {

namespace {

constexpr double kReferenceNm = 550.0;

struct FftwFree {
    void operator()(void* p) const { fftw_free(p); }
};
template <class T>
std::unique_ptr<T[], FftwFree> fftw_buffer(std::size_t n) {
    auto* p = static_cast<T*>(fftw_malloc(sizeof(T) * n));
    if (!p) throw std::bad_alloc();
    return std::unique_ptr<T[], FftwFree>(p);
}

// The same grid from a transmission image spanning [-1, 1]^2 stop radii, 2 x 2 supersampled.
void rasterise_image(const ApertureImage& image, int m, int r, double* out) {
    const double inv = 1.0 / r;
    for (int y = 0; y < m; ++y) {
        for (int x = 0; x < m; ++x) {
            const double u = (x - m / 2) * inv;
            const double v = (m / 2 - y) * inv;
            double t = 0.0;
            for (int sy = 0; sy < 2; ++sy)
                for (int sx = 0; sx < 2; ++sx) t += image.at(u + (sx - 0.5) * 0.5 * inv, v - (sy - 0.5) * 0.5 * inv);
            out[static_cast<std::size_t>(y) * static_cast<std::size_t>(m) + static_cast<std::size_t>(x)] = 0.25 * t;
        }
    }
}

// Separable Gaussian blur of one float plane in place (edges clamped).
void blur(std::vector<double>& plane, int n, double sigma) {
    if (sigma <= 0.0) return;
    const int radius = static_cast<int>(std::ceil(3.0 * sigma));
    std::vector<double> kernel(static_cast<std::size_t>(2 * radius + 1));
    double total = 0.0;
    for (int i = -radius; i <= radius; ++i) total += kernel[static_cast<std::size_t>(i + radius)] = std::exp(-0.5 * i * i / (sigma * sigma));
    for (double& k : kernel) k /= total;
    std::vector<double> tmp(plane.size());
    const auto idx = [n](int x, int y) { return static_cast<std::size_t>(y) * static_cast<std::size_t>(n) + static_cast<std::size_t>(x); };
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            double s = 0.0;
            for (int i = -radius; i <= radius; ++i) s += kernel[static_cast<std::size_t>(i + radius)] * plane[idx(std::clamp(x + i, 0, n - 1), y)];
            tmp[idx(x, y)] = s;
        }
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            double s = 0.0;
            for (int i = -radius; i <= radius; ++i) s += kernel[static_cast<std::size_t>(i + radius)] * tmp[idx(x, std::clamp(y + i, 0, n - 1))];
            plane[idx(x, y)] = s;
        }
}

}  // namespace

double starburst_core_radius_texels(const Starburst& starburst) {
    return starburst.texel_per_fnumber_mm > 0.0 ? 2.23 * kReferenceNm * 1e-6 / starburst.texel_per_fnumber_mm : 0.0;
}

std::array<double, 3> Starburst::sums() const {
    std::array<double, 3> s{};
    for (std::size_t i = 0; i < rgb.size(); ++i) s[i % 3] += static_cast<double>(rgb[i]);
    return s;
}

namespace {

void validate_options(const StarburstOptions& o) {
    if (o.size < 16 || o.size > 8192) throw std::invalid_argument(fmt::format("starburst size {} outside 16..8192", o.size));
    if (o.pupil_samples < 8) throw std::invalid_argument(fmt::format("starburst pupil samples {} below 8", o.pupil_samples));
    if (!(o.step_nm > 0.0) || !(o.last_nm >= o.first_nm) || !(o.first_nm > 0.0))
        throw std::invalid_argument("starburst wavelength range must be positive and increasing");
}

// FFT size: the shortest wavelength stretches the spectrum least, so it must still cover the texture,
// and the iris must be padded at least 2x for the power spectrum to be sampled finely enough.
int fft_size(const StarburstOptions& o) {
    const double reach = 0.5 * o.size * kReferenceNm / o.first_nm + 2.0;
    int m = 64;
    while (m < 2.0 * reach || m < 4 * o.pupil_samples) m *= 2;
    return m;
}

// The iris's power spectrum on an m x m grid, centred: frequency (0, 0) at (m/2, m/2).
struct PowerSpectrum {
    int m = 0;
    std::vector<double> power;

    // Bilinear at (fx, fy) FFT bins from the centre; 0 outside the grid.
    double sample(double fx, double fy) const {
        const double px = fx + m / 2, py = fy + m / 2;
        const int x0 = static_cast<int>(std::floor(px)), y0 = static_cast<int>(std::floor(py));
        if (x0 < 0 || y0 < 0 || x0 + 1 >= m || y0 + 1 >= m) return 0.0;
        const double ax = px - x0, ay = py - y0;
        const auto at = [&](int x, int y) { return power[static_cast<std::size_t>(y) * static_cast<std::size_t>(m) + static_cast<std::size_t>(x)]; };
        return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x0 + 1, y0)) + ay * ((1 - ax) * at(x0, y0 + 1) + ax * at(x0 + 1, y0 + 1));
    }
};

// The transmission grid: the aperture's outline or the options' image, with the pupil's imperfections.
void rasterise_iris(const Aperture& aperture, const StarburstOptions& o, int m, double* out) {
    if (o.image.empty()) {
        rasterise_aperture(aperture, m, o.pupil_samples, out);
    } else {
        rasterise_image(o.image, m, o.pupil_samples, out);
    }
    apply_imperfections(o.dirt, m, o.pupil_samples, out);
}

// |F|^2 of a real m x m transform's half spectrum, centred; the real input's spectrum is
// conjugate-symmetric, so the missing half is the mirrored one.
std::vector<double> centred_power(const fftw_complex* half_spectrum, int m) {
    const std::size_t half = static_cast<std::size_t>(m / 2 + 1);
    std::vector<double> power(static_cast<std::size_t>(m) * static_cast<std::size_t>(m));
    for (int y = 0; y < m; ++y) {
        for (int x = 0; x < m; ++x) {
            int fx = x - m / 2, fy = y - m / 2;
            if (fx < 0) { fx = -fx; fy = -fy; }
            const int row = (fy % m + m) % m;
            const fftw_complex& c = half_spectrum[static_cast<std::size_t>(row) * half + static_cast<std::size_t>(fx)];
            power[static_cast<std::size_t>(y) * static_cast<std::size_t>(m) + static_cast<std::size_t>(x)] = c[0] * c[0] + c[1] * c[1];
        }
    }
    return power;
}

PowerSpectrum iris_power_spectrum(const Aperture& aperture, const StarburstOptions& o, int m) {
    const std::size_t mm = static_cast<std::size_t>(m) * static_cast<std::size_t>(m);
    const std::size_t half = static_cast<std::size_t>(m / 2 + 1);
    auto in = fftw_buffer<double>(mm);
    auto out = fftw_buffer<fftw_complex>(static_cast<std::size_t>(m) * half);
    fftw_plan plan = fftw_plan_dft_r2c_2d(m, m, in.get(), out.get(), FFTW_ESTIMATE);
    if (!plan) throw std::runtime_error("FFTW could not plan the starburst transform");
    rasterise_iris(aperture, o, m, in.get());
    fftw_execute(plan);
    fftw_destroy_plan(plan);
    return {m, centred_power(out.get(), m)};
}

using XyzPlanes = std::array<std::vector<double>, 3>;

// Rows [y0, y1) of the pattern in CIE XYZ (see integrate_wavelengths), added into xyz.
void integrate_rows(const PowerSpectrum& spectrum, const StarburstOptions& o, int y0, int y1, XyzPlanes& xyz) {
    const int n = o.size;
    for (double l = o.first_nm; l <= o.last_nm + 1e-9; l += o.step_nm) {
        const std::array<double, 3> cmf = cie1931_xyz(l);
        const double s = kReferenceNm / l;          // texel -> FFT bin at this wavelength
        const double energy = s * s;                // a pattern stretched by 1/s spreads its energy over 1/s^2 the area
        for (int y = y0; y < y1; ++y) {
            for (int x = 0; x < n; ++x) {
                const double p = spectrum.sample((x - n / 2) * s, (y - n / 2) * s) * energy;
                const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(n) + static_cast<std::size_t>(x);
                for (std::size_t c = 0; c < 3; ++c) xyz[c][i] += cmf[c] * p;
            }
        }
    }
}

// The pattern in CIE XYZ over the options' wavelengths, o.size texels square. One FFT bin at 550 nm is one
// texel: wavelength x N x (2 r / m) on the sensor (eq. 2 with z0/D = N). The rows are shared between the
// cores (most of a cold run's starburst time): each texel still sums its wavelengths in the same order, so
// the result does not depend on how many threads there are.
XyzPlanes integrate_wavelengths(const PowerSpectrum& spectrum, const StarburstOptions& o) {
    const int n = o.size;
    const std::size_t nn = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
    XyzPlanes xyz{std::vector<double>(nn, 0.0), std::vector<double>(nn, 0.0), std::vector<double>(nn, 0.0)};
    const int threads = static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 8u));
    std::vector<std::jthread> helpers;
    for (int t = 1; t < threads; ++t)
        helpers.emplace_back([&, t] { integrate_rows(spectrum, o, n * t / threads, n * (t + 1) / threads, xyz); });
    integrate_rows(spectrum, o, 0, n / threads, xyz);
    for (std::jthread& h : helpers) h.join();  // before xyz is returned (moved) from under them
    return xyz;
}

// The texture ends at its inscribed circle, fading over its outer third (smoothstep) so no square edge shows.
void fade_to_inscribed_circle(XyzPlanes& xyz, int n) {
    for (int y = 0; y < n; ++y) {
        for (int x = 0; x < n; ++x) {
            const double r = std::hypot(x - n / 2, y - n / 2) / (0.5 * n);
            const double t = std::clamp((r - 2.0 / 3.0) * 3.0, 0.0, 1.0);
            const double w = 1.0 - t * t * (3.0 - 2.0 * t);
            const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(n) + static_cast<std::size_t>(x);
            for (auto& plane : xyz) plane[i] *= w;
        }
    }
}

// Interleaved RGB in the working space, negative values clipped, each channel scaled to sum 1.
std::vector<float> unit_sum_rgb(const XyzPlanes& xyz, const Mat3& xyz_to_rgb) {
    const std::size_t nn = xyz[0].size();
    std::array<double, 3> total{};
    std::vector<double> rgb(nn * 3);
    for (std::size_t i = 0; i < nn; ++i) {
        for (std::size_t c = 0; c < 3; ++c) {
            const double v = std::max(0.0, row_times(xyz_to_rgb, c, {xyz[0][i], xyz[1][i], xyz[2][i]}));
            rgb[i * 3 + c] = v;
            total[c] += v;
        }
    }
    std::vector<float> out(nn * 3, 0.0f);
    for (std::size_t i = 0; i < nn * 3; ++i) out[i] = total[i % 3] > 0.0 ? static_cast<float>(rgb[i] / total[i % 3]) : 0.0f;
    return out;
}

}  // namespace

Starburst make_starburst(const Aperture& aperture, const StarburstOptions& o) {
    validate_options(o);
    const int m = fft_size(o);
    const PowerSpectrum spectrum = iris_power_spectrum(aperture, o, m);
    XyzPlanes xyz = integrate_wavelengths(spectrum, o);
    for (auto& plane : xyz) blur(plane, o.size, o.smoothing);
    fade_to_inscribed_circle(xyz, o.size);

    Starburst sb;
    sb.size = o.size;
    sb.texel_per_fnumber_mm = kReferenceNm * 1e-6 * 2.0 * o.pupil_samples / m;
    sb.rgb = unit_sum_rgb(xyz, o.xyz_to_rgb);
    return sb;
}

void splat_starburst(const Starburst& sb, const StarburstPlacement& at, const std::array<double, 3>& power,
                     const SensorImage& image) {
    const double f_number = at.f_number, cx = at.cx, cy = at.cy, core_radius_texels = at.core_radius_texels;
    const double pixel_w_mm = image.pixel_w_mm, pixel_h_mm = image.pixel_h_mm;
    float* const rgb = image.rgb;
    const int width = image.width, height = image.height;
    if (sb.size == 0 || !(f_number > 0.0) || !std::isfinite(cx) || !std::isfinite(cy)) return;
    const double texel_mm = sb.texel_per_fnumber_mm * f_number;
    const double tx = texel_mm / pixel_w_mm;  // texel size in pixels
    const double ty = texel_mm / pixel_h_mm;
    const double pixel_area = pixel_w_mm * pixel_h_mm;
    const double half = sb.size / 2;
    const double core2 = core_radius_texels * core_radius_texels;
    // A pattern wholly outside the frame adds nothing; the test is made in double, so that a light far
    // outside (3e9 px) never reaches the int pixel arithmetic below.
    const double reach_x = half * tx + 2.0, reach_y = half * ty + 2.0;
    if (!(cx + reach_x > 0.0 && cx - reach_x < width && cy + reach_y > 0.0 && cy - reach_y < height)) return;
    if (!(reach_x < 1e8 && reach_y < 1e8)) return;  // texels larger than any frame: a degenerate scale
    const auto left_out = [&](int i, int j) {
        const double dx = i - half, dy = j - half;
        return (dx * dx + dy * dy < core2) != at.only_core;
    };
    const auto add = [&](int x, int y, double w, int i, int j) {
        if (x < 0 || y < 0 || x >= width || y >= height || w <= 0.0 || left_out(i, j)) return;
        float* px = rgb + (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 3;
        const std::size_t texel = static_cast<std::size_t>(j) * static_cast<std::size_t>(sb.size) + static_cast<std::size_t>(i);
        for (std::size_t c = 0; c < 3; ++c)
            px[c] += static_cast<float>(w * power[c] / pixel_area * static_cast<double>(sb.rgb[texel * 3 + c]));
    };
    if (tx <= 1.0 && ty <= 1.0) {
        // Texels smaller than pixels: each texel's energy goes bilinearly into the pixels around its centre.
        // The weights are separable: each texture row is gathered into pixel columns, then shared between
        // two pixel rows (the texture is far larger than its image here, so this is most of the cost).
        const int n = sb.size;
        std::vector<int> column(static_cast<std::size_t>(n));
        std::vector<double> right(static_cast<std::size_t>(n));  // share of the texel in column + 1
        for (int i = 0; i < n; ++i) {
            const double px = cx + (i - half) * tx - 0.5;
            column[static_cast<std::size_t>(i)] = static_cast<int>(std::floor(px));
            right[static_cast<std::size_t>(i)] = px - std::floor(px);
        }
        const int first = column.front(), columns = column.back() + 2 - first;
        std::vector<double> row(static_cast<std::size_t>(columns) * 3);
        for (int j = 0; j < n; ++j) {
            const double py = cy + (j - half) * ty - 0.5;
            const int y0 = static_cast<int>(std::floor(py));
            if (y0 + 1 < 0 || y0 >= height) continue;
            const double ay = py - y0;
            std::fill(row.begin(), row.end(), 0.0);
            const float* texels = sb.rgb.data() + static_cast<std::size_t>(j) * static_cast<std::size_t>(n) * 3;
            for (int i = 0; i < n; ++i) {
                if (left_out(i, j)) continue;
                const std::size_t k = static_cast<std::size_t>(column[static_cast<std::size_t>(i)] - first) * 3;
                const double a = right[static_cast<std::size_t>(i)];
                for (std::size_t c = 0; c < 3; ++c) {
                    const auto v = static_cast<double>(texels[static_cast<std::size_t>(i) * 3 + c]);
                    row[k + c] += (1.0 - a) * v;
                    row[k + 3 + c] += a * v;
                }
            }
            for (int dy = 0; dy < 2; ++dy) {
                const int y = y0 + dy;
                const double wy = (dy ? ay : 1.0 - ay) / pixel_area;
                if (y < 0 || y >= height || wy <= 0.0) continue;
                for (int k = std::max(0, -first); k < columns && first + k < width; ++k) {
                    float* px = rgb + (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(first + k)) * 3;
                    for (std::size_t c = 0; c < 3; ++c)
                        px[c] += static_cast<float>(wy * power[c] * row[static_cast<std::size_t>(k) * 3 + c]);
                }
            }
        }
        return;
    }
    // Texels larger than pixels: each pixel takes the texture at its centre, weighted by its share of a texel.
    const int x_begin = std::max(0, static_cast<int>(std::floor(cx - reach_x)));
    const int x_end = std::min(width, static_cast<int>(std::ceil(cx + reach_x)));
    const int y_begin = std::max(0, static_cast<int>(std::floor(cy - reach_y)));
    const int y_end = std::min(height, static_cast<int>(std::ceil(cy + reach_y)));
    const double share = 1.0 / (tx * ty);
    for (int y = y_begin; y < y_end; ++y) {
        for (int x = x_begin; x < x_end; ++x) {
            const double u = (x + 0.5 - cx) / tx + half - 0.5;
            const double v = (y + 0.5 - cy) / ty + half - 0.5;
            const int i0 = static_cast<int>(std::floor(u)), j0 = static_cast<int>(std::floor(v));
            const double au = u - i0, av = v - j0;
            for (int dj = 0; dj < 2; ++dj)
                for (int di = 0; di < 2; ++di) {
                    const int i = i0 + di, j = j0 + dj;
                    if (i < 0 || j < 0 || i >= sb.size || j >= sb.size) continue;
                    add(x, y, share * (di ? au : 1 - au) * (dj ? av : 1 - av), i, j);
                }
        }
    }
}

namespace {

// The iris's edges as the tail sees them, in stop radii: outward normal angle (upright frame), the spread
// of a curved edge's normals, its length and its share of the perimeter.
struct TailEdge {
    double normal = 0.0;
    double spread = 0.0;  // 0: straight (a spike); 2 pi: a round iris
    double length = 0.0;
    double share = 0.0;
};

struct IrisOutline {
    std::vector<TailEdge> edges;
    double coefficient = 0.0;  // P R / (pi^2 A)
    double half_gap = 0.0;     // half the angle between neighbouring spikes (n of them for even n blades, 2 n for odd)
};

IrisOutline iris_outline(const Aperture& aperture) {
    IrisOutline out;
    const double pi = std::numbers::pi;
    if (aperture.blades < 3) {
        out.edges.push_back({0.0, 2.0 * pi, 2.0 * pi, 1.0});
        out.coefficient = 2.0 / (pi * pi);
        return out;
    }
    const int n = aperture.blades;
    const double half_chord = std::sin(pi / n), apothem = std::cos(pi / n);
    const double c = std::clamp(aperture.blade_curvature, 0.0, 1.0);
    const double alpha = c > 1e-9 ? std::asin(std::min(1.0, half_chord * c)) : 0.0;  // half the arc's angle
    const double length = c > 1e-9 ? 2.0 * alpha / c : 2.0 * half_chord;
    const double area = n * half_chord * apothem + (c > 1e-9 ? n * 0.5 / (c * c) * (2.0 * alpha - std::sin(2.0 * alpha)) : 0.0);
    out.coefficient = n * length / (pi * pi * area);
    out.half_gap = pi / (n % 2 == 0 ? n : 2 * n);
    const double first = (aperture.rotation_deg - 90.0) * pi / 180.0;
    for (int k = 0; k < n; ++k) out.edges.push_back({first + 2.0 * pi * k / n, 2.0 * alpha, length, 1.0 / n});
    return out;
}

// Per channel, the mean wavelength (nm) of the texture's spectrum (380-780 nm through the CIE functions
// into linear Rec.709): the tail scales with the wavelength.
std::array<double, 3> channel_wavelengths() {
    std::array<double, 3> sum{}, weight{};
    for (double l = 380.0; l <= 780.0; l += 5.0) {
        const std::array<double, 3> xyz = cie1931_xyz(l);
        for (std::size_t c = 0; c < 3; ++c) {
            const double w = std::max(0.0, row_times(kXyzToRec709, c, xyz));
            sum[c] += w * l;
            weight[c] += w;
        }
    }
    return {sum[0] / weight[0], sum[1] / weight[1], sum[2] / weight[2]};
}

// Adds `energy` (per channel, already over the pixel area) bilinearly around continuous pixel position (x, y).
void deposit(float* rgb, int width, int height, double x, double y, const std::array<double, 3>& energy) {
    const double px = x - 0.5, py = y - 0.5;
    const int x0 = static_cast<int>(std::floor(px)), y0 = static_cast<int>(std::floor(py));
    const double ax = px - x0, ay = py - y0;
    for (int dy = 0; dy < 2; ++dy) {
        const int yy = y0 + dy;
        if (yy < 0 || yy >= height) continue;
        for (int dx = 0; dx < 2; ++dx) {
            const int xx = x0 + dx;
            if (xx < 0 || xx >= width) continue;
            const double w = (dx ? ax : 1.0 - ax) * (dy ? ay : 1.0 - ay);
            float* p = rgb + (static_cast<std::size_t>(yy) * static_cast<std::size_t>(width) + static_cast<std::size_t>(xx)) * 3;
            for (std::size_t c = 0; c < 3; ++c) p[c] += static_cast<float>(w * energy[c]);
        }
    }
}

// What the tail adds at radius r (mm) beyond the texture: 1 where the texture has faded out, rising across
// its fade (the outer third of its radius, smoothstep as in fade_to_inscribed_circle).
struct TailRamp {
    double fade_begin_mm, fade_end_mm;
    double operator()(double r) const {
        const double t = std::clamp((r - fade_begin_mm) / (fade_end_mm - fade_begin_mm), 0.0, 1.0);
        return t * t * (3.0 - 2.0 * t);
    }
};

// The halo of curved edges (a round iris, curved blades): each spreads its share of the tail evenly over
// the directions of its normals, both ways, so the energy per area is a / r^3 x that density. Drawn pixel
// by pixel out to where a pixel would hold under 1e-9 of the light (a spike's energy stays on a line and
// is walked instead).
void add_curved_tail(const IrisOutline& iris, const std::array<double, 3>& a, const TailRamp& ramp, double cx,
                     double cy, const std::array<double, 3>& power, double pixel_w_mm, double pixel_h_mm, float* rgb,
                     int width, int height) {
    double densest = 0.0;
    for (const TailEdge& e : iris.edges)
        if (e.spread > 0.0) densest = std::max(densest, e.share / e.spread);
    if (densest == 0.0) return;
    const double a_max = std::max({a[0], a[1], a[2]});
    const double r_cut = std::cbrt(a_max * densest * pixel_w_mm * pixel_h_mm / 1e-9);
    const int x0 = std::max(0, static_cast<int>(std::floor(cx - r_cut / pixel_w_mm)));
    const int x1 = std::min(width, static_cast<int>(std::ceil(cx + r_cut / pixel_w_mm)));
    const int y0 = std::max(0, static_cast<int>(std::floor(cy - r_cut / pixel_h_mm)));
    const int y1 = std::min(height, static_cast<int>(std::ceil(cy + r_cut / pixel_h_mm)));
    const double two_pi = 2.0 * std::numbers::pi;
    for (int y = y0; y < y1; ++y) {
        for (int x = x0; x < x1; ++x) {
            const double dx = (x + 0.5 - cx) * pixel_w_mm, dy = (cy - y - 0.5) * pixel_h_mm;
            const double r = std::hypot(dx, dy);
            if (r < ramp.fade_begin_mm || r > r_cut) continue;
            const double theta = std::atan2(dy, dx);
            double density = 0.0;
            for (const TailEdge& e : iris.edges) {
                if (e.spread == 0.0) continue;
                for (const double direction : {e.normal, e.normal + std::numbers::pi})
                    if (std::abs(std::remainder(theta - direction, two_pi)) <= 0.5 * e.spread) density += 0.5 * e.share / e.spread;
            }
            if (density == 0.0) continue;
            const double v = density * ramp(r) / (r * r * r);
            float* p = rgb + (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 3;
            for (std::size_t c = 0; c < 3; ++c) p[c] += static_cast<float>(power[c] * a[c] * v);
        }
    }
}

}  // namespace

double starburst_tail_coefficient(const Aperture& aperture) { return iris_outline(aperture).coefficient; }

namespace {

// The tail's reach in mm, where the texture fades out (the outer third of its radius) at this f-number.
TailRamp tail_ramp(const Starburst& sb, double f_number) {
    const double texel_mm = sb.texel_per_fnumber_mm * f_number;
    return TailRamp{2.0 / 3.0 * 0.5 * sb.size * texel_mm, 0.5 * sb.size * texel_mm};
}

// Energy outside r (per unit power, channel c): a[c] / r, each channel at its own wavelength.
std::array<double, 3> tail_amplitude(const IrisOutline& iris, double f_number, double length_scale) {
    const std::array<double, 3> nm = channel_wavelengths();
    std::array<double, 3> a{};
    for (std::size_t c = 0; c < 3; ++c) a[c] = iris.coefficient * nm[c] * 1e-6 * f_number * length_scale;
    return a;
}

// The integral of sinc^2(t) = (sin(pi t) / (pi t))^2 from 0 to u (odd in u; 1/2 at infinity): a table by
// Simpson's rule up to u = 8, interpolated, and the asymptotic series beyond.
double sinc2_integral(double u) {
    constexpr int kPerUnit = 256;
    constexpr double kTableEnd = 8.0;
    static const std::vector<double> table = [] {
        const auto f = [](double t) {
            if (t == 0.0) return 1.0;
            const double s = std::sin(std::numbers::pi * t) / (std::numbers::pi * t);
            return s * s;
        };
        const int n = static_cast<int>(kTableEnd) * kPerUnit;
        std::vector<double> c(static_cast<std::size_t>(n) + 1, 0.0);
        const double h = 1.0 / kPerUnit;
        for (int i = 0; i < n; ++i) c[static_cast<std::size_t>(i) + 1] = c[static_cast<std::size_t>(i)] + h / 6.0 * (f(i * h) + 4.0 * f((i + 0.5) * h) + f((i + 1) * h));
        return c;
    }();
    const double a = std::abs(u);
    double c;
    if (a >= kTableEnd) {
        const double pi = std::numbers::pi;
        c = 0.5 - 1.0 / (2.0 * pi * pi * a) - std::sin(2.0 * pi * a) / (4.0 * pi * pi * pi * a * a);
    } else {
        const double x = a * kPerUnit;
        const auto i = static_cast<std::size_t>(x);
        const double f = x - static_cast<double>(i);
        c = (1.0 - f) * table[i] + f * table[std::min(i + 1, table.size() - 1)];
    }
    return std::copysign(c, u);
}

// The share of a uniform ellipse's light (projected onto a line: a semicircle of half-width w) in [lo, hi].
double semicircle_share(double lo, double hi, double w) {
    const auto cumulative = [w](double x) {
        const double t = std::clamp(x / w, -1.0, 1.0);
        return (t * std::sqrt(1.0 - t * t) + std::asin(t)) / std::numbers::pi;
    };
    return cumulative(hi) - cumulative(lo);
}

// Per channel, wavelengths (nm) and their (non-negative) weights in the channel, summing to 1: the
// CIE functions into linear Rec.709 every 10 nm, as channel_wavelengths.
std::array<std::vector<std::pair<double, double>>, 3> channel_spectra() {
    std::array<std::vector<std::pair<double, double>>, 3> spectra;
    std::array<double, 3> total{};
    for (double l = 380.0; l <= 780.0; l += 10.0) {
        const std::array<double, 3> xyz = cie1931_xyz(l);
        for (std::size_t c = 0; c < 3; ++c) {
            const double w = std::max(0.0, row_times(kXyzToRec709, c, xyz));
            if (w > 0.0) spectra[c].emplace_back(l, w);
            total[c] += w;
        }
    }
    for (std::size_t c = 0; c < 3; ++c)
        for (auto& [l, w] : spectra[c]) w /= total[c];
    return spectra;
}

// Across a spike (see starburst.h): taps every `spacing` mm, tap k (-K..K) at k x spacing, each channel's
// weight the share of its wavelength-averaged sinc^2, spread over the source's width, in that tap's
// interval; `core` (mm) is how far out every step draws (the main lobe and the source), the wings' reach
// is set per step.
struct SpikeProfile {
    double spacing = 0.0;
    double core = 0.0;
    int taps = 0;                                // K
    std::vector<std::array<double, 3>> weights;  // 2 K + 1, tap k at k + K
    const std::array<double, 3>& at(int k) const { return weights[static_cast<std::size_t>(k + taps)]; }
};

SpikeProfile spike_profile(const TailEdge& edge, double f_number, double spacing, double source_half_width, double reach) {
    static const std::array<std::vector<std::pair<double, double>>, 3> spectra = channel_spectra();
    SpikeProfile p;
    p.spacing = spacing;
    const double widest_zero = 2.0 * 780e-6 * f_number / edge.length;
    p.core = source_half_width + 4.0 * widest_zero + spacing;
    p.taps = static_cast<int>(std::ceil(std::min(std::max(reach, p.core), 4096.0 * spacing) / spacing));
    const auto n = static_cast<std::size_t>(2 * p.taps + 1);
    std::vector<std::array<double, 3>> sharp(n);
    for (std::size_t c = 0; c < 3; ++c) {
        for (const auto& [nm, w] : spectra[c]) {
            const double zero = 2.0 * nm * 1e-6 * f_number / edge.length;
            for (int k = -p.taps; k <= p.taps; ++k)
                sharp[static_cast<std::size_t>(k + p.taps)][c] +=
                    w * (sinc2_integral((k + 0.5) * spacing / zero) - sinc2_integral((k - 0.5) * spacing / zero));
        }
    }
    if (source_half_width < 0.25 * spacing) {
        p.weights = std::move(sharp);
        return p;
    }
    // Spread over the source: each tap's light shared among the taps its semicircle covers.
    const int span = static_cast<int>(std::ceil(source_half_width / spacing)) + 1;
    p.weights.assign(n, {});
    for (int j = -span; j <= span; ++j) {
        const double share = semicircle_share((j - 0.5) * spacing, (j + 0.5) * spacing, source_half_width);
        if (share <= 0.0) continue;
        for (int k = std::max(-p.taps, -p.taps - j); k <= std::min(p.taps, p.taps - j); ++k)
            for (std::size_t c = 0; c < 3; ++c)
                p.weights[static_cast<std::size_t>(k + j + p.taps)][c] += share * sharp[static_cast<std::size_t>(k + p.taps)][c];
    }
    return p;
}

// Half the width (mm) across a spike whose across direction is (nx, ny) (mm, +y up) of the source ellipse.
double source_half_width(const SourceEllipse& s, double nx, double ny, double pixel_w_mm, double pixel_h_mm) {
    const double a = std::min(s.major_px, kMaxSourceSpreadPx), b = std::min(s.minor_px, kMaxSourceSpreadPx);
    if (!(a > 0.0) && !(b > 0.0)) return 0.0;
    const double phi = s.angle_deg * std::numbers::pi / 180.0;
    const double along_major = nx * std::cos(phi) * pixel_w_mm + ny * std::sin(phi) * pixel_h_mm;
    const double along_minor = -nx * std::sin(phi) * pixel_w_mm + ny * std::cos(phi) * pixel_h_mm;
    return std::hypot(std::max(0.0, a) * along_major, std::max(0.0, b) * along_minor);
}

}  // namespace

StarburstTail starburst_tail_share(const Starburst& sb, const Aperture& aperture, double f_number, double length_scale) {
    StarburstTail tail;
    if (sb.size == 0 || !(f_number > 0.0) || !(length_scale > 0.0)) return tail;
    const TailRamp ramp = tail_ramp(sb, f_number);
    const std::array<double, 3> a = tail_amplitude(iris_outline(aperture), f_number, length_scale);
    // The tail's share: the ramp over the fade (midpoint rule), all of it beyond.
    constexpr int kFadeSteps = 64;
    double fade = 0.0;
    const double dr = (ramp.fade_end_mm - ramp.fade_begin_mm) / kFadeSteps;
    for (int i = 0; i < kFadeSteps; ++i) {
        const double r0 = ramp.fade_begin_mm + i * dr;
        fade += ramp(r0 + 0.5 * dr) * (1.0 / r0 - 1.0 / (r0 + dr));
    }
    const double outside = fade + 1.0 / ramp.fade_end_mm;
    for (std::size_t c = 0; c < 3; ++c) tail.share[c] = std::min(1.0, a[c] * outside);
    return tail;
}

namespace {

// The span [lo, hi] of r in [r0, r1] for which c + r s lies within [a, b] (empty: lo > hi).
std::pair<double, double> ray_span(double c, double s, double a, double b, double r0, double r1) {
    if (s == 0.0) return c >= a && c <= b ? std::pair{r0, r1} : std::pair{1.0, 0.0};
    const double t0 = (a - c) / s, t1 = (b - c) / s;
    return {std::max(r0, std::min(t0, t1)), std::min(r1, std::max(t0, t1))};
}

// The steps n (r = r0 + n step, r < the spans' end) of a walk from r0 that fall within both spans, a step
// either side kept: [first, end).
std::pair<long long, long long> steps_within(std::pair<double, double> a, std::pair<double, double> b, double r0, double step) {
    const double lo = std::max(a.first, b.first), hi = std::min(a.second, b.second);
    if (!(lo <= hi)) return {0, 0};
    const auto first = static_cast<long long>(std::max(0.0, std::floor((lo - r0) / step) - 1.0));
    const auto end = static_cast<long long>(std::ceil((hi - r0) / step) + 1.0);
    return {first, end};
}

}  // namespace

void draw_starburst_tail(const Starburst& sb, const Aperture& aperture, double length_scale, const StarburstPlacement& at,
                         const std::array<double, 3>& power, const SensorImage& image) {
    const double f_number = at.f_number, cx = at.cx, cy = at.cy;
    const double pixel_w_mm = image.pixel_w_mm, pixel_h_mm = image.pixel_h_mm;
    float* const rgb = image.rgb;
    const int width = image.width, height = image.height;
    if (sb.size == 0 || !(f_number > 0.0) || !(length_scale > 0.0) || !std::isfinite(cx) || !std::isfinite(cy)) return;
    const IrisOutline iris = iris_outline(aperture);
    const TailRamp ramp = tail_ramp(sb, f_number);
    const std::array<double, 3> a = tail_amplitude(iris, f_number, length_scale);
    const double pixel_area = pixel_w_mm * pixel_h_mm;
    // The farthest frame corner from the light, in mm: where the walk along a spike ends.
    double reach = 0.0;
    for (const double x : {0.0, static_cast<double>(width)})
        for (const double y : {0.0, static_cast<double>(height)})
            reach = std::max(reach, std::hypot((x - cx) * pixel_w_mm, (y - cy) * pixel_h_mm));
    const double step = 0.5 * std::min(pixel_w_mm, pixel_h_mm);
    const double a_max = std::max({a[0], a[1], a[2]});
    const double midline = std::tan(iris.half_gap);  // a spike's wings end where its neighbour's begin
    for (const TailEdge& edge : iris.edges) {
        if (edge.spread > 0.0) continue;
        // A pixel x mm across at r mm holds about a share x0 pixel_area / (4 pi^2 r^2 x^2) of the light in
        // the wings (x0 the first zero): under 1e-9 beyond x = wings / r.
        const double widest_zero = 2.0 * 780e-6 * f_number / edge.length;
        const double wings = std::sqrt(a_max * edge.share * widest_zero * pixel_area / (4.0 * std::numbers::pi * std::numbers::pi * 1e-9));
        for (const double angle : {edge.normal, edge.normal + std::numbers::pi}) {
            const double ux = std::cos(angle), uy = std::sin(angle);
            const double half_width = source_half_width(at.source, -uy, ux, pixel_w_mm, pixel_h_mm);
            const SpikeProfile across = spike_profile(edge, f_number, step, half_width, std::sqrt(wings * midline));
            // Pixels per mm along and across the spike (the image's y runs down).
            const double sx = ux / pixel_w_mm, sy = -uy / pixel_h_mm;
            const double tx = -uy / pixel_w_mm, ty = -ux / pixel_h_mm;
            // Only the stretch of the spike whose taps can reach the image (a frame far wider than tall, or a light far
            // outside it, would otherwise walk the whole length past the image).
            const double across_x = across.taps * step * std::abs(tx) + 1.0, across_y = across.taps * step * std::abs(ty) + 1.0;
            const auto [first, end] = steps_within(ray_span(cx, sx, -across_x, width + across_x, ramp.fade_begin_mm, reach),
                                                   ray_span(cy, sy, -across_y, height + across_y, ramp.fade_begin_mm, reach),
                                                   ramp.fade_begin_mm, step);
            for (long long n = first; n < end; ++n) {
                const double r = ramp.fade_begin_mm + static_cast<double>(n) * step;
                if (r >= reach) break;
                const double mid = r + 0.5 * step;
                const double x = cx + mid * sx, y = cy + mid * sy;
                const double fraction = 0.5 * edge.share * ramp(mid) * (1.0 / r - 1.0 / (r + step));
                const double out_to = std::max(across.core, std::min(midline * mid, wings / mid));
                const int taps = std::min(across.taps, static_cast<int>(out_to / step));
                for (int k = -taps; k <= taps; ++k) {
                    const std::array<double, 3>& w = across.at(k);
                    std::array<double, 3> e{};
                    for (std::size_t c = 0; c < 3; ++c) e[c] = power[c] * a[c] * fraction * w[c] / pixel_area;
                    deposit(rgb, width, height, x + k * step * tx, y + k * step * ty, e);
                }
            }
        }
    }
    add_curved_tail(iris, a, ramp, cx, cy, power, pixel_w_mm, pixel_h_mm, rgb, width, height);
}

namespace {

// The light's ellipse as a kernel of pixel offsets (-R..R a side, row 0 at the top): each pixel's share of
// the ellipse (4 x 4 samples a pixel, semi-axes at least half a pixel so it is never empty), summing to 1.
std::vector<double> ellipse_kernel(const SourceEllipse& s, int radius) {
    const double a = std::clamp(s.major_px, 0.5, kMaxSourceSpreadPx), b = std::clamp(s.minor_px, 0.5, kMaxSourceSpreadPx);
    const double phi = s.angle_deg * std::numbers::pi / 180.0, c = std::cos(phi), sn = std::sin(phi);
    const int side = 2 * radius + 1;
    std::vector<double> k(static_cast<std::size_t>(side) * static_cast<std::size_t>(side), 0.0);
    double total = 0.0;
    for (int y = -radius; y <= radius; ++y)
        for (int x = -radius; x <= radius; ++x) {
            double inside = 0.0;
            for (int sy = 0; sy < 4; ++sy)
                for (int sx = 0; sx < 4; ++sx) {
                    const double px = x + (sx + 0.5) / 4.0 - 0.5, py = -(y + (sy + 0.5) / 4.0 - 0.5);  // +y up
                    const double u = (px * c + py * sn) / a, v = (-px * sn + py * c) / b;
                    inside += u * u + v * v <= 1.0 ? 1.0 : 0.0;
                }
            total += k[static_cast<std::size_t>(y + radius) * static_cast<std::size_t>(side) + static_cast<std::size_t>(x + radius)] = inside;
        }
    for (double& v : k) v /= total;
    return k;
}

// What the texture carries of a light of `power`: all but the tail's share.
std::array<double, 3> texture_power(const StarburstTail& tail, const std::array<double, 3>& power) {
    std::array<double, 3> p{};
    for (std::size_t c = 0; c < 3; ++c) p[c] = power[c] * (1.0 - tail.share[c]);
    return p;
}

// The texture of a light with an extent spread over its ellipse (every point of the light makes the
// pattern): drawn into a buffer around the light, each pixel shared over the ellipse's offsets, added to
// the image. A point (semi-axes under half a pixel) is splatted directly.
void splat_over_source(const Starburst& sb, const StarburstPlacement& at, const std::array<double, 3>& power, const SensorImage& image) {
    const double spread = std::min(std::max(at.source.major_px, at.source.minor_px), kMaxSourceSpreadPx);
    if (!(spread >= 0.5)) {
        splat_starburst(sb, at, power, image);
        return;
    }
    const int radius = static_cast<int>(std::ceil(spread)) + 1;
    const double texel_mm = sb.texel_per_fnumber_mm * at.f_number;
    const double reach_x = 0.5 * sb.size * texel_mm / image.pixel_w_mm + 2.0 + radius;
    const double reach_y = 0.5 * sb.size * texel_mm / image.pixel_h_mm + 2.0 + radius;
    const auto clamp_to = [](double v, int n) { return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(n))); };
    const int x0 = clamp_to(std::floor(at.cx - reach_x), image.width), x1 = clamp_to(std::ceil(at.cx + reach_x), image.width);
    const int y0 = clamp_to(std::floor(at.cy - reach_y), image.height), y1 = clamp_to(std::ceil(at.cy + reach_y), image.height);
    if (x1 <= x0 || y1 <= y0) return;
    // The buffer reaches the kernel's radius beyond the region, so what spreads into the region is whole.
    const int bx = x0 - radius, by = y0 - radius, w = x1 - x0 + 2 * radius, h = y1 - y0 + 2 * radius;
    std::vector<float> local(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3, 0.0f);
    StarburstPlacement shifted = at;
    shifted.cx -= bx;
    shifted.cy -= by;
    splat_starburst(sb, shifted, power, {local.data(), w, h, image.pixel_w_mm, image.pixel_h_mm});
    const std::vector<double> kernel = ellipse_kernel(at.source, radius);
    const int side = 2 * radius + 1;
    for (int y = y0; y < y1; ++y) {
        float* to = image.rgb + (static_cast<std::size_t>(y) * static_cast<std::size_t>(image.width) + static_cast<std::size_t>(x0)) * 3;
        for (int x = x0; x < x1; ++x, to += 3) {
            std::array<double, 3> sum{};
            for (int ky = 0; ky < side; ++ky) {
                // The light at (x, y) - offset, offset = (kx - radius, ky - radius), in buffer coordinates.
                const float* from = local.data() + (static_cast<std::size_t>(y - by + radius - ky) * static_cast<std::size_t>(w) +
                                                    static_cast<std::size_t>(x - bx + radius)) * 3;
                const double* k = kernel.data() + static_cast<std::size_t>(ky) * static_cast<std::size_t>(side);
                for (int kx = 0; kx < side; ++kx, from -= 3)
                    for (std::size_t c = 0; c < 3; ++c) sum[c] += k[kx] * static_cast<double>(from[c]);
            }
            for (std::size_t c = 0; c < 3; ++c) to[c] += static_cast<float>(sum[c]);
        }
    }
}

}  // namespace

StarburstTail draw_starburst(const Starburst& sb, const Aperture& aperture, double length_scale, const StarburstPlacement& at,
                             const std::array<double, 3>& power, const SensorImage& image) {
    if (sb.size == 0 || !(at.f_number > 0.0) || !(length_scale > 0.0) || !std::isfinite(at.cx) || !std::isfinite(at.cy)) return {};
    const StarburstTail tail = starburst_tail_share(sb, aperture, at.f_number, length_scale);
    StarburstPlacement rest = at;
    rest.only_core = false;
    splat_over_source(sb, rest, texture_power(tail, power), image);
    draw_starburst_tail(sb, aperture, length_scale, at, power, image);
    return tail;
}

void draw_starburst_core(const Starburst& sb, const Aperture& aperture, double length_scale, const StarburstPlacement& at,
                         const std::array<double, 3>& power, const SensorImage& image) {
    if (sb.size == 0 || !(at.f_number > 0.0) || !(length_scale > 0.0) || !std::isfinite(at.cx) || !std::isfinite(at.cy)) return;
    StarburstPlacement core = at;
    core.only_core = true;
    splat_over_source(sb, core, texture_power(starburst_tail_share(sb, aperture, at.f_number, length_scale), power), image);
}

}  // namespace lensfx::optics
