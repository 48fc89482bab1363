// Per-value guards of the colour transforms and quantisation (internal to filter/src/colour/).
#pragma once

#include <cmath>

namespace lensfx::colour {

// The largest half float: what +Inf becomes, so that it stays the brightest value an EXR can hold.
inline constexpr float inf_replacement = 65504.0f;

// NaN and -Inf to 0, +Inf to the largest half float.
inline float sanitise(float v) {
    if (std::isnan(v)) return 0.0f;
    if (std::isinf(v)) return v > 0.0f ? inf_replacement : 0.0f;
    return v;
}

// Clamp to [0, 1] that also turns a NaN into 0.
inline float clamp01(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }

}  // namespace lensfx::colour
