// A seeded random generator whose sequence is fixed by its definition (splitmix64), unlike std's
// distributions: the same seed gives the same dirt or jitter on every machine and library.
#pragma once

#include <cstdint>

namespace lensfx::optics {

class Random {
public:
    explicit Random(std::uint64_t seed) : state_(seed) {}
    double uniform() {  // [0, 1)
        std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
        z ^= z >> 31;
        return static_cast<double>(z >> 11) * 0x1.0p-53;
    }
    double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

private:
    std::uint64_t state_;
};

}  // namespace lensfx::optics
