// Colour management with OpenColorIO: which colour space the input frames are in, the scene-linear working
// space the flare is rendered and composited in (and its primaries, for the renderer's spectral-to-RGB
// conversion), the display transform (view/look/exposure) for viewable outputs, and quantisation with dither.
// Without an OCIO config (no --ocio, no $OCIO) a config is built in code from OCIO's built-in ACES transforms.
// This header gathers the colour module's parts (filter/colour/); include the part you need where you can.
#pragma once

#include <filter/colour/config.h>
#include <filter/colour/matrix.h>
#include <filter/colour/options.h>
#include <filter/colour/pipeline.h>
#include <filter/colour/pixel_span.h>
#include <filter/colour/quantise.h>
#include <filter/colour/stages.h>
#include <filter/colour/transform.h>
#include <filter/dither.h>
