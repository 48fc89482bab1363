// Arithmetic on pixel values that cannot overflow: a finite value scaled or added stays finite (at most
// the largest float), so a huge gain or exposure saturates instead of turning a frame Inf or NaN. Values
// already Inf or NaN in the input pass through as they were.
#pragma once

#include <cmath>
#include <limits>

namespace lensfx::flare {

inline constexpr float kFloatMax = std::numeric_limits<float>::max();

// v * s, held at +-kFloatMax where a finite v would overflow.
inline float scaled_within_float(float v, float s) {
    const float r = v * s;
    return std::isinf(r) && std::isfinite(v) && std::isfinite(s) ? std::copysign(kFloatMax, r) : r;
}

// a + b, held at +-kFloatMax where two finite values would overflow.
inline float added_within_float(float a, float b) {
    const float r = a + b;
    return std::isinf(r) && std::isfinite(a) && std::isfinite(b) ? std::copysign(kFloatMax, r) : r;
}

// A double made a float, held at +-kFloatMax (NaN stays NaN).
inline float to_float_within(double v) {
    return static_cast<float>(std::isfinite(v) ? std::fmax(-double(kFloatMax), std::fmin(double(kFloatMax), v)) : v);
}

}  // namespace lensfx::flare
