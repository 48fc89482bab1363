#include <optics/ringing.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <memory>
#include <numbers>
#include <stdexcept>

#include <fftw3.h>
#include <fmt/core.h>

#include <optics/aperture.h>

namespace lensfx::optics {

namespace {

struct PlanDeleter {
    void operator()(fftw_plan_s* p) const { fftw_destroy_plan(p); }
};
struct FftwFree {
    void operator()(void* p) const { fftw_free(p); }
};

}  // namespace

double ringing_order(double wavelength_nm, double f_number) {
    return 0.15 * (wavelength_nm / 400.0) * (f_number / 18.0);
}

std::vector<float> fractional_ringing(const std::vector<double>& t, int n, double extent, double alpha) {
    if (n < 8 || n > 8192) throw std::invalid_argument(fmt::format("ringing texture size {} outside 8..8192", n));
    if (t.size() != static_cast<std::size_t>(n) * static_cast<std::size_t>(n))
        throw std::invalid_argument(fmt::format("ringing: {} samples for a {}x{} grid", t.size(), n, n));
    if (!(extent > 0.0) || !std::isfinite(extent)) throw std::invalid_argument("ringing: extent must be positive");
    if (!(alpha >= 0.0 && alpha < 0.5))
        throw std::invalid_argument(fmt::format("ringing order {} outside [0, 0.5)", alpha));
    std::vector<float> out(t.size());
    if (alpha == 0.0) {
        for (std::size_t i = 0; i < t.size(); ++i) out[i] = static_cast<float>(t[i] * t[i]);
        return out;
    }
    // Padded grid: 2n samples over [-2 extent, 2 extent), sample k at x = (k - n) h.
    const int m = 2 * n;
    const double h = 2.0 * extent / n;
    const std::size_t mm = static_cast<std::size_t>(m) * static_cast<std::size_t>(m);
    std::unique_ptr<fftw_complex[], FftwFree> field(static_cast<fftw_complex*>(fftw_malloc(sizeof(fftw_complex) * mm)));
    if (!field) throw std::bad_alloc();
    std::fill_n(&field[0][0], 2 * mm, 0.0);
    // Input texel (i, j) goes to padded sample (i + n/2, j + n/2) and is read back from there.
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            field[static_cast<std::size_t>(j + n / 2) * static_cast<std::size_t>(m) + static_cast<std::size_t>(i + n / 2)][0] =
                t[static_cast<std::size_t>(j) * static_cast<std::size_t>(n) + static_cast<std::size_t>(i)];

    std::unique_ptr<fftw_plan_s, PlanDeleter> forward(
        fftw_plan_dft_2d(m, m, field.get(), field.get(), FFTW_FORWARD, FFTW_ESTIMATE));
    std::unique_ptr<fftw_plan_s, PlanDeleter> backward(
        fftw_plan_dft_2d(m, m, field.get(), field.get(), FFTW_BACKWARD, FFTW_ESTIMATE));
    if (!forward || !backward) throw std::runtime_error("FFTW could not plan the ringing transform");

    // FrFT of angle phi = alpha pi / 2 in units s (s^2 = (2 extent)^2 / n) = Fresnel propagation with
    // lambda z = s^2 tan(phi) read at x / cos(phi); transfer exp(-i pi lambda z (fx^2 + fy^2)).
    const double phi = alpha * std::numbers::pi / 2.0;
    const double s2 = 4.0 * extent * extent / n;
    const double lambda_z = s2 * std::tan(phi);
    fftw_execute(forward.get());
    const double df = 1.0 / (m * h);
    for (int ky = 0; ky < m; ++ky) {
        const double fy = (ky < m / 2 ? ky : ky - m) * df;
        for (int kx = 0; kx < m; ++kx) {
            const double fx = (kx < m / 2 ? kx : kx - m) * df;
            const std::complex<double> k = std::polar(1.0 / static_cast<double>(mm), -std::numbers::pi * lambda_z * (fx * fx + fy * fy));
            fftw_complex& c = field[static_cast<std::size_t>(ky) * static_cast<std::size_t>(m) + static_cast<std::size_t>(kx)];
            const std::complex<double> v = std::complex<double>(c[0], c[1]) * k;
            c[0] = v.real();
            c[1] = v.imag();
        }
    }
    fftw_execute(backward.get());

    // Read back at the input's own scale: the FrFT's intensity magnified by 1 / cos(phi), which keeps the
    // ghost the size its rays give it and adds only the fringes. Fresnel propagation keeps the energy.
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            const fftw_complex& v = field[static_cast<std::size_t>(j + n / 2) * static_cast<std::size_t>(m) +
                                          static_cast<std::size_t>(i + n / 2)];
            out[static_cast<std::size_t>(j) * static_cast<std::size_t>(n) + static_cast<std::size_t>(i)] =
                static_cast<float>(v[0] * v[0] + v[1] * v[1]);
        }
    }
    return out;
}

std::vector<float> ringing_aperture(const Aperture& aperture, int n, double extent, double alpha) {
    if (n < 8 || n > 8192) throw std::invalid_argument(fmt::format("ringing texture size {} outside 8..8192", n));
    // The iris at texel centres.
    const double h = 2.0 * extent / n;
    std::vector<double> t(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i)
            t[static_cast<std::size_t>(j) * static_cast<std::size_t>(n) + static_cast<std::size_t>(i)] =
                aperture_coverage(aperture, (i - n / 2 + 0.5) * h, (n / 2 - j - 0.5) * h, h);
    return fractional_ringing(t, n, extent, alpha);
}

}  // namespace lensfx::optics
