// Anti-reflection coatings as thin-film stacks: the reflectance and transmittance of a coated interface
// at any wavelength and angle, for unpolarised light (s and p averaged). Single layers use the closed-form
// two-interface (Airy) formula; general stacks the characteristic (transfer) matrix method with complex
// amplitudes (Macleod, "Thin-Film Optical Filters", ch. 2). Layers are lossless (real indices).
#pragma once

#include <span>
#include <vector>

#include <optics/fresnel.h>
#include <optics/lens.h>

namespace lensfx::optics {

// One homogeneous layer at one wavelength.
struct FilmLayer {
    double index = 1.38;
    double thickness_nm = 0.0;
};

// A Coating evaluated at one wavelength: its layers (object side first) with their indices at that
// wavelength. Kind::None gives no layers. Kind::QuarterWave gives one layer of index layer_index (taken as
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
