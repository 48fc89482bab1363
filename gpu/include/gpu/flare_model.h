// The CPU flare model (flare/flare.h) in the names the GL renderers draw it by: the view they are given,
// the image they give back, the pupil rectangles they trace over.
#pragma once

#include <flare/cache.h>
#include <flare/flare.h>

namespace lensfx::gpu {

using optics::Aperture;
using optics::Ghost;
using optics::System;
using optics::TraceResult;
using optics::TraceSystem;

using flare::FlareImage;
using flare::FlareView;
using flare::GhostPower;
using flare::PupilRect;
using flare::SpectralPass;
using flare::aperture_sdf;
using flare::entrance_square;
using flare::ghost_pupil_bounds;
using flare::kRgbWavelengths_nm;
using flare::ray_passes;
using flare::selected_ghosts;
using flare::sensor_to_pixel;
using flare::system_hash;
using flare::without_coatings;

}  // namespace lensfx::gpu
