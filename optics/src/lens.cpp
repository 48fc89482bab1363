#include <optics/lens.h>

#include <algorithm>

namespace lensfx::optics {

int Lens::zoom_positions() const {
    std::size_t n = 1;
    for (const auto& s : surfaces) n = std::max(n, s.thickness_mm.size());
    return static_cast<int>(n);
}

int Lens::stop_index() const {
    for (std::size_t i = 0; i < surfaces.size(); ++i)
        if (surfaces[i].is_stop) return static_cast<int>(i);
    return -1;
}

}  // namespace lensfx::optics
