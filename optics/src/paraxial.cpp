// Paraxial analysis by 2x2 ray-transfer matrices acting on (y, n u): refraction [1 0; -phi 1] with
// phi = (n' - n) / R, transfer [1 t/n; 0 1].
#include <optics/paraxial.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <fmt/core.h>

namespace lensfx::optics {
namespace {

struct Matrix {
    double a = 1, b = 0, c = 0, d = 1;
    Matrix then(const Matrix& m) const {  // m applied after *this
        return {m.a * a + m.b * c, m.a * b + m.b * d, m.c * a + m.d * c, m.c * b + m.d * d};
    }
};

Matrix refraction(const System::Interface& s, double wavelength_nm) {
    if (s.radius_mm == 0.0 || s.is_stop) return {};
    const double phi = (s.after.index(wavelength_nm) - s.before.index(wavelength_nm)) / s.radius_mm;
    return {1, 0, -phi, 1};
}

// Interfaces [first, last] refracted, with the transfers between them (none after `last`).
Matrix span(const System& sys, std::size_t first, std::size_t last, double wavelength_nm) {
    Matrix m;
    for (std::size_t i = first; i <= last; ++i) {
        if (i > first) {
            const auto& prev = sys.interfaces[i - 1];
            const double t = sys.interfaces[i].z_mm - prev.z_mm;
            m = m.then({1, t / prev.after.index(wavelength_nm), 0, 1});
        }
        m = m.then(refraction(sys.interfaces[i], wavelength_nm));
    }
    return m;
}

void require_stop(const System& sys) {
    if (sys.interfaces.empty()) throw std::invalid_argument(fmt::format("lens '{}': no surfaces", sys.name));
    if (sys.stop < 0 || sys.stop >= static_cast<int>(sys.interfaces.size()))
        throw std::invalid_argument(fmt::format("lens '{}': no aperture stop", sys.name));
}

}  // namespace

double stop_radius_for_epd(const System& sys, double epd_mm, double wavelength_nm) {
    require_stop(sys);
    // A ray parallel to the axis at height h reaches the stop at height a * h.
    const Matrix front = span(sys, 0, static_cast<std::size_t>(sys.stop), wavelength_nm);
    return 0.5 * epd_mm * std::abs(front.a);
}

Paraxial paraxial(const System& sys, double wavelength_nm) {
    require_stop(sys);
    const std::size_t last = sys.interfaces.size() - 1;
    const auto stop = static_cast<std::size_t>(sys.stop);
    const double n_object = sys.interfaces.front().before.index(wavelength_nm);
    const double n_image = sys.interfaces.back().after.index(wavelength_nm);

    const Matrix whole = span(sys, 0, last, wavelength_nm);
    const double power = -whole.c;
    if (std::abs(power) < 1e-12)
        throw std::invalid_argument(fmt::format("lens '{}': afocal at {} nm (no paraxial power)", sys.name, wavelength_nm));

    Paraxial p;
    p.wavelength_nm = wavelength_nm;
    p.efl_mm = 1.0 / power;
    p.bfl_mm = n_image * whole.a / power;
    p.ffl_mm = -n_object * whole.d / power;

    // Entrance pupil: the stop seen through the interfaces before it. A ray aimed at the stop centre
    // (y_stop = a y0 + b nu0 = 0) crosses the axis in object space at z = n b / a.
    const Matrix front = span(sys, 0, stop, wavelength_nm);
    const double stop_radius = sys.interfaces[stop].semi_diameter_mm;
    if (std::abs(front.a) < 1e-15)
        throw std::invalid_argument(fmt::format("lens '{}': the stop is imaged to infinity in object space", sys.name));
    p.entrance_pupil_mm = n_object * front.b / front.a;
    p.entrance_pupil_diameter_mm = 2.0 * stop_radius / std::abs(front.a);
    p.f_number = std::abs(p.efl_mm) / p.entrance_pupil_diameter_mm;

    // Exit pupil: the stop seen through the interfaces after it, from the image side.
    Matrix rear;
    if (stop < last) {
        const double t = sys.interfaces[stop + 1].z_mm - sys.interfaces[stop].z_mm;
        rear = Matrix{1, t / sys.interfaces[stop].after.index(wavelength_nm), 0, 1}.then(span(sys, stop + 1, last, wavelength_nm));
    }
    const double d = rear.d;
    p.exit_pupil_mm = std::abs(d) < 1e-15 ? std::numeric_limits<double>::infinity() : -n_image * rear.b / d;
    // The marginal ray of the entrance pupil, carried to the exit pupil plane.
    const double h = 0.5 * p.entrance_pupil_diameter_mm;
    const double y_last = whole.a * h, nu_last = whole.c * h;
    p.exit_pupil_diameter_mm = std::isfinite(p.exit_pupil_mm)
                                   ? 2.0 * std::abs(y_last + p.exit_pupil_mm * nu_last / n_image)
                                   : std::numeric_limits<double>::infinity();
    return p;
}

FieldOfView field_of_view(const Paraxial& p, double w, double h) {
    const double f = std::abs(p.efl_mm);
    const auto full = [f](double size) { return 2.0 * std::atan(0.5 * size / f) * 180.0 / std::numbers::pi; };
    return {full(w), full(h), full(std::hypot(w, h))};
}

}  // namespace lensfx::optics
