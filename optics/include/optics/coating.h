// Anti-reflection coatings as thin-film stacks: the reflectance and transmittance of a coated interface
// at any wavelength and angle, for unpolarised light (s and p averaged). Single layers use the closed-form
// two-interface (Airy) formula; general stacks the characteristic (transfer) matrix method with complex
// amplitudes (Macleod, "Thin-Film Optical Filters", ch. 2). Layers are lossless (real indices).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include <optics/fresnel.h>
#include <optics/lens.h>

namespace lensfx::optics {

// One homogeneous layer at one wavelength.
struct FilmLayer {
    double index = 1.38;
    double thickness_nm = 0.0;
};

// The standard designs of Coating::Kind::Design, in quarter-wave optical thicknesses (QWOT) at the design
// wavelength, listed from the air side (Macleod, "Thin-Film Optical Filters", ch. 4; layer materials
// non-dispersive: L = MgF2 1.38, H = ZrO2 2.05, M = CeF3 / Al2O3 mixtures 1.63 on n = 1.52 glass):
// - VCoat: two layers L, H with the thicknesses that make R = 0 at the design wavelength on the glass
//   they sit on (closed form); a V-shaped curve, strongly coloured away from its minimum.
// - QuarterHalfQuarter: L 1, H 2, M 1, M's index scaled to the glass (1.63 sqrt(n / 1.52)), the classic
//   broadband W curve (under 0.5% over 450-650 nm on N-BK7 at 550 nm).
// - Broadband4: L 0.96, H 1.96, then a thin L, H pair that matches the glass (0.32, 0.20 QWOT on 1.52,
//   thinner on denser glass): under 0.3% over 420-680 nm on N-BK7, purple-red at the ends.
inline constexpr double kLowIndex = 1.38;
inline constexpr double kHighIndex = 2.05;
inline constexpr double kMediumIndex = 1.63;

// A design's layers (index, physical thickness) from the air side, for glass of index n_glass and air
// n_air at the design wavelength. Throws std::invalid_argument when the design has no solution there.
std::vector<FilmLayer> design_layers(Coating::Design design, double design_wavelength_nm, double n_air, double n_glass);

// Named designs as the lens files and the command line spell them: "v-coat", "broadband-3"
// (quarter-half-quarter), "broadband-4"; nullopt for any other name.
std::optional<Coating::Design> parse_design(std::string_view name);
const char* design_name(Coating::Design design);

// `--coating`: what every air-glass interface gets. Uncoated: nothing; Single: one MgF2 quarter wave at
// 550 nm (1950s-70s); Multi: the four-layer broadband at 550 nm (since the 1970s); Lens: what the lens
// file says (each preset's is reasoned in its file).
enum class CoatingChoice { Uncoated, Single, Multi, Lens };
CoatingChoice parse_coating_choice(std::string_view text);  // also "none" = uncoated; throws naming the value

// Sets the coatings of a system's air-glass interfaces by `choice`, then gives every layer of every coated
// interface a relative thickness error drawn from a normal distribution of standard deviation `spread`
// (0: exact), seeded by `seed` and the interface's index, so the same lens looks the same on every run.
void choose_coatings(System& system, CoatingChoice choice, double spread, std::uint64_t seed = 1);

// A Coating evaluated at one wavelength: its layers (object side first) with their indices at that
// wavelength. Kind::None gives no layers. Kind::Design: design_layers on the glass side. Every kind's
// layers are scaled by their layer_errors. Kind::QuarterWave gives one layer of index layer_index (taken as
// non-dispersive, as MgF2 nearly is; layer_index <= 0 means the ideal sqrt(n_before * n_after) of the two
// media at the design wavelength, as in the Stingray notes) and physical thickness
// design_wavelength / (4 * index) * (1 + thickness_offset), a quarter wave at normal incidence.
// Building one allocates; evaluating it does not.
struct ResolvedCoating {
    std::vector<FilmLayer> layers;
};
ResolvedCoating resolve_coating(const Coating& coating, const Glass& before, const Glass& after,
                                double wavelength_nm);

// Light travelling in medium n_in hits the coated interface towards medium n_out at cos_i (in medium
// n_in). from_object_side tells whether it arrives from the object side (layers traversed in listed
// order) or from the sensor side (reversed order); n_in / n_out are then the before / after media or the
// reverse. No layers: bare Fresnel. Never NaN; R + T = 1 to rounding (lossless layers).
Reflectance coated_reflectance(const ResolvedCoating& coating, double n_in, double n_out, double cos_i,
                               double wavelength_nm, bool from_object_side);

// The characteristic-matrix method for an arbitrary stack, layers listed from the incident side.
// T is computed from the transmitted amplitude (not as 1 - R), so R + T = 1 checks energy conservation.
Reflectance multilayer_reflectance(std::span<const FilmLayer> layers, double n_in, double n_out,
                                   double cos_i, double wavelength_nm);

// Closed-form single-layer thin film (two interfaces, all multiple reflections summed), for cross-checks
// and as the fast path of coated_reflectance.
Reflectance single_layer_reflectance(const FilmLayer& layer, double n_in, double n_out, double cos_i,
                                     double wavelength_nm);

}  // namespace lensfx::optics
