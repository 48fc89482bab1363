// RGB float image operations (filter/image_ops.h).
#include <filter/image_ops.h>

#include <filter/float_range.h>

namespace lensfx::filter {

Region nonzero_region(const ConstRgbView& image) {
    Region box{image.x + image.width, image.y + image.height, image.x, image.y};
    for (int y = image.y; y < image.y + image.height; ++y) {
        const float* row = image.at(image.x, y);
        auto lit = [&](int i) { return row[i * 3] != 0.0f || row[i * 3 + 1] != 0.0f || row[i * 3 + 2] != 0.0f; };
        int first = 0;
        while (first < image.width && !lit(first)) ++first;
        if (first == image.width) continue;
        int last = image.width - 1;
        while (!lit(last)) --last;
        box.x0 = std::min(box.x0, image.x + first);
        box.x1 = std::max(box.x1, image.x + last + 1);
        box.y0 = std::min(box.y0, y);
        box.y1 = y + 1;
    }
    return box.empty() ? Region{} : box;
}

void add(const RgbView& dst, const ConstRgbView& src, const Region& region) {
    const Region r = intersection(intersection(region, dst.region()), src.region());
    if (r.empty()) return;
    const auto n = static_cast<std::size_t>(r.width()) * 3;
    for (int y = r.y0; y < r.y1; ++y) {
        float* to = dst.at(r.x0, y);
        const float* from = src.at(r.x0, y);
        for (std::size_t i = 0; i < n; ++i) to[i] = added_within_float(to[i], from[i]);
    }
}

}  // namespace lensfx::filter
