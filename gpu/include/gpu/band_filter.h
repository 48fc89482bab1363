// The image-space filter between spectral bands (flare paper section 4.2): each ghost's image at each band
// is smeared along a 1D segment reaching halfway to where that ghost lies in the neighbouring bands (its
// centroid there), so that a few bands blend into a continuous spectrum instead of separate coloured copies.
#pragma once

#include <functional>
#include <utility>
#include <vector>

#include <gpu/flare_model.h>
#include <gpu/flare_renderer.h>

namespace lensfx::gpu {

// Renders ghosts at one wavelength: `band` is the caller's view at that wavelength (wavelength_nm set, bands 0,
// only_ghosts as the caller gave it), `ghosts` those to draw of it. The GPU renderer keeps `band`'s ghost list
// and draws only `ghosts` (GpuFlareOptions::draw_only), so every render of a band shares one bounds table, one
// set of sequences and one cache file; the CPU reference sets only_ghosts = ghosts.
using RenderOne = std::function<FlareImage(const FlareView& band, const std::vector<std::pair<int, int>>& ghosts)>;

// The view's spectral bands (view.bands > 0, else std::invalid_argument) of its ghosts (or of those in
// `draw_only`, when not empty), filtered, weighted and summed. The brightest ghosts along the axis (those
// holding 99.9% of the ghosts' axial power, at most 32) are rendered one ghost and band at a time through
// `render` and smeared; the rest, too faint for their smear to show, in one render per band, unsmeared. Same
// units as an unfiltered render; the filter keeps each band's energy (it only moves it). ghosts: the smeared
// ghosts' powers, and the others' when `render` gives them.
FlareImage render_band_filtered(const System& system, const FlareView& view, const RenderOne& render,
                                const std::vector<std::pair<int, int>>& draw_only = {});

// RenderOne on the GPU: `renderer` with `options` drawing only the asked ghost.
RenderOne render_one_on(FlareRenderer& renderer, const System& system, const GpuFlareOptions& options);

}  // namespace lensfx::gpu
