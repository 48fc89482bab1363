// An image window's side from its inclusive bounds (as EXR headers give them), computed without
// overflow: shared by the EXR readers of filter/ and dof/, whose hostile headers declare any bounds.
#pragma once

#include <string_view>

namespace lensfx {

// max - min + 1, in 64 bits. Throws std::runtime_error "WINDOW MIN..MAX is empty or too large" when the
// side is below 1 or beyond an int (2^31 - 1 pixels); `window` names it ("data window").
int window_side(int min, int max, std::string_view window);

}  // namespace lensfx
