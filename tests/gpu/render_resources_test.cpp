// The GL resources the renderer keeps between renders (gpu/render_resources.h): each kept while asked for at
// the same size or iris, and remade when asked for at another (llvmpipe).
#include <stdexcept>

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
