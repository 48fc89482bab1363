// The dither of display-referred outputs, chosen on the command line and used by image writing
// (filter/colour/quantise.h quantises with it).
#pragma once

namespace lensfx::colour {

enum class Dither { None, Ordered, BlueNoise };

}  // namespace lensfx::colour
