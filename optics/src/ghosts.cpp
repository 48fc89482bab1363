#include <optics/ghosts.h>

#include <optics/paraxial.h>

#include <algorithm>
#include <optional>

namespace lensfx::optics {

std::vector<int> reflecting_interfaces(const System& system) {
    std::vector<int> out;
    for (std::size_t i = 0; i < system.interfaces.size(); ++i) {
        const auto& s = system.interfaces[i];
        if (s.is_stop) continue;
        if (s.coating.kind == Coating::Kind::None && same_medium(s.before, s.after)) continue;
        out.push_back(static_cast<int>(i));
    }
    return out;
}

namespace {

// Reflecting interfaces in front of / behind the stop (all in front when there is no stop).
bool in_front_of_stop(const System& system, int i) { return system.stop < 0 || i < system.stop; }

}  // namespace

std::vector<Ghost> enumerate_ghosts(const System& system, const GhostOptions& options) {
    const auto refl = reflecting_interfaces(system);
    const int n = static_cast<int>(system.interfaces.size());
    std::vector<Ghost> ghosts;
    ghosts.reserve(refl.size() * (refl.size() > 0 ? refl.size() - 1 : 0) / 2);
    for (std::size_t a = 0; a < refl.size(); ++a) {
        const int j = refl[a];
        for (std::size_t b = 0; b < a; ++b) {
            const int i = refl[b];
            const bool three = system.stop >= 0 && in_front_of_stop(system, i) && !in_front_of_stop(system, j);
            if (options.aperture_culling && three) continue;
            Ghost g;
            g.first = j;
            g.second = i;
            g.crosses_stop_three_times = three;
            g.path.reserve(static_cast<std::size_t>(n + 2 * (j - i)));
            for (int k = 0; k < j; ++k) g.path.push_back({k, false, true});
            g.path.push_back({j, true, true});
            for (int k = j - 1; k > i; --k) g.path.push_back({k, false, false});
            g.path.push_back({i, true, false});
            for (int k = i + 1; k < n; ++k) g.path.push_back({k, false, true});
            ghosts.push_back(std::move(g));
        }
    }
    return ghosts;
}

std::size_t ghost_count(const System& system, const GhostOptions& options) {
    if (!options.aperture_culling) {
        const std::size_t r = reflecting_interfaces(system).size();
        return r * (r > 0 ? r - 1 : 0) / 2;
    }
    std::size_t f = 0, b = 0;
    for (int i : reflecting_interfaces(system)) (in_front_of_stop(system, i) ? f : b) += 1;
    return (f * (f > 0 ? f - 1 : 0) + b * (b > 0 ? b - 1 : 0)) / 2;
}

double ghost_axial_factor(const TraceSystem& system, const Ghost& ghost) {
    const auto& ifs = system.interfaces();
    double factor = 1.0;
    for (const Step& st : ghost.path) {
        if (st.interface < 0 || st.interface >= static_cast<int>(ifs.size())) return 0.0;
        const auto& s = ifs[st.interface];
        if (s.is_stop) continue;
        const double n1 = st.forward ? s.n_before : s.n_after;
        const double n2 = st.forward ? s.n_after : s.n_before;
        const Reflectance rt = coated_reflectance(s.coating, n1, n2, 1.0, system.wavelength_nm(), st.forward);
        factor *= st.reflect ? rt.R : rt.T;
    }
    return factor;
}

std::vector<GhostImaging> ghost_imaging(const System& system, const std::vector<Ghost>& ghosts, double wavelength_nm) {
    const TraceSystem traced(system, wavelength_nm);
    const Paraxial first_order = paraxial(system, wavelength_nm);
    const double pupil_z = system.interfaces.front().z_mm + first_order.entrance_pupil_mm;
    const double pupil_radius = 0.5 * first_order.entrance_pupil_diameter_mm;
    // Small enough to stay first order, large enough to stay clear of rounding.
    const double angle_deg = 0.02;
    const double height = 1e-3 * pupil_radius;
    // Sensor x of the ray through the entrance pupil at (x, 0) from a light at angle ax; nullopt if it fails.
    auto landing = [&](std::span<const Step> path, double ax, double x) -> std::optional<double> {
        const TraceResult r = trace(traced, collimated_ray(ax, 0.0, x, 0.0, pupil_z), path);
        if (!r.ok()) return std::nullopt;
        return r.position.x;
    };
    const std::vector<Step> direct = direct_path(system);
    const auto d0 = landing(direct, -angle_deg, 0.0);
    const auto d1 = landing(direct, angle_deg, 0.0);
    const double direct_shift = d0 && d1 ? *d1 - *d0 : 0.0;
    std::vector<GhostImaging> out(ghosts.size());
    for (std::size_t g = 0; g < ghosts.size(); ++g) {
        const auto c0 = landing(ghosts[g].path, -angle_deg, 0.0);
        const auto c1 = landing(ghosts[g].path, angle_deg, 0.0);
        const auto lo = landing(ghosts[g].path, 0.0, -height);
        const auto hi = landing(ghosts[g].path, 0.0, height);
        if (!c0 || !c1 || !lo || !hi || direct_shift == 0.0) continue;
        out[g].magnification = (*c1 - *c0) / direct_shift;
        out[g].blur_mm = std::abs(*hi - *lo) / (2.0 * height) * 2.0 * pupil_radius;
    }
    return out;
}

}  // namespace lensfx::optics
