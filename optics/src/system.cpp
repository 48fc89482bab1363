// Realisation of a Lens: zoom interpolation, layout along +z, stop radius from the f-number, sensor at focus.
#include <optics/system.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <string>

#include <fmt/core.h>

#include <optics/paraxial.h>

namespace lensfx::optics {

namespace {
// How far below the widest f-number an asked one may be and still mean it (the entrance pupil's radius, relative):
// marked f-numbers are rounded to two figures (f/2 for f/2.03, f/2.8 for 2.83).
constexpr double kMarkedRounding = 0.03;
}  // namespace

std::vector<double> thicknesses_at(const Lens& lens, double zoom) {
    if (!std::isfinite(zoom) || zoom < 0.0 || zoom > 1.0)
        throw std::invalid_argument(fmt::format("lens '{}': zoom {} is outside [0, 1]", lens.name, zoom));
    std::vector<double> out;
    out.reserve(lens.surfaces.size());
    for (const auto& s : lens.surfaces) {
        const auto& t = s.thickness_mm;
        if (t.empty()) {
            out.push_back(0.0);
        } else if (t.size() == 1) {
            out.push_back(t[0]);
        } else {
            const double x = zoom * static_cast<double>(t.size() - 1);
            const auto k = std::min(static_cast<std::size_t>(x), t.size() - 2);
            const double f = x - static_cast<double>(k);
            out.push_back(t[k] + f * (t[k + 1] - t[k]));
        }
    }
    return out;
}

double zoom_for_label(const Lens& lens, double label) {
    const auto& l = lens.zoom_focal_labels;
    if (l.size() < 2)
        throw std::invalid_argument(fmt::format("lens '{}' has no zoom labels; give --zoom as a number in [0, 1]", lens.name));
    const bool rising = l.back() > l.front();
    for (std::size_t k = 0; k + 1 < l.size(); ++k) {
        const double lo = l[k], hi = l[k + 1];
        if ((rising && label >= lo && label <= hi) || (!rising && label <= lo && label >= hi))
            return (static_cast<double>(k) + (label - lo) / (hi - lo)) / static_cast<double>(l.size() - 1);
    }
    throw std::invalid_argument(fmt::format("lens '{}': focal length {} mm is outside its zoom range {}-{} mm",
                                            lens.name, label, l.front(), l.back()));
}

double parse_zoom(const Lens& lens, std::string_view text) {
    std::string s(text);
    bool label = false;
    if (s.size() > 2 && s.ends_with("mm")) {
        s.resize(s.size() - 2);
        label = true;
    }
    double v = 0.0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc{} || end != s.data() + s.size() || !std::isfinite(v))
        throw std::invalid_argument(fmt::format("--zoom '{}': expected a number in [0, 1] or a focal length like 135mm", text));
    if (label) return zoom_for_label(lens, v);
    if (v < 0.0 || v > 1.0)
        throw std::invalid_argument(fmt::format("--zoom {}: the zoom parameter runs from 0 to 1 (or give a focal length like 135mm)", text));
    return v;
}

System with_entrance_pupil_diameter(System system, double epd_mm, double wavelength_nm) {
    system.interfaces.at(static_cast<std::size_t>(system.stop)).semi_diameter_mm =
        stop_radius_for_epd(system, epd_mm, wavelength_nm);
    return system;
}

System realize(const Lens& lens, double zoom, std::optional<double> f_number) {
    const int stop = lens.stop_index();
    if (stop < 0) throw std::invalid_argument(fmt::format("lens '{}': no aperture stop", lens.name));
    if (lens.surfaces.empty()) throw std::invalid_argument(fmt::format("lens '{}': no surfaces", lens.name));
    const auto t = thicknesses_at(lens, zoom);

    System sys;
    sys.name = lens.name;
    sys.aperture = lens.aperture;
    sys.stop = stop;
    double z = 0.0;
    Glass before = Glass::air();
    for (std::size_t i = 0; i < lens.surfaces.size(); ++i) {
        const auto& s = lens.surfaces[i];
        System::Interface f{s.radius_mm, z, s.semi_diameter_mm, before, s.is_stop ? before : s.medium,
                            s.coating, s.is_stop, s.conic, s.aspheric};
        if (s.is_stop) f.radius_mm = 0.0;
        before = f.after;
        sys.interfaces.push_back(std::move(f));
        if (i + 1 < lens.surfaces.size()) z += t[i];
    }
    if (!before.is_air())
        throw std::invalid_argument(fmt::format("lens '{}': the last surface leaves the light in '{}', not air", lens.name, before.name));

    if (f_number) {
        if (!(*f_number > 0.0) || !std::isfinite(*f_number))
            throw std::invalid_argument(fmt::format("lens '{}': f-number {} must be positive", lens.name, *f_number));
        const Paraxial open = paraxial(sys, kLambdaD_nm);
        const double radius = stop_radius_for_epd(sys, std::abs(open.efl_mm) / *f_number, kLambdaD_nm);
        const double clear = sys.interfaces[static_cast<std::size_t>(stop)].semi_diameter_mm;
        // A marked f-number is rounded (f/2 for f/2.03): one within kMarkedRounding of the widest is taken wide open.
        if (radius > clear * (1.0 + kMarkedRounding))
            throw std::invalid_argument(fmt::format("lens '{}': f/{:g} is wider than its stop allows (f/{:.3g} at this zoom)",
                                                    lens.name, *f_number, open.f_number));
        sys.interfaces[static_cast<std::size_t>(stop)].semi_diameter_mm = std::min(radius, clear);
    }

    const double last_z = sys.interfaces.back().z_mm;
    sys.sensor_z_mm = lens.sensor_as_written ? last_z + t.back() : last_z + paraxial(sys, kLambdaD_nm).bfl_mm;
    return sys;
}

}  // namespace lensfx::optics
