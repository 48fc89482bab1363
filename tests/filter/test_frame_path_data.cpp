// Flicker on real footage: a pan across the stage lamp of StageEnvLatLong in sub-pixel steps (bilinear
// shifts of a 480x270 crop), flared end to end; the flare's energy per unit source flux must stay within
// 1% from frame to frame.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <gtest/gtest.h>

#include "run_lensfx.h"

namespace fs = std::filesystem;

namespace {

const fs::path kStage = fs::path(LENSFX_SHARED_DIR) / "data" / "hdr" / "MultiResolution" / "StageEnvLatLong.exr";

std::vector<float> green(const fs::path& path) {
    OIIO::ImageBuf buf(path.string());
    EXPECT_TRUE(buf.read(0, 0, true, OIIO::TypeDesc::FLOAT)) << path;
    std::vector<float> px(static_cast<std::size_t>(buf.spec().width) * static_cast<std::size_t>(buf.spec().height));
    buf.get_pixels(OIIO::ROI(buf.spec().x, buf.spec().x + buf.spec().width, buf.spec().y, buf.spec().y + buf.spec().height, 0, 1, 1, 2),
                   OIIO::TypeDesc::FLOAT, px.data());
    return px;
}

}  // namespace

TEST(FramePathData, StageLampPanDoesNotFlicker) {
    if (!fs::exists(kStage)) GTEST_SKIP() << "sample data not found: " << kStage;
    const fs::path dir = fs::temp_directory_path() / "lensfx_frame_path_data_pan";
    fs::remove_all(dir);
    fs::create_directories(dir);
    OIIO::ImageBuf src(kStage.string());
    ASSERT_TRUE(src.read(0, 0, true, OIIO::TypeDesc::FLOAT));
    const int frames = 8;
    for (int f = 1; f <= frames; ++f) {
        // Frame f shows the scene shifted left by 0.37 f and up by 0.13 f pixels (bilinear, so the
        // recorded energy of each light is kept).
        const double sx = 200.0 + 0.37 * f, sy = 120.0 + 0.13 * f;
        const int ix = static_cast<int>(std::floor(sx)), iy = static_cast<int>(std::floor(sy));
        const float fx = static_cast<float>(sx - ix), fy = static_cast<float>(sy - iy);
        OIIO::ImageSpec spec(480, 270, 3, OIIO::TypeDesc::FLOAT);
        OIIO::ImageBuf out(spec);
        for (int y = 0; y < 270; ++y)
            for (int x = 0; x < 480; ++x) {
                float p00[3], p10[3], p01[3], p11[3], v[3];
                src.getpixel(ix + x, iy + y, p00, 3);
                src.getpixel(ix + x + 1, iy + y, p10, 3);
                src.getpixel(ix + x, iy + y + 1, p01, 3);
                src.getpixel(ix + x + 1, iy + y + 1, p11, 3);
                for (int c = 0; c < 3; ++c)
                    v[c] = (1 - fx) * (1 - fy) * p00[c] + fx * (1 - fy) * p10[c] + (1 - fx) * fy * p01[c] + fx * fy * p11[c];
                out.setpixel(x, y, v);
            }
        ASSERT_TRUE(out.write((dir / ("in." + std::to_string(10000 + f).substr(1) + ".exr")).string()));
    }
    const std::string args = "-i " + (dir / "in.#.exr").string() + " -o " + (dir / "out.#.exr").string() +
                            " --flare-only --parts ghosts --lens brendel-tessar --fstop 4 --grid 32 --threshold 100 -q 2>&1";
    ASSERT_EQ(lensfx::test::run_lensfx_status(args, (dir / "cache").string()), 0);
    std::vector<double> ratio;
    for (int f = 1; f <= frames; ++f) {
        const std::string n = std::to_string(10000 + f).substr(1);
        const std::vector<float> in = green(dir / ("in." + n + ".exr")), out = green(dir / ("out." + n + ".exr"));
        double source = 0.0, flare = 0.0;
        for (float v : in)
            if (v >= 50.0f) source += static_cast<double>(v);  // the lights, down to the low threshold
        for (float v : out) flare += static_cast<double>(v);
        ASSERT_GT(source, 0.0);
        ASSERT_GT(flare, 0.0);
        ratio.push_back(flare / source);
    }
    double worst = 0.0;
    for (std::size_t i = 1; i < ratio.size(); ++i) {
        const double flicker = std::abs(ratio[i] - ratio[i - 1]) / ratio[i - 1];
        EXPECT_LT(flicker, 0.01) << "flicker between frames " << i << " and " << i + 1;
        worst = std::max(worst, flicker);
    }
    RecordProperty("worst_flicker_percent", std::to_string(100.0 * worst));
    std::printf("worst frame-to-frame flicker: %.3f%%\n", 100.0 * worst);
}
