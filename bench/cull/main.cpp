// bench_cull: scene culling's time against its error (issue 17). For each image, lens and gain, the whole
// `lensfx -i IMAGE -o OUT.exr --lens LENS --gain G` program with culling and with --no-scene-cull (warm
// cache: one unmeasured run first; the best of --repeat runs each), and the difference of the two outputs
// in display code values: 8-bit sRGB of the scene-linear values (clipped) and the ACES SDR video view
// (lensfx's default PNG output). Prints one row per case: wall and CPU (user + system) seconds, best of each.
//   bench_cull [--lenses a,b] [--gains 1,20] [--repeat N] [--dir DIR] [--lensfx PATH] [--errors-only] IMAGE...
// --errors-only runs each program once (no warm-up run, no timing worth reading); --lensfx measures another
// build's program (default: this build's). The last column is the share of 8-bit sRGB values 2 or more codes off.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/resource.h>

#include <OpenImageIO/imagebuf.h>
#include <fmt/core.h>

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

std::vector<std::string> split(const std::string& text) {
    std::vector<std::string> out;
    std::stringstream in(text);
    for (std::string item; std::getline(in, item, ',');) out.push_back(item);
    return out;
}

// CPU seconds (user + system) of the children waited for so far.
double children_cpu_seconds() {
    rusage usage{};
    getrusage(RUSAGE_CHILDREN, &usage);
    auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
    return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

// A command's wall and CPU seconds (on a shared machine the CPU time says more of the program).
struct Seconds {
    double wall = 1e300;
    double cpu = 1e300;
};
Seconds command_seconds(const std::string& command) {
    const auto t0 = Clock::now();
    const double cpu0 = children_cpu_seconds();
    if (std::system(command.c_str()) != 0) throw std::runtime_error("failed: " + command);
    return {std::chrono::duration<double>(Clock::now() - t0).count(), children_cpu_seconds() - cpu0};
}
Seconds best(const Seconds& a, const Seconds& b) { return {std::min(a.wall, b.wall), std::min(a.cpu, b.cpu)}; }

// R, G, B of an image as float (any type), row by row.
std::vector<float> read_rgb(const fs::path& file) {
    OIIO::ImageBuf image(file.string());
    const OIIO::ROI roi = image.roi();
    std::vector<float> rgb(static_cast<std::size_t>(roi.npixels()) * 3);
    if (!image.get_pixels(OIIO::ROI(roi.xbegin, roi.xend, roi.ybegin, roi.yend, 0, 1, 0, 3), OIIO::TypeDesc::FLOAT, rgb.data()))
        throw std::runtime_error(file.string() + ": cannot read");
    return rgb;
}

int srgb8(float value) {
    const double v = std::clamp(static_cast<double>(value), 0.0, 1.0);
    return static_cast<int>(std::lround(255.0 * (v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055)));
}

struct CodeError {
    int p999 = 0;  // code difference at the 99.9th percentile of values
    int max = 0;
    double off2 = 0.0;  // share of values 2 or more codes off (the bound allows 0.1%)
};
CodeError code_error(const std::vector<int>& a, const std::vector<int>& b) {
    if (a.size() != b.size() || a.empty()) throw std::runtime_error("outputs of different sizes");
    std::vector<int> d(a.size());
    for (std::size_t i = 0; i < a.size(); ++i) d[i] = std::abs(a[i] - b[i]);
    std::sort(d.begin(), d.end());
    const auto off2 = static_cast<double>(d.end() - std::lower_bound(d.begin(), d.end(), 2)) / static_cast<double>(d.size());
    return {d[static_cast<std::size_t>(0.999 * static_cast<double>(d.size() - 1))], d.back(), off2};
}

std::vector<int> srgb8_codes(const fs::path& exr) {
    const std::vector<float> rgb = read_rgb(exr);
    std::vector<int> codes(rgb.size());
    std::transform(rgb.begin(), rgb.end(), codes.begin(), srgb8);
    return codes;
}

// The ACES SDR video view of an EXR, through lensfx's own display output (8-bit PNG), as codes.
std::vector<int> aces_codes(const std::string& lensfx, const fs::path& exr) {
    const fs::path png = fs::path(exr).replace_extension(".aces.png");
    command_seconds(fmt::format("{} -i '{}' -o '{}' -q", lensfx, exr.string(), png.string()));
    const std::vector<float> rgb = read_rgb(png);
    std::vector<int> codes(rgb.size());
    std::transform(rgb.begin(), rgb.end(), codes.begin(), [](float v) { return static_cast<int>(std::lround(255.0 * static_cast<double>(v))); });
    return codes;
}

}  // namespace

int main(int argc, char** argv) try {
    std::vector<std::string> lenses{"canon-70-200", "nikon-80-200", "itoh-zoom"};
    std::vector<std::string> gains{"1", "20"};
    std::vector<std::string> images;
    int repeat = 1;
    bool errors_only = false;  // each program once, for the display error (no warm cache run, no best of)
    std::string lensfx = LENSFX_BINARY;  // the program measured (another build's, copied aside)
    fs::path dir = fs::temp_directory_path() / "lensfx-bench-cull";
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
            return argv[++i];
        };
        if (a == "--lenses") lenses = split(next());
        else if (a == "--gains") gains = split(next());
        else if (a == "--repeat") repeat = std::max(1, std::stoi(next()));
        else if (a == "--dir") dir = next();
        else if (a == "--errors-only") errors_only = true;
        else if (a == "--lensfx") lensfx = next();
        else images.push_back(a);
    }
    if (images.empty()) throw std::invalid_argument("no image given");
    fs::create_directories(dir);
    fmt::print("{:<24} {:<16} {:>5} {:>9} {:>9} {:>7} {:>9} {:>9} {:>7} {:>11} {:>11} {:>9}\n", "image", "lens", "gain", "cull_s",
               "all_s", "speedup", "cull_cpu", "all_cpu", "cpu_x", "srgb8 p/max", "aces p/max", "srgb8 2+");
    for (const std::string& image : images) {
        for (const std::string& lens : lenses) {
            for (const std::string& gain : gains) {
                const fs::path cull = dir / "cull.exr", all = dir / "all.exr";
                const std::string base = fmt::format("{} -i '{}' --lens {} --gain {} -q", lensfx, image, lens, gain);
                const std::string with = fmt::format("{} -o '{}'", base, cull.string());
                const std::string without = fmt::format("{} -o '{}' --no-scene-cull", base, all.string());
                if (!errors_only) command_seconds(with);  // the bounds table, direct power and starburst into the cache
                Seconds t_cull, t_all;
                for (int r = 0; r < (errors_only ? 1 : repeat); ++r) {
                    t_cull = best(t_cull, command_seconds(with));
                    t_all = best(t_all, command_seconds(without));
                }
                const CodeError s = code_error(srgb8_codes(cull), srgb8_codes(all));
                const CodeError a = code_error(aces_codes(lensfx, cull), aces_codes(lensfx, all));
                fmt::print("{:<24} {:<16} {:>5} {:>9.2f} {:>9.2f} {:>6.1f}x {:>9.2f} {:>9.2f} {:>6.1f}x {:>5}/{:<5} {:>5}/{:<5} {:>8.4f}%\n",
                           fs::path(image).filename().string(), lens, gain, t_cull.wall, t_all.wall, t_all.wall / t_cull.wall,
                           t_cull.cpu, t_all.cpu, t_all.cpu / t_cull.cpu, s.p999, s.max, a.p999, a.max, 100.0 * s.off2);
                std::fflush(stdout);
            }
        }
    }
    return 0;
} catch (const std::exception& e) {
    fmt::print(stderr, "bench_cull: {}\n", e.what());
    return 1;
}
