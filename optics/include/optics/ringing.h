// Ghost ringing (flare paper section 3.3, eq. 5): a ghost is an image of the iris part way between the
// spatial and the Fourier domain, which the fractional Fourier transform of order alpha models. The
// aperture texture that shades ghosts becomes the FrFT's intensity, with fringes along the iris edge.
#pragma once

#include <vector>

#include <optics/lens.h>

namespace lensfx::optics {

// Eq. 5: alpha = 0.15 (lambda / 400 nm) (N / 18); longer wavelengths and smaller apertures ring more.
double ringing_order(double wavelength_nm, double f_number);

// Intensity of the order-alpha FrFT (0 <= alpha < 0.5; 0 = the transmission itself) of a square
// transmission grid of n x n samples spanning [-extent, extent]^2 stop radii at texel centres, row 0 at
// the top. Dimensionless FrFT coordinates take the grid's own scale, s^2 = (2 extent)^2 / n, so a grid
// of the GPU's iris texture size fixes the look. Computed as the equivalent Fresnel propagation (angular
// spectrum, FFTW, 2x padding) and returned at the input's scale, i.e. the FrFT magnified by
// 1 / cos(alpha pi / 2), so a ghost keeps the size its rays give it and gains only the fringes. Energy is
// kept: the sum equals the input's sum of squares.
std::vector<float> fractional_ringing(const std::vector<double>& transmission, int n, double extent, double alpha);

// The iris (aperture.h) as an n x n transmission texture over [-extent, extent]^2 with its ringing at
// order alpha: what the GPU shades ghosts with in the high quality mode.
std::vector<float> ringing_aperture(const Aperture& aperture, int n, double extent, double alpha);

}  // namespace lensfx::optics
