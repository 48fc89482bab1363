#include <optics/ghosts.h>

#include <algorithm>

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

}  // namespace lensfx::optics
