// Optical media: refractive index as a function of wavelength, from the Sellmeier catalog
// (optics/data/glass.csv, refractiveindex.info, CC0), explicit coefficients, or an nd/Vd model.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lensfx::optics {

struct Glass {
    // Constant: n = nd at every wavelength (air, or a glass without dispersion).
    // Sellmeier: n^2 = 1 + sum B_i l^2 / (l^2 - C_i), l in um; coefficients = B1, C1, B2, C2, B3, C3 ...
    //   (an odd count means a leading constant A: n^2 = 1 + A + sum ..., refractiveindex.info formula 2).
    // Polynomial: n^2 = c0 + sum c_i l^e_i, l in um; coefficients = c0, c1, e1, c2, e2, ...
    //   (refractiveindex.info formula 3).
    // Abbe: only nd and vd known; a normal-line two-term Sellmeier fitted to nd and Vd, see
    //   glass_from_abbe (coefficients then hold its B1, C1, B2, C2).
    enum class Formula { Constant, Sellmeier, Polynomial, Abbe };

    std::string name = "air";
    Formula formula = Formula::Constant;
    std::vector<double> coefficients;
    double nd = 1.0;
    double vd = 0.0;
    std::string catalog;  // maker the data came from ("schott", "ohara", ...); empty when not from the catalog

    static Glass air() { return {}; }
    bool is_air() const { return formula == Formula::Constant && nd == 1.0; }
    double index(double wavelength_nm) const;  // valid 360-830 nm (and beyond, extrapolated)
};

// Same optical medium: equal formula, coefficients, nd and vd (names and makers ignored).
bool same_medium(const Glass& a, const Glass& b);

// Fraunhofer lines used for nd and Vd = (nd - 1) / (nF - nC), nm.
inline constexpr double kLineD_nm = 587.5618;
inline constexpr double kLineF_nm = 486.1327;
inline constexpr double kLineC_nm = 656.2725;

// The catalog makers in the order catalog_glass prefers them when a name occurs under several.
inline constexpr const char* kCatalogMakers[] = {"schott", "ohara", "hikari", "hoya", "cdgm", "sumita"};

// A catalog glass by name ("N-BK7", "schott:N-BK7", case-insensitive, surrounding spaces ignored), or
// nullopt. Without a maker prefix a name found under several makers resolves in kCatalogMakers order.
// The catalog (optics/data/glass.csv, from refractiveindex.info, CC0) is compiled into the library.
std::optional<Glass> catalog_glass(std::string_view name);
// Every catalog glass as "maker:NAME", in catalog order.
std::vector<std::string> catalog_glass_names();

// A glass known only by nd and Vd: n^2 = 1 + B1 l^2/(l^2 - C1) + B2 l^2/(l^2 - C2), l in um, with the
// infrared resonance fixed at C2 = 100 um^2 (close to common glasses') and B1, C1, B2 solved so that
// n(587.56 nm) = nd, (nd - 1)/(nF - nC) = vd and the partial dispersion P_g,F = (ng - nF)/(nF - nC) lies
// on Schott's normal line 0.6438 - 0.001682 vd (so the curve bends like a normal glass' below 486 nm).
// Where that has no solution with the UV resonance below 360 nm, B2 = 1 and only nd, vd are matched.
// Over the 1,609 catalog glasses the model is within 2.8e-4 of the makers' formulas (median of the
// largest error over 400-700 nm; 90th percentile 1.4e-3, worst 1.3e-2, anomalous-dispersion glasses).
// Throws std::invalid_argument (naming the glass) when nd <= 1, vd <= 0 or no model exists.
Glass glass_from_abbe(double nd, double vd, std::string name = {});

}  // namespace lensfx::optics
