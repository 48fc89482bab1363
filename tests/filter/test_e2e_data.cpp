// End-to-end pass-through on the real OpenEXR sample images of ../shared/data/hdr: multi-channel
// sequence with a moving data window, display windows, tiled and mip-mapped files, and the damaged files.
#include <filesystem>

#include <fmt/core.h>
#include <gtest/gtest.h>

#include "filter_test_util.h"

namespace fs = std::filesystem;
using namespace lensfx::test;

namespace {

const fs::path hdr = fs::path(LENSFX_SHARED_DIR) / "data" / "hdr";

#define REQUIRE_DATA()                                                                                      \
    if (!fs::is_directory(hdr))                                                                             \
    GTEST_SKIP() << "the real images are not here: " << hdr.string() << " is missing (see ../shared/data)"

}  // namespace

TEST(FilterData, BeachballSequenceAllChannelsAndMovingDataWindow) {
    REQUIRE_DATA();
    const auto dir = scratch_dir("beachball");
    const auto r = run(lensfx_cmd() + fmt::format(" -i {}/Beachball/singlepart.####.exr -o {}/bb.####.exr --frames 1-8x3 -q",
                                              hdr.string(), dir.string()));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    for (int f : {1, 4, 7}) {
        const std::string name = fmt::format("{:04}", f);
        EXPECT_EQ(compare_images((hdr / ("Beachball/singlepart." + name + ".exr")).string(), (dir / ("bb." + name + ".exr")).string()), "")
            << "frame " << f;
    }
    EXPECT_EQ(file_count(dir), 3u);
    fs::remove_all(dir);
}

TEST(FilterData, SingleFilesRoundTrip) {
    REQUIRE_DATA();
    const auto dir = scratch_dir("singles");
    for (const char* file : {"DisplayWindow/t01.exr", "DisplayWindow/t05.exr", "DisplayWindow/t08.exr", "DisplayWindow/t12.exr",
                             "DisplayWindow/t16.exr", "Tiles/GoldenGate.exr", "MultiResolution/StageEnvLatLong.exr",
                             "ScanLines/CandleGlass.exr", "TestImages/BrightRingsNanInf.exr", "TestImages/WideFloatRange.exr"}) {
        const auto out = dir / "out.exr";
        const auto r = run(lensfx_cmd() + fmt::format(" -i {} -o {}", (hdr / file).string(), out.string()));
        ASSERT_EQ(r.exit_code, 0) << file << ": " << r.stderr_text;
        // Tiled and mip-mapped inputs are written as scanlines of the top level: pixels, channels, windows
        // and the other attributes are the same.
        EXPECT_EQ(compare_images((hdr / file).string(), out.string()), "") << file;
        fs::remove(out);
    }
    fs::remove_all(dir);
}

TEST(FilterData, EveryDamagedFileGivesOneLineAndNoOutput) {
    REQUIRE_DATA();
    const auto dir = scratch_dir("damaged");
    int files = 0;
    for (const auto& e : fs::directory_iterator(hdr / "Damaged")) {
        ++files;
        const auto r = run(lensfx_cmd() + fmt::format(" -i \"{}\" -o {}/out.exr", e.path().string(), dir.string()));
        EXPECT_EQ(r.exit_code, 1) << e.path();
        EXPECT_EQ(r.stderr_text.rfind("lensfx: " + e.path().string() + ": frame 1: ", 0), 0u) << r.stderr_text;
        EXPECT_EQ(std::count(r.stderr_text.begin(), r.stderr_text.end(), '\n'), 1) << r.stderr_text;
        EXPECT_EQ(file_count(dir), 0u) << e.path();
    }
    EXPECT_GT(files, 30);
    fs::remove_all(dir);
}
