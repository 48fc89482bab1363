#include <optics/glass.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "glass_catalog.h"

namespace lensfx::optics {

namespace {

constexpr double kAbbeC2 = 100.0;  // um^2, infrared resonance of the nd/Vd model
constexpr double kAbbeB2 = 1.0;
constexpr double kAbbeC1Max = 0.125;  // um^2, keeps the UV resonance below 360 nm (0.1296 um^2)

double sellmeier_n2(const std::vector<double>& c, double l2) {
    double n2 = 1.0;
    std::size_t i = 0;
    if (c.size() % 2 == 1) n2 += c[i++];
    for (; i + 1 < c.size(); i += 2) n2 += c[i] * l2 / (l2 - c[i + 1]);
    return n2;
}

double polynomial_n2(const std::vector<double>& c, double l) {
    if (c.empty()) return 1.0;
    double n2 = c[0];
    for (std::size_t i = 1; i + 1 < c.size(); i += 2) n2 += c[i] * std::pow(l, c[i + 1]);
    return n2;
}

std::string lower(std::string_view s) {
    std::string out(s);
    for (auto& ch : out) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return out;
}

bool iequals(std::string_view a, std::string_view b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
               return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
           });
}

std::string_view trim(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
}

Glass from_entry(const detail::CatalogEntry& e) {
    Glass g;
    g.name = e.name;
    g.catalog = e.maker;
    g.nd = e.nd;
    g.vd = e.vd;
    if (e.formula == 2) {
        g.formula = Glass::Formula::Sellmeier;
        if (e.c[0] != 0.0) g.coefficients.push_back(e.c[0]);
        g.coefficients.insert(g.coefficients.end(), e.c + 1, e.c + 7);
    } else {
        g.formula = Glass::Formula::Polynomial;
        g.coefficients.assign(e.c, e.c + 7);
        g.coefficients.insert(g.coefficients.end(), e.extra, e.extra + e.extra_count);
    }
    return g;
}

constexpr double kLineG_nm = 435.8343;

// Schott's "normal line" of the relative partial dispersion P_g,F = (ng - nF) / (nF - nC) of normal glasses.
double normal_line_pgf(double vd) { return 0.6438 - 0.001682 * vd; }

double abbe_n(const std::array<double, 4>& c, double nm) {
    const double l2 = nm * nm * 1e-6;
    return std::sqrt(1.0 + c[0] * l2 / (l2 - c[1]) + c[2] * l2 / (l2 - c[3]));
}

// Model coefficients B1, C1, B2, C2 for given C1 and B2, with B1 set so that n(d) = nd.
std::array<double, 4> abbe_coefficients(double nd, double c1, double b2) {
    const double l2 = (kLineD_nm * 1e-3) * (kLineD_nm * 1e-3);
    const double b1 = (nd * nd - 1.0 - b2 * l2 / (l2 - kAbbeC2)) * (l2 - c1) / l2;
    return {b1, c1, b2, kAbbeC2};
}

struct AbbeFit {
    double vd, pgf;
};
AbbeFit abbe_properties(double nd, double c1, double b2) {
    const auto c = abbe_coefficients(nd, c1, b2);
    const double nf = abbe_n(c, kLineF_nm);
    const double nc = abbe_n(c, kLineC_nm);
    return {(nd - 1.0) / (nf - nc), (abbe_n(c, kLineG_nm) - nf) / (nf - nc)};
}

// Newton on (C1, B2) for Vd and the normal-line P_g,F; false when it leaves the valid region or stalls.
bool fit_normal_line(double nd, double vd, double& c1, double& b2) {
    const double pgf = normal_line_pgf(vd);
    c1 = 0.01;
    b2 = kAbbeB2;
    for (int it = 0; it < 60; ++it) {
        const AbbeFit r = abbe_properties(nd, c1, b2);
        const double f1 = r.vd - vd;
        const double f2 = r.pgf - pgf;
        if (std::abs(f1) < 1e-11 * vd && std::abs(f2) < 1e-12) return true;
        const double h1 = 1e-7, h2 = 1e-6;
        const AbbeFit a = abbe_properties(nd, c1 + h1, b2);
        const AbbeFit b = abbe_properties(nd, c1, b2 + h2);
        const double j11 = (a.vd - r.vd) / h1, j12 = (b.vd - r.vd) / h2;
        const double j21 = (a.pgf - r.pgf) / h1, j22 = (b.pgf - r.pgf) / h2;
        const double det = j11 * j22 - j12 * j21;
        if (!std::isfinite(det) || det == 0.0) return false;
        c1 -= (f1 * j22 - f2 * j12) / det;
        b2 -= (j11 * f2 - j21 * f1) / det;
        if (!(c1 > 0.0 && c1 < kAbbeC1Max) || !std::isfinite(b2)) return false;
    }
    return false;
}

}  // namespace

double Glass::index(double wavelength_nm) const {
    const double l = wavelength_nm * 1e-3;
    double n2 = 1.0;
    switch (formula) {
        case Formula::Constant: return nd;
        case Formula::Sellmeier:
        case Formula::Abbe: n2 = sellmeier_n2(coefficients, l * l); break;
        case Formula::Polynomial: n2 = polynomial_n2(coefficients, l); break;
    }
    if (!(n2 > 0.0) || !std::isfinite(n2))
        throw std::domain_error(fmt::format("glass '{}': no refractive index at {} nm (n^2 = {})", name,
                                            wavelength_nm, n2));
    return std::sqrt(n2);
}

bool same_medium(const Glass& a, const Glass& b) {
    return a.formula == b.formula && a.coefficients == b.coefficients && a.nd == b.nd &&
           (a.formula == Glass::Formula::Constant || a.vd == b.vd);
}

std::optional<Glass> catalog_glass(std::string_view name) {
    name = trim(name);
    std::string_view maker;
    if (const auto colon = name.find(':'); colon != std::string_view::npos) {
        maker = trim(name.substr(0, colon));
        name = trim(name.substr(colon + 1));
    }
    const detail::CatalogEntry* best = nullptr;
    std::size_t best_rank = std::size(kCatalogMakers);
    for (std::size_t i = 0; i < detail::kGlassCatalogSize; ++i) {
        const auto& e = detail::kGlassCatalog[i];
        if (!iequals(e.name, name)) continue;
        if (!maker.empty()) {
            if (iequals(e.maker, maker)) return from_entry(e);
            continue;
        }
        std::size_t rank = 0;
        while (rank < std::size(kCatalogMakers) && lower(e.maker) != kCatalogMakers[rank]) ++rank;
        if (best == nullptr || rank < best_rank) {
            best = &e;
            best_rank = rank;
        }
    }
    if (best == nullptr) return std::nullopt;
    return from_entry(*best);
}

std::vector<std::string> catalog_glass_names() {
    std::vector<std::string> names;
    names.reserve(detail::kGlassCatalogSize);
    for (std::size_t i = 0; i < detail::kGlassCatalogSize; ++i)
        names.push_back(fmt::format("{}:{}", detail::kGlassCatalog[i].maker, detail::kGlassCatalog[i].name));
    return names;
}

Glass glass_from_abbe(double nd, double vd, std::string name) {
    if (name.empty()) name = fmt::format("nd={} vd={}", nd, vd);
    if (!(nd > 1.0) || !(vd > 0.0) || !std::isfinite(nd) || !std::isfinite(vd))
        throw std::invalid_argument(fmt::format("glass '{}': nd must be > 1 and vd > 0 (nd={}, vd={})", name, nd, vd));
    double c1 = 0.0, b2 = kAbbeB2;
    if (!fit_normal_line(nd, vd, c1, b2)) {
        // Fallback: B2 fixed; Vd falls monotonically as C1 moves towards the visible, so bisect on C1.
        b2 = kAbbeB2;
        double lo = 0.0, hi = kAbbeC1Max;
        const double vd_lo = abbe_properties(nd, lo, b2).vd;
        const double vd_hi = abbe_properties(nd, hi, b2).vd;
        if (!(vd <= vd_lo && vd >= vd_hi))
            throw std::invalid_argument(fmt::format(
                "glass '{}': no dispersion model for nd={} vd={} (this nd allows vd from {:.2f} to {:.2f})", name,
                nd, vd, vd_hi, vd_lo));
        for (int it = 0; it < 200 && hi - lo > 1e-17; ++it) {
            const double mid = 0.5 * (lo + hi);
            (abbe_properties(nd, mid, b2).vd > vd ? lo : hi) = mid;
        }
        c1 = 0.5 * (lo + hi);
    }
    const auto c = abbe_coefficients(nd, c1, b2);
    Glass g;
    g.name = std::move(name);
    g.formula = Glass::Formula::Abbe;
    g.nd = nd;
    g.vd = vd;
    g.coefficients.assign(c.begin(), c.end());
    return g;
}

}  // namespace lensfx::optics
