// What a frame can show of an added flare: one 8-bit sRGB code at the least of each cell's channel, per channel.
#include <filter/visibility.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace lensfx::filter {

double srgb8_code_step(double plate) {
    const double L = std::clamp(std::isfinite(plate) ? plate : 0.0, 0.0, 1.0);
    const double slope = L <= 0.0031308 ? 12.92 : 1.055 / 2.4 * std::pow(L, 1.0 / 2.4 - 1.0);
    return 1.0 / (255.0 * slope);
}

namespace {

// Cells a visibility map holds at most (24 bytes each while it is made, a float per channel twice: 100 MB): a display window of more
// than 2048 x 2048 cells gets cells twice as wide, as often as needed (a tiny file declaring a 10^6 x 10^6
// window once made this map of 10^9 cells, 8 GB, before the flare's own memory check refused the frame).
constexpr std::size_t kMaxVisibilityCells = std::size_t{1} << 22;

int cell_within_bound(int width, int height, int cell) {
    auto cells = [&](int c) { return static_cast<std::size_t>((width + c - 1) / c) * static_cast<std::size_t>((height + c - 1) / c); };
    while (cells(cell) > kMaxVisibilityCells && cell < std::max(width, height)) cell *= 2;
    return cell;
}

}  // namespace

std::shared_ptr<gpu::VisibilityMap> plate_visibility(const Frame& frame, double budget, int cell) {
    auto map = std::make_shared<gpu::VisibilityMap>();
    const ImageSpec& spec = frame.spec;
    cell = cell_within_bound(spec.full_width, spec.full_height, cell);
    map->width = spec.full_width;
    map->height = spec.full_height;
    map->cell = cell;
    map->cols = (map->width + cell - 1) / cell;
    map->rows = (map->height + cell - 1) / cell;
    map->budget = budget;
    const std::size_t cells = static_cast<std::size_t>(map->cols) * static_cast<std::size_t>(map->rows);
    // The least of each channel per cell; display pixels outside the data window are black.
    std::vector<float> least(cells * 3, std::numeric_limits<float>::max());
    const int dx = spec.x - spec.full_x, dy = spec.y - spec.full_y;
    const bool covers = dx <= 0 && dy <= 0 && dx + spec.width >= map->width && dy + spec.height >= map->height;
    if (!covers) std::fill(least.begin(), least.end(), 0.0f);
    const int y0 = std::max(0, -dy), y1 = std::min(spec.height, map->height - dy);
    const int x0 = std::max(0, -dx), x1 = std::min(spec.width, map->width - dx);
    for (int y = y0; y < y1; ++y) {
        const float* row = frame.rgb.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(spec.width) * 3;
        float* cell_row = least.data() + static_cast<std::size_t>((y + dy) / cell) * static_cast<std::size_t>(map->cols) * 3;
        for (int x = x0; x < x1; ++x) {
            const float* p = row + static_cast<std::size_t>(x) * 3;
            float* c = cell_row + static_cast<std::size_t>((x + dx) / cell) * 3;
            for (std::size_t k = 0; k < 3; ++k) c[k] = std::min(c[k], p[k]);  // NaN pixels leave the cell as it was
        }
    }
    map->visible.resize(cells * 3);
    for (std::size_t i = 0; i < cells * 3; ++i)
        map->visible[i] = static_cast<float>(srgb8_code_step(static_cast<double>(least[i])));
    return map;
}

}  // namespace lensfx::filter
