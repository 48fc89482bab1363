// Prints the detection time per frame (median of repeated runs, image already in memory) for the sample
// frames, with what was found. Usage: bench_detect [--repeat N] [--threshold T] [--list] [--png DIR] [FILE.exr ...]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <detect/detector.h>

namespace {

cv::Mat read_rgb(const std::string& path) {
    OIIO::ImageBuf buf(path);
    if (!buf.read(0, 0, 0, 3, true, OIIO::TypeDesc::FLOAT)) throw std::runtime_error(path + ": " + buf.geterror());
    const auto spec = buf.spec();
    cv::Mat m(spec.height, spec.width, CV_32FC3);
    const OIIO::ROI roi(spec.x, spec.x + spec.width, spec.y, spec.y + spec.height, 0, 1, 0, 3);
    if (!buf.get_pixels(roi, OIIO::TypeDesc::FLOAT, m.ptr<float>())) throw std::runtime_error(path + ": " + buf.geterror());
    return m;
}

// A tone-mapped preview (x / (1 + x), sRGB-ish gamma) with each source's extent ellipse drawn on it.
void write_preview(const cv::Mat& rgb, const lensfx::detect::Detection& d, const std::string& path) {
    cv::Mat out(rgb.rows, rgb.cols, CV_8UC3);
    for (int y = 0; y < rgb.rows; ++y)
        for (int x = 0; x < rgb.cols; ++x) {
            const auto p = rgb.at<cv::Vec3f>(y, x);
            for (int c = 0; c < 3; ++c) {
                const double v = std::isfinite(p[c]) && p[c] > 0.0f ? static_cast<double>(p[c]) : 0.0;
                out.at<cv::Vec3b>(y, x)[c] = static_cast<unsigned char>(255.0 * std::pow(v / (1.0 + v), 1.0 / 2.2) + 0.5);
            }
        }
    for (const auto& s : d.sources) {
        const cv::Point2d c(s.x, s.y);
        const cv::Size2d axes(std::max(3.0, s.extent.major), std::max(3.0, s.extent.minor));
        cv::ellipse(out, cv::RotatedRect(c, cv::Size2f(static_cast<float>(2 * axes.width), static_cast<float>(2 * axes.height)),
                                         static_cast<float>(-s.extent.angle_deg)),
                    s.clipped ? cv::Scalar(255, 0, 255) : cv::Scalar(0, 255, 0), 1);
    }
    OIIO::ImageBuf buf(OIIO::ImageSpec(out.cols, out.rows, 3, OIIO::TypeDesc::UINT8), out.ptr<unsigned char>());
    if (!buf.write(path)) throw std::runtime_error(path + ": " + buf.geterror());
}

}  // namespace

int main(int argc, char** argv) {
    int repeat = 20;
    bool list = false;
    std::string png_dir;
    lensfx::detect::DetectorOptions opt;
    std::vector<std::string> files;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--repeat" && i + 1 < argc) repeat = std::max(1, std::atoi(argv[++i]));
        else if (a == "--threshold" && i + 1 < argc) opt.threshold = lensfx::detect::Threshold::parse(argv[++i]);
        else if (a == "--max-lights" && i + 1 < argc) opt.max_lights = std::atoi(argv[++i]);
        else if (a == "--list") list = true;
        else if (a == "--png" && i + 1 < argc) png_dir = argv[++i];
        else files.push_back(a);
    }
    const std::string hdr = std::string(LENSFX_SHARED_DIR) + "/data/hdr/";
    if (files.empty())
        files = {hdr + "ScanLines/CandleGlass.exr", hdr + "ScanLines/StillLife.exr", hdr + "Tiles/GoldenGate.exr",
                 hdr + "ScanLines/Desk.exr", hdr + "ScanLines/Tree.exr", hdr + "MultiResolution/StageEnvLatLong.exr"};
    try {
        lensfx::detect::Detector detector(opt);
        fmt::print("threshold {}, max_lights {}, downsample {}, {} runs each (median)\n", opt.threshold.to_string(), opt.max_lights,
                   opt.downsample, repeat);
        for (const auto& file : files) {
            const cv::Mat img = read_rgb(file);
            std::vector<double> ms;
            lensfx::detect::Detection d;
            for (int r = 0; r < repeat; ++r) {
                const auto t0 = std::chrono::steady_clock::now();
                d = detector.detect(img);
                ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
            }
            std::sort(ms.begin(), ms.end());
            const auto& st = d.stats;
            fmt::print("{:<40} {:>5}x{:<5} {:7.2f} ms/frame (min {:.2f})  median L {:.3g}, T {:.3g}/{:.3g}, components {}, "
                       "clustered {}, sources {} (+{} over budget, {} invisible)\n",
                       file.substr(file.rfind('/') + 1), img.cols, img.rows, ms[ms.size() / 2], ms.front(), st.median_luminance,
                       st.threshold, st.low_threshold, st.components, st.clustered ? "yes" : "no", d.sources.size(),
                       st.dropped_budget, st.dropped_invisible);
            if (!png_dir.empty()) {
                const auto base = file.substr(file.rfind('/') + 1);
                write_preview(img, d, png_dir + "/" + base.substr(0, base.rfind('.')) + ".png");
            }
            if (list)
                for (const auto& s : d.sources)
                    fmt::print("    ({:7.2f}, {:7.2f}) flux {:10.4g} {:10.4g} {:10.4g} peak {:8.4g} px {:6} members {:4} extent {:6.2f} x {:6.2f} @ {:5.1f}{}{}\n",
                               s.x, s.y, s.flux[0], s.flux[1], s.flux[2], s.peak, s.pixel_count, s.members, s.extent.major,
                               s.extent.minor, s.extent.angle_deg, s.clipped ? " clipped" : "",
                               s.shape ? fmt::format(" shape {}x{} cell {}", s.shape->width, s.shape->height, s.shape->cell) : "");
        }
    } catch (const std::exception& e) {
        fmt::print(stderr, "bench_detect: {}\n", e.what());
        return 1;
    }
    return 0;
}
