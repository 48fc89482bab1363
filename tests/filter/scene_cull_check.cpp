#include "scene_cull_check.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <gtest/gtest.h>

#include "filter_test_util.h"

namespace fs = std::filesystem;

namespace lensfx::test {
namespace {

// "flare.ghosts culled" (or another figure) of the single frame of a --report file.
double report_figure(const fs::path& report, const std::string& name) {
    std::ifstream in(report);
    std::stringstream text;
    text << in.rdbuf();
    const std::string key = "\"" + name + "\": ";
    const auto at = text.str().find(key);
    return at == std::string::npos ? -1.0 : std::stod(text.str().substr(at + key.size()));
}

// The 8-bit sRGB codes of an EXR's R, G, B (clipped to [0, 1], as the display shows them).
std::vector<int> srgb8_codes(const fs::path& file) {
    OIIO::ImageBuf image(file.string());
    const OIIO::ROI roi = image.roi();
    std::vector<float> rgb(static_cast<std::size_t>(roi.npixels()) * 3);
    EXPECT_TRUE(image.get_pixels(OIIO::ROI(roi.xbegin, roi.xend, roi.ybegin, roi.yend, 0, 1, 0, 3), OIIO::TypeDesc::FLOAT, rgb.data()));
    std::vector<int> codes(rgb.size());
    for (std::size_t i = 0; i < rgb.size(); ++i) {
        const double v = std::clamp(static_cast<double>(rgb[i]), 0.0, 1.0);
        const double e = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
        codes[i] = static_cast<int>(std::lround(255.0 * e));
    }
    return codes;
}

}  // namespace

fs::path resized_frame(const fs::path& source, int width, int height, const fs::path& dir) {
    const fs::path out = dir / "resized.exr";
    const OIIO::ImageBuf src(source.string());
    const OIIO::ImageBuf resized = OIIO::ImageBufAlgo::resize(src, "", 0.0f, OIIO::ROI(0, width, 0, height, 0, 1, 0, src.nchannels()));
    EXPECT_TRUE(resized.write(out.string())) << resized.geterror();
    return out;
}

void expect_within_a_code_of_drawing_every_ghost(const fs::path& input, const std::string& lens, const std::vector<std::string>& gains) {
    const fs::path dir = scratch_dir("scene_cull");
    for (const std::string& gain : gains) {
        std::vector<std::vector<int>> codes;
        std::vector<double> culled;
        for (const std::string cull : {"", " --no-scene-cull"}) {
            const fs::path out = dir / ("out" + gain + (cull.empty() ? "c" : "n") + ".exr");
            const fs::path report = dir / ("r" + gain + (cull.empty() ? "c" : "n") + ".json");
            const auto r = run(lensfx_cmd() + " -i '" + input.string() + "' -o '" + out.string() + "' --lens " + lens + " --gain " + gain +
                               cull + " -q --cache-dir '" + (dir / "cache").string() + "' --report '" + report.string() + "'");
            ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
            codes.push_back(srgb8_codes(out));
            culled.push_back(report_figure(report, "flare.ghosts culled"));
        }
        EXPECT_GT(culled[0], 0.0) << "gain " << gain;
        EXPECT_EQ(culled[1], 0.0) << "gain " << gain;
        ASSERT_EQ(codes[0].size(), codes[1].size());
        std::vector<int> diff(codes[0].size());
        for (std::size_t i = 0; i < diff.size(); ++i) diff[i] = std::abs(codes[0][i] - codes[1][i]);
        std::sort(diff.begin(), diff.end());
        EXPECT_LE(diff[static_cast<std::size_t>(0.999 * static_cast<double>(diff.size() - 1))], 1) << "gain " << gain;
        EXPECT_LE(diff.back(), 4) << "gain " << gain;
    }
    fs::remove_all(dir);
}

}  // namespace lensfx::test
