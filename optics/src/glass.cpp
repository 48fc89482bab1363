#include <optics/glass.h>

#include <algorithm>
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

// Abbe-model coefficients for a given C1: B1 from nd, the rest fixed.
double abbe_b1(double nd, double c1) {
    const double l2 = (kLineD_nm * 1e-3) * (kLineD_nm * 1e-3);
    const double ir = kAbbeB2 * l2 / (l2 - kAbbeC2);
    return (nd * nd - 1.0 - ir) * (l2 - c1) / l2;
}

double abbe_vd(double nd, double c1) {
    const std::vector<double> c{abbe_b1(nd, c1), c1, kAbbeB2, kAbbeC2};
    auto n = [&](double nm) { return std::sqrt(sellmeier_n2(c, nm * nm * 1e-6)); };
    return (nd - 1.0) / (n(kLineF_nm) - n(kLineC_nm));
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
    // Vd falls monotonically as the UV resonance C1 moves towards the visible: bisect on C1.
    double lo = 0.0;
    double hi = kAbbeC1Max;
    const double vd_lo = abbe_vd(nd, lo);
    const double vd_hi = abbe_vd(nd, hi);
    if (!(vd <= vd_lo && vd >= vd_hi))
        throw std::invalid_argument(fmt::format(
            "glass '{}': no dispersion model for nd={} vd={} (this nd allows vd from {:.2f} to {:.2f})", name, nd,
            vd, vd_hi, vd_lo));
    for (int it = 0; it < 200 && hi - lo > 1e-17; ++it) {
        const double mid = 0.5 * (lo + hi);
        (abbe_vd(nd, mid) > vd ? lo : hi) = mid;
    }
    const double c1 = 0.5 * (lo + hi);
    Glass g;
    g.name = std::move(name);
    g.formula = Glass::Formula::Abbe;
    g.nd = nd;
    g.vd = vd;
    g.coefficients = {abbe_b1(nd, c1), c1, kAbbeB2, kAbbeC2};
    return g;
}

}  // namespace lensfx::optics
