// `lensfx --dof` on the deep forest of ../shared/data (deep RGBA + Z samples are the layers); skipped when
// the data is absent. Few rays, no chromatic blur: it checks the path, not the quality.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "../filter/filter_test_util.h"
#include "exr_rgbz.h"

namespace lensfx::dof::test {
namespace {

TEST(DofFilterData, DeepInputIsReadAsLayersAndWrittenFlat) {
    const std::string in = std::string(LENSFX_SHARED_DIR) + "/data/hdr/v2/LowResLeftView/Balls.exr";
    if (!std::filesystem::exists(in)) GTEST_SKIP() << in << " absent";
    const auto dir = lensfx::test::scratch_dir("dof_deep");
    const std::string sharp = (dir / "sharp.exr").string(), blurred = (dir / "blurred.exr").string();
    auto r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + sharp);
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    r = lensfx::test::run(lensfx::test::lensfx_cmd() + " -i " + in + " -o " + blurred +
                          " --dof --dof-only --lens pbrt-dgauss-50 --fstop 2.8 --focus 0.5 --dof-rays 4 --no-chromatic-blur");
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    int w = 0, h = 0;
    const std::vector<float> a = read_channel(sharp, "G", w, h), b = read_channel(blurred, "G", w, h);
    double diff = 0.0, sum = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) diff += std::abs(double{a[i]} - double{b[i]}), sum += std::abs(double{a[i]});
    EXPECT_GT(sum, 0.0);
    EXPECT_GT(diff / sum, 0.05) << "the balls are out of focus at 0.5 m";
}

}  // namespace
}  // namespace lensfx::dof::test
