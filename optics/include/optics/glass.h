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
    // Polynomial: n^2 = c0 + sum c_i l^e_i, l in um; coefficients = c0, c1, e1, c2, e2, ...
    // Abbe: only nd and vd known; the dispersion model documented in glass.cpp.
    enum class Formula { Constant, Sellmeier, Polynomial, Abbe };

    std::string name = "air";
    Formula formula = Formula::Constant;
    std::vector<double> coefficients;
    double nd = 1.0;
    double vd = 0.0;

    static Glass air() { return {}; }
    bool is_air() const { return formula == Formula::Constant && nd == 1.0; }
    double index(double wavelength_nm) const;  // valid 360-830 nm (and beyond, extrapolated)
};

// A catalog glass by name ("N-BK7", "schott:N-BK7", case-insensitive), or nullopt.
std::optional<Glass> catalog_glass(std::string_view name);
Glass glass_from_abbe(double nd, double vd, std::string name = {});

}  // namespace lensfx::optics
