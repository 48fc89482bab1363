// How close a fitted flare is to a reference one (issue 19's measures): relative L1 over blocks, the
// total power's relative error, and Spearman's rank correlation of two series.
#pragma once

#include <vector>

namespace lensfx::measured {

// sum over block x block tiles and channels of |sum fit - sum truth| over the sum of truth (RGB floats,
// width x height x 3): block averaging forgives sub-block misplacement, not a wrong shape or level.
double block_l1(const std::vector<float>& fit, const std::vector<float>& truth, int width, int height, int block = 8);

// |sum fit - sum truth| / sum truth over every value.
double power_error(const std::vector<float>& fit, const std::vector<float>& truth);

// Spearman's rank correlation of a and b (the same length, at least 2; ties ranked in order).
double spearman(const std::vector<double>& a, const std::vector<double>& b);

}  // namespace lensfx::measured
