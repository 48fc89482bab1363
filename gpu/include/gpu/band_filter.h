// The image-space filter between spectral bands (flare paper section 4.2): each ghost's image at each band
// is smeared along a 1D segment reaching halfway to where that ghost lies in the neighbouring bands (its
// centroid there), so that a few bands blend into a continuous spectrum instead of separate coloured copies.
#pragma once

#include <functional>

#include <gpu/flare_model.h>

namespace lensfx::gpu {

// Renders one ghost at one wavelength (view.only_ghosts holds it, view.wavelength_nm is set): the GPU
// renderer or render_reference.
using RenderOne = std::function<FlareImage(const FlareView&)>;

// The view's spectral bands (view.bands > 0, else std::invalid_argument), each ghost and band rendered on
// its own through `render`, filtered, weighted and summed. Same units as an unfiltered render; the filter
// keeps each band's energy (it only moves it). Costs one render per ghost and band.
FlareImage render_band_filtered(const System& system, const FlareView& view, const RenderOne& render);

}  // namespace lensfx::gpu
