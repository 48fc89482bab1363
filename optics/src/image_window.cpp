// An image window's side from its inclusive bounds (see image_window.h).
#include <optics/image_window.h>

#include <cstdint>
#include <limits>
#include <stdexcept>

#include <fmt/core.h>

namespace lensfx {

int window_side(int min, int max, std::string_view window) {
    const std::int64_t side = std::int64_t{max} - min + 1;
    if (side < 1 || side > std::numeric_limits<int>::max())
        throw std::runtime_error(fmt::format("{} {}..{} is empty or too large", window, min, max));
    return static_cast<int>(side);
}

}  // namespace lensfx
