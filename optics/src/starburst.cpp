#include <optics/starburst.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>

#include <fftw3.h>
#include <fmt/core.h>

#include <optics/aperture.h>

namespace lensfx::optics {

namespace {

constexpr double kReferenceNm = 550.0;

double lobe(double x, double mu, double sigma_left, double sigma_right) {
    const double t = (x - mu) / (x < mu ? sigma_left : sigma_right);
    return std::exp(-0.5 * t * t);
}

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

std::array<double, 3> cie1931_xyz(double l) {
    const double x = 1.056 * lobe(l, 599.8, 37.9, 31.0) + 0.362 * lobe(l, 442.0, 16.0, 26.7) -
                     0.065 * lobe(l, 501.1, 20.4, 26.2);
    const double y = 0.821 * lobe(l, 568.8, 46.9, 40.5) + 0.286 * lobe(l, 530.9, 16.3, 31.1);
    const double z = 1.217 * lobe(l, 437.0, 11.8, 36.0) + 0.681 * lobe(l, 459.0, 26.0, 13.8);
    return {x, y, z};
}

double starburst_core_radius_texels(const Starburst& starburst) {
    return starburst.texel_per_fnumber_mm > 0.0 ? 2.23 * kReferenceNm * 1e-6 / starburst.texel_per_fnumber_mm : 0.0;
}

std::array<double, 3> Starburst::sums() const {
    std::array<double, 3> s{};
    for (std::size_t i = 0; i < rgb.size(); ++i) s[i % 3] += static_cast<double>(rgb[i]);
    return s;
}

Starburst make_starburst(const Aperture& aperture, const StarburstOptions& o) {
    if (o.size < 16 || o.size > 8192) throw std::invalid_argument(fmt::format("starburst size {} outside 16..8192", o.size));
    if (o.pupil_samples < 8) throw std::invalid_argument(fmt::format("starburst pupil samples {} below 8", o.pupil_samples));
    if (!(o.step_nm > 0.0) || !(o.last_nm >= o.first_nm) || !(o.first_nm > 0.0))
        throw std::invalid_argument("starburst wavelength range must be positive and increasing");

    // FFT size: the shortest wavelength stretches the spectrum least, so it must still cover the texture,
    // and the iris must be padded at least 2x for the power spectrum to be sampled finely enough.
    const double reach = 0.5 * o.size * kReferenceNm / o.first_nm + 2.0;
    int m = 64;
    while (m < 2.0 * reach || m < 4 * o.pupil_samples) m *= 2;

    const std::size_t mm = static_cast<std::size_t>(m) * static_cast<std::size_t>(m);
    const std::size_t half = static_cast<std::size_t>(m / 2 + 1);
    auto in = fftw_buffer<double>(mm);
    auto out = fftw_buffer<fftw_complex>(static_cast<std::size_t>(m) * half);
    fftw_plan plan = fftw_plan_dft_r2c_2d(m, m, in.get(), out.get(), FFTW_ESTIMATE);
    if (!plan) throw std::runtime_error("FFTW could not plan the starburst transform");
    if (o.image.empty()) {
        rasterise_aperture(aperture, m, o.pupil_samples, in.get());
    } else {
        rasterise_image(o.image, m, o.pupil_samples, in.get());
    }
    apply_imperfections(o.dirt, m, o.pupil_samples, in.get());
    fftw_execute(plan);
    fftw_destroy_plan(plan);

    // Centred power spectrum P[y][x], frequency (0, 0) at (m/2, m/2); the real input's spectrum is
    // conjugate-symmetric, so the missing half is the mirrored one.
    std::vector<double> power(mm);
    for (int y = 0; y < m; ++y) {
        for (int x = 0; x < m; ++x) {
            int fx = x - m / 2, fy = y - m / 2;
            if (fx < 0) { fx = -fx; fy = -fy; }
            const int row = (fy % m + m) % m;
            const fftw_complex& c = out[static_cast<std::size_t>(row) * half + static_cast<std::size_t>(fx)];
            power[static_cast<std::size_t>(y) * static_cast<std::size_t>(m) + static_cast<std::size_t>(x)] = c[0] * c[0] + c[1] * c[1];
        }
    }
    const auto sample = [&](double fx, double fy) {
        const double px = fx + m / 2, py = fy + m / 2;
        const int x0 = static_cast<int>(std::floor(px)), y0 = static_cast<int>(std::floor(py));
        if (x0 < 0 || y0 < 0 || x0 + 1 >= m || y0 + 1 >= m) return 0.0;
        const double ax = px - x0, ay = py - y0;
        const auto at = [&](int x, int y) { return power[static_cast<std::size_t>(y) * static_cast<std::size_t>(m) + static_cast<std::size_t>(x)]; };
        return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x0 + 1, y0)) + ay * ((1 - ax) * at(x0, y0 + 1) + ax * at(x0 + 1, y0 + 1));
    };

    // One FFT bin at 550 nm is one texel: wavelength x N x (2 r / m) on the sensor (eq. 2 with z0/D = N).
    const int n = o.size;
    const std::size_t nn = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
    std::array<std::vector<double>, 3> xyz{std::vector<double>(nn, 0.0), std::vector<double>(nn, 0.0), std::vector<double>(nn, 0.0)};
    for (double l = o.first_nm; l <= o.last_nm + 1e-9; l += o.step_nm) {
        const std::array<double, 3> cmf = cie1931_xyz(l);
        const double s = kReferenceNm / l;          // texel -> FFT bin at this wavelength
        const double energy = s * s;                // a pattern stretched by 1/s spreads its energy over 1/s^2 the area
        for (int y = 0; y < n; ++y) {
            for (int x = 0; x < n; ++x) {
                const double p = sample((x - n / 2) * s, (y - n / 2) * s) * energy;
                const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(n) + static_cast<std::size_t>(x);
                for (std::size_t c = 0; c < 3; ++c) xyz[c][i] += cmf[c] * p;
            }
        }
    }
    for (auto& plane : xyz) blur(plane, n, o.smoothing);
    // The texture ends at its inscribed circle, fading over its outer third so no square edge shows.
    for (int y = 0; y < n; ++y) {
        for (int x = 0; x < n; ++x) {
            const double r = std::hypot(x - n / 2, y - n / 2) / (0.5 * n);
            const double t = std::clamp((r - 2.0 / 3.0) * 3.0, 0.0, 1.0);
            const double w = 1.0 - t * t * (3.0 - 2.0 * t);
            const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(n) + static_cast<std::size_t>(x);
            for (auto& plane : xyz) plane[i] *= w;
        }
    }

    Starburst sb;
    sb.size = n;
    sb.texel_per_fnumber_mm = kReferenceNm * 1e-6 * 2.0 * o.pupil_samples / m;
    sb.rgb.assign(nn * 3, 0.0f);
    std::array<double, 3> total{};
    std::vector<double> rgb(nn * 3);
    for (std::size_t i = 0; i < nn; ++i) {
        for (std::size_t c = 0; c < 3; ++c) {
            const auto& row = o.xyz_to_rgb[c];
            const double v = std::max(0.0, row[0] * xyz[0][i] + row[1] * xyz[1][i] + row[2] * xyz[2][i]);
            rgb[i * 3 + c] = v;
            total[c] += v;
        }
    }
    for (std::size_t i = 0; i < nn * 3; ++i) sb.rgb[i] = total[i % 3] > 0.0 ? static_cast<float>(rgb[i] / total[i % 3]) : 0.0f;
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
    const auto in_core = [&](int i, int j) {
        const double dx = i - half, dy = j - half;
        return dx * dx + dy * dy < core2;
    };
    const auto add = [&](int x, int y, double w, int i, int j) {
        if (x < 0 || y < 0 || x >= width || y >= height || w <= 0.0 || in_core(i, j)) return;
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
                if (in_core(i, j)) continue;
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
            const auto& row = kXyzToRec709[c];
            const double w = std::max(0.0, row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2]);
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
// its fade (the outer third of its radius, smoothstep as in make_starburst).
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

// Across a spike: the edge's sinc^2 (first zeros at +-2 lambda N R / length) as a Gaussian per channel,
// each as wide as its own wavelength makes it (red widest), sampled at half-pixel offsets (mm) shared by
// the channels; each channel's weights sum to 1.
struct SpikeProfile {
    std::vector<double> offsets{0.0};
    std::vector<std::array<double, 3>> weights{{1.0, 1.0, 1.0}};
};

SpikeProfile spike_profile(const TailEdge& edge, double f_number, double pixel_mm) {
    const std::array<double, 3> nm = channel_wavelengths();
    std::array<double, 3> sigma_mm{};
    for (std::size_t c = 0; c < 3; ++c) sigma_mm[c] = 0.376 * 2.0 * nm[c] * 1e-6 * f_number / edge.length;
    const double widest = std::max({sigma_mm[0], sigma_mm[1], sigma_mm[2]});
    SpikeProfile profile;
    if (widest / pixel_mm <= 0.5) return profile;
    profile.offsets.clear();
    profile.weights.clear();
    const int taps = static_cast<int>(std::ceil(3.0 * widest / pixel_mm / 0.5));
    std::array<double, 3> total{};
    for (int j = -taps; j <= taps; ++j) {
        const double t = j * 0.5 * pixel_mm;
        std::array<double, 3> w{};
        for (std::size_t c = 0; c < 3; ++c) total[c] += w[c] = std::exp(-0.5 * t * t / (sigma_mm[c] * sigma_mm[c]));
        profile.offsets.push_back(t);
        profile.weights.push_back(w);
    }
    for (auto& w : profile.weights)
        for (std::size_t c = 0; c < 3; ++c) w[c] /= total[c];
    return profile;
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
    for (const TailEdge& edge : iris.edges) {
        if (edge.spread > 0.0) continue;
        const SpikeProfile across = spike_profile(edge, f_number, std::min(pixel_w_mm, pixel_h_mm));
        for (const double angle : {edge.normal, edge.normal + std::numbers::pi}) {
            const double ux = std::cos(angle), uy = std::sin(angle);
            // Pixels per mm along and across the spike (the image's y runs down).
            const double sx = ux / pixel_w_mm, sy = -uy / pixel_h_mm;
            const double tx = -uy / pixel_w_mm, ty = -ux / pixel_h_mm;
            for (double r = ramp.fade_begin_mm; r < reach; r += step) {
                const double mid = r + 0.5 * step;
                const double x = cx + mid * sx, y = cy + mid * sy;
                const double fraction = 0.5 * edge.share * ramp(mid) * (1.0 / r - 1.0 / (r + step));
                for (std::size_t k = 0; k < across.offsets.size(); ++k) {
                    const double t = across.offsets[k];
                    std::array<double, 3> e{};
                    for (std::size_t c = 0; c < 3; ++c) e[c] = power[c] * a[c] * fraction * across.weights[k][c] / pixel_area;
                    deposit(rgb, width, height, x + t * tx, y + t * ty, e);
                }
            }
        }
    }
    add_curved_tail(iris, a, ramp, cx, cy, power, pixel_w_mm, pixel_h_mm, rgb, width, height);
}

StarburstTail draw_starburst(const Starburst& sb, const Aperture& aperture, double length_scale, const StarburstPlacement& at,
                             const std::array<double, 3>& power, const SensorImage& image) {
    if (sb.size == 0 || !(at.f_number > 0.0) || !(length_scale > 0.0) || !std::isfinite(at.cx) || !std::isfinite(at.cy)) return {};
    const StarburstTail tail = starburst_tail_share(sb, aperture, at.f_number, length_scale);
    std::array<double, 3> texture_power{};
    for (std::size_t c = 0; c < 3; ++c) texture_power[c] = power[c] * (1.0 - tail.share[c]);
    splat_starburst(sb, at, texture_power, image);
    draw_starburst_tail(sb, aperture, length_scale, at, power, image);
    return tail;
}

}  // namespace lensfx::optics
