// The GL resources the renderer keeps between renders (gpu/render_resources.h): each kept while asked for at
// the same size or iris, and remade when asked for at another (llvmpipe).
#include <stdexcept>
#include <vector>

#include <epoxy/gl.h>

#include <gtest/gtest.h>

#include <gpu/context.h>
#include <gpu/render_resources.h>

namespace lensfx::gpu {
namespace {

TEST(RenderTargets, KeptAtTheSameSizeAndRemadeAtAnother) {
    const Context context(Platform::Surfaceless);
    RenderTargets targets;
    const FloatTarget& quarter = targets.reduced(4, 101, 50);
    EXPECT_EQ(quarter.width(), 26);  // sides rounded up
    EXPECT_EQ(quarter.height(), 13);
    EXPECT_EQ(&targets.reduced(4, 101, 50), &quarter);
    EXPECT_EQ(&targets.reduced(4, 103, 52), &quarter);  // the same 26 x 13 target: kept
    targets.full(101, 20);
    targets.full(101, 20);
    EXPECT_EQ(targets.made(), 2);
    EXPECT_EQ(targets.reduced(4, 120, 50).width(), 30);  // another size: remade
    targets.full(101, 30);                                // another band height: remade
    EXPECT_EQ(targets.made(), 4);
    targets.release();
    targets.reduced(4, 120, 50);  // made again after a release
    EXPECT_EQ(targets.made(), 5);
    EXPECT_THROW(targets.reduced(3, 90, 90), std::logic_error);
    EXPECT_EQ(RenderTargets::slot(16), 4u);
    EXPECT_EQ(RenderTargets::slot(32), 5u);  // faint ghosts at least 2048 px across
    EXPECT_EQ(targets.reduced(32, 1920, 1080).width(), 60);
    EXPECT_THROW(targets.reduced(64, 1920, 1080), std::logic_error);
}

// A target is cleared whole until a read-back says where it is lit; then only there, once: what it is drawn
// into next is lit anywhere again. (Ones stand for what a draw left; the clear must not touch them outside.)
TEST(RenderTargets, ClearedOnlyWhereLastSeenLit) {
    const Context context(Platform::Surfaceless);
    RenderTargets targets;
    const FloatTarget& t = targets.reduced(2, 16, 12);  // 8 x 6
    const float one[4] = {1.f, 1.f, 1.f, 1.f};
    auto fill_ones = [&] { glClearTexImage(t.texture(), 0, GL_RGBA, GL_FLOAT, one); };
    auto at = [&](const std::vector<float>& rgba, int x, int y) { return rgba[(static_cast<std::size_t>(y) * 8 + static_cast<std::size_t>(x)) * 4]; };
    fill_ones();
    targets.clear(1);  // never read back: whole
    for (float v : t.read_rgba()) EXPECT_EQ(v, 0.0f);
    fill_ones();
    targets.lit_within(1, {2, 1, 5, 3});
    targets.clear(1);
    const std::vector<float> part = t.read_rgba();
    EXPECT_EQ(at(part, 2, 1), 0.0f);
    EXPECT_EQ(at(part, 4, 2), 0.0f);
    EXPECT_EQ(at(part, 5, 2), 1.0f);  // beyond the lit rect: left as it was
    EXPECT_EQ(at(part, 3, 3), 1.0f);
    EXPECT_EQ(at(part, 0, 0), 1.0f);
    targets.clear(1);  // drawn into since (as far as it knows): whole again
    for (float v : t.read_rgba()) EXPECT_EQ(v, 0.0f);
    // Only the rect is read back, each texel at its own column of a full-width row.
    fill_ones();
    std::vector<float> rows(8 * 2 * 4, -1.0f);
    t.read_rgba_rect({3, 2, 6, 4}, rows.data());
    EXPECT_EQ(rows[(0 * 8 + 3) * 4], 1.0f);
    EXPECT_EQ(rows[(1 * 8 + 5) * 4 + 2], 1.0f);
    EXPECT_EQ(rows[(0 * 8 + 2) * 4], -1.0f);
    EXPECT_EQ(rows[(1 * 8 + 6) * 4], -1.0f);
}

TEST(IrisTextures, UploadedOncePerIrisAndOrder) {
    const Context context(Platform::Surfaceless);
    IrisTextures iris;
    optics::Aperture six;
    six.blades = 6;
    optics::Aperture five = six;
    five.blades = 5;
    const unsigned sdf = iris.sdf(six);
    EXPECT_EQ(iris.sdf(six), sdf);
    EXPECT_EQ(iris.uploads(), 1);
    EXPECT_NE(iris.sdf(five), 0u);  // another shape: remade
    EXPECT_EQ(iris.uploads(), 2);
    const unsigned ringing = iris.ringing(six, 0.2);
    EXPECT_EQ(iris.ringing(six, 0.2), ringing);
    EXPECT_EQ(iris.uploads(), 3);
    iris.ringing(six, 0.3);  // another order
    iris.ringing(five, 0.2);  // another shape
    EXPECT_EQ(iris.uploads(), 5);
}

}  // namespace
}  // namespace lensfx::gpu
