// Operations on RGB float images, shaped like OpenImageIO's ImageBufAlgo: a view of an image's pixels placed in
// a shared pixel space (its data window's origin), a region type, and op(dst, src, region). The flare is drawn
// over the display window and added to a frame whose data window may differ; these say that once.
#pragma once

#include <algorithm>
#include <cstddef>
#include <functional>
#include <span>
#include <vector>

namespace lensfx::flare {

// A rectangle of pixels [x0, x1) x [y0, y1) (rows from the top), as OIIO's ROI without channels or depth.
struct Region {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    bool empty() const { return x1 <= x0 || y1 <= y0; }
    int width() const { return x1 - x0; }
    int height() const { return y1 - y0; }
};
// What two regions share (empty when nothing).
inline Region intersection(const Region& a, const Region& b) {
    return {std::max(a.x0, b.x0), std::max(a.y0, b.y0), std::min(a.x1, b.x1), std::min(a.y1, b.y1)};
}

// Top-down RGB float pixels, 3 floats a pixel, whose first pixel sits at (x, y) of the pixel space.
template <typename Float>
struct BasicRgbView {
    Float* rgb = nullptr;
    int x = 0, y = 0;
    int width = 0, height = 0;
    Region region() const { return {x, y, x + width, y + height}; }
    Float* at(int px, int py) const {
        return rgb + (static_cast<std::size_t>(py - y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(px - x)) * 3;
    }
};
using RgbView = BasicRgbView<float>;
using ConstRgbView = BasicRgbView<const float>;

// The smallest region holding every pixel with a non-zero channel (empty when all are zero), as OIIO's
// nonzero_region.
Region nonzero_region(const ConstRgbView& image);

// dst += src over `region` (clipped to both views), each sum held within float range (added_within_float).
void add(const RgbView& dst, const ConstRgbView& src, const Region& region);

// Where output pixel i of n samples a source of sn pixels stretched over the n (add_resized's mapping, pixel
// centres aligned, edges held): neighbours i0 and i1, and i1's share f.
struct BilinearTap {
    int i0, i1;
    float f;
};
std::vector<BilinearTap> bilinear_taps(int n, int sn);

// The Mitchell-Netravali cubic (B = C = 1/3) at offset x in source pixels: smoother than bilinear (its gradient is
// continuous, so an enlarged image has no creases at the source pixels' centres) with lobes under 4% below zero.
double mitchell(double x);
// Where output pixel i of n samples a source of sn pixels through the Mitchell cubic, with the same mapping as
// bilinear_taps: four neighbours (edge pixels repeated beyond the border) and their weights.
struct CubicTap {
    int i[4];
    float f[4];
};
std::vector<CubicTap> mitchell_taps(int n, int sn);

// Reduction by a whole factor f and its way back, one mapping for every reduced render: pixel (i, j) of the
// reduced pixel space covers pixels [i f, (i + 1) f) x [j f, (j + 1) f) of the full one, so reduced_side(n, f)
// pixels cover n (the last partly beyond them).
inline int reduced_side(int n, int factor) { return (n + factor - 1) / factor; }
// Sets each pixel of dst (in the reduced space) to the mean of the f x f pixels of src it covers (area
// average; those beyond src count as 0).
void reduce_area(const RgbView& dst, const ConstRgbView& src, int factor);
// dst += src (in the reduced space) enlarged bilinearly over the full-space pixels it covers: add_resized over
// [src.x f, (src.x + src.width) f) x [src.y f, (src.y + src.height) f), so a reduced pixel's centre stays at
// the centre of the pixels it covers.
void add_enlarged(const RgbView& dst, const ConstRgbView& src, int factor);

// dst += src resized bilinearly to cover `region` of dst's pixel space (src's pixel centres spread evenly over
// it, its edge pixels held beyond the outer centres, as OIIO's resize maps display windows), over the part of
// `region` inside dst; each sum held within float range. A reduced render enlarged into a full-size image.
// Only the pixels the source's nonzero region reaches are visited: the others are left as they were, bit for bit.
void add_resized(const RgbView& dst, const ConstRgbView& src, const Region& region);
// add_resized of each source over its region in turn, done row by row (a frame row stays in cache while they
// all add to it): the same sums in the same order, for the cost of one pass over dst. From 256 rows on, half
// the rows are added on a second thread (split_rows): the same image.
void add_resized_each(const RgbView& dst, std::span<const ConstRgbView> srcs, std::span<const Region> regions);

// A loop over rows [y0, y1) whose rows do not depend on each other, split in two: body(y0, middle) on this
// thread while body(middle, y1) runs on another, or body(y0, y1) here alone when there are fewer than min_rows
// rows or no thread to be had. What body throws on either thread is thrown here, after both halves end.
void split_rows(int y0, int y1, int min_rows, const std::function<void(int, int)>& body);

}  // namespace lensfx::flare
