// The composite's image operations (filter/image_ops.h): regions, nonzero_region and add between views placed
// at different origins, clipped to both and held within float range.
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include <filter/image_ops.h>

namespace lensfx::filter {
namespace {

TEST(ImageOps, NonzeroRegionIsTheLitBoxInThePixelSpace) {
    std::vector<float> rgb(5 * 4 * 3, 0.0f);
    const ConstRgbView view{rgb.data(), 10, 20, 5, 4};
    EXPECT_TRUE(nonzero_region(view).empty());
    rgb[(1 * 5 + 3) * 3 + 2] = 0.5f;   // (3, 1): blue only
    rgb[(2 * 5 + 1) * 3 + 0] = -1.0f;  // (1, 2): negative counts as lit
    const Region r = nonzero_region(view);
    EXPECT_EQ(r.x0, 11);
    EXPECT_EQ(r.y0, 21);
    EXPECT_EQ(r.x1, 14);
    EXPECT_EQ(r.y1, 23);
}

TEST(ImageOps, AddCoversTheOverlapOnlyAndSaturates) {
    std::vector<float> dst(4 * 3 * 3, 1.0f);  // at (2, 1), 4 x 3
    std::vector<float> src(3 * 3 * 3, 0.0f);  // at (0, 0), 3 x 3: overlaps columns 2, rows 1..2
    for (std::size_t i = 0; i < src.size(); ++i) src[i] = static_cast<float>(i);
    const float big = std::numeric_limits<float>::max();
    dst[0] = big;  // (2, 1) red: the largest float plus the largest float stays finite
    src[(1 * 3 + 2) * 3] = big;
    const RgbView to{dst.data(), 2, 1, 4, 3};
    const ConstRgbView from{src.data(), 0, 0, 3, 3};
    add(to, from, from.region());
    EXPECT_EQ(dst[0], big);                             // held, not inf
    EXPECT_EQ(dst[1], 1.0f + src[(1 * 3 + 2) * 3 + 1]);  // (2, 1) green
    EXPECT_EQ(dst[(1 * 4 + 0) * 3 + 2], 1.0f + src[(2 * 3 + 2) * 3 + 2]);  // (2, 2) blue
    EXPECT_EQ(dst[3], 1.0f);                            // (3, 1): outside the source
    EXPECT_EQ(dst[(2 * 4 + 0) * 3], 1.0f);              // (2, 3): below it
    // A region that misses either view adds nothing.
    add(to, from, Region{0, 0, 2, 3});
    EXPECT_EQ(dst[3], 1.0f);
}

}  // namespace
}  // namespace lensfx::filter
