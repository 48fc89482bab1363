// End to end: `lensfx track` over an EXR sequence writes the same lights as the library run in memory.
#include <cstdio>
#include <cstdlib>
#include <unistd.h>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <OpenImageIO/imagebuf.h>
#include <opencv2/imgproc.hpp>

#include <detect/detector.h>
#include <detect/track_file.h>
#include <detect/tracker.h>

#include "exr_io.h"
#include "run_lensfx.h"

using namespace lensfx::detect;
using namespace lensfx::detect::test;

namespace {

namespace fs = std::filesystem;

void write_exr(const cv::Mat& rgb, const fs::path& path) {
    OIIO::ImageBuf buf(OIIO::ImageSpec(rgb.cols, rgb.rows, 3, OIIO::TypeDesc::FLOAT), const_cast<float*>(rgb.ptr<float>()));
    if (!buf.write(path.string())) throw std::runtime_error(path.string() + ": " + buf.geterror());
}

int run(const std::string& args, const fs::path& log) {
    return lensfx::test::run_lensfx_status(args + " > " + log.string() + " 2>&1");
}

std::string slurp(const fs::path& p) {
    std::FILE* f = std::fopen(p.c_str(), "rb");
    std::string s;
    if (!f) return s;
    char buf[4096];
    for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) s.append(buf, n);
    std::fclose(f);
    return s;
}

}  // namespace

TEST(TrackCommand, WritesTheLightsOfTheLibraryRun) {
    const auto src = hdr_dir() / "MultiResolution/StageEnvLatLong.exr";
    LENSFX_REQUIRE_DATA(src);
    const cv::Mat full = read_rgb(src).rgb;
    const fs::path dir = fs::temp_directory_path() / ("lensfx_track_cmd_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    std::vector<cv::Mat> frames;
    for (int f = 1; f <= 8; ++f) {
        cv::Mat crop;
        cv::getRectSubPix(full, cv::Size(320, 200), cv::Point2f(static_cast<float>(480.0 + 1.3 * f), 180.0f), crop, CV_32F);
        char name[32];
        std::snprintf(name, sizeof name, "pan.%04d.exr", f);
        write_exr(crop, dir / name);
        frames.push_back(crop);
    }
    ASSERT_EQ(run("track -i " + (dir / "pan.####.exr").string() + " --tracks-out " + (dir / "t.json").string() + " --threshold 20",
                  dir / "log.txt"),
              0)
        << slurp(dir / "log.txt");
    const TrackFile file = read_track_file(dir / "t.json");
    EXPECT_EQ(file.width, 320);
    EXPECT_EQ(file.height, 200);

    Detector det{DetectorOptions{}};
    Tracker tr;
    std::size_t lights = 0;
    for (int f = 1; f <= 8; ++f) {
        const auto live = tr.update(det.detect(frames[static_cast<std::size_t>(f - 1)]));
        lights += live.size();
        EXPECT_EQ(file.lights_at(f), live) << "frame " << f;
    }
    EXPECT_GT(lights, 8u);

    // A frame range that does not exist: a one-line error naming the file, exit code 1.
    EXPECT_NE(run("track -i " + (dir / "pan.####.exr").string() + " --frames 7-9 --tracks-out " + (dir / "u.json").string(), dir / "log2.txt"),
              0);
    const std::string err = slurp(dir / "log2.txt");
    EXPECT_NE(err.find("pan.0009.exr"), std::string::npos) << err;
    EXPECT_FALSE(fs::exists(dir / "u.json"));
    fs::remove_all(dir);
}
