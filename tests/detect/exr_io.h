// Test-only image reading: an EXR's R, G, B channels as a CV_32FC3 matrix (OpenImageIO), and the location
// of ../shared/data (tests skip when it is absent).
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>

#include <OpenImageIO/imagebuf.h>
#include <opencv2/core.hpp>

namespace lensfx::detect::test {

inline std::filesystem::path hdr_dir() { return std::filesystem::path(LENSFX_SHARED_DIR) / "data" / "hdr"; }

struct RgbImage {
    cv::Mat rgb;  // data window
    int x = 0, y = 0;  // data window origin in the display window
};

inline RgbImage read_rgb(const std::filesystem::path& path) {
    OIIO::ImageBuf buf(path.string());
    if (!buf.init_spec(path.string(), 0, 0)) throw std::runtime_error(path.string() + ": " + buf.geterror());
    const OIIO::ImageSpec spec = buf.spec();
    int ch[3] = {-1, -1, -1};
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c) ch[c] = spec.channelindex(names[c]);
    if (ch[0] < 0 || ch[1] < 0 || ch[2] < 0) throw std::runtime_error(path.string() + ": no R, G, B channels");
    if (!buf.read(0, 0, true, OIIO::TypeDesc::FLOAT)) throw std::runtime_error(path.string() + ": " + buf.geterror());
    RgbImage out;
    out.x = spec.x;
    out.y = spec.y;
    out.rgb.create(spec.height, spec.width, CV_32FC3);
    for (int c = 0; c < 3; ++c) {
        cv::Mat plane(spec.height, spec.width, CV_32F);
        const OIIO::ROI roi(spec.x, spec.x + spec.width, spec.y, spec.y + spec.height, 0, 1, ch[c], ch[c] + 1);
        if (!buf.get_pixels(roi, OIIO::TypeDesc::FLOAT, plane.ptr<float>())) throw std::runtime_error(path.string() + ": " + buf.geterror());
        cv::insertChannel(plane, out.rgb, c);
    }
    return out;
}

}  // namespace lensfx::detect::test

#define LENSFX_REQUIRE_DATA(path)                                                                         \
    do {                                                                                                  \
        if (!std::filesystem::exists(path)) GTEST_SKIP() << "sample data not found: " << (path).string(); \
    } while (0)
