// bench_frame: seconds per frame of `lensfx -i IN -o OUT --lens LENS` on real HDR stills, start to finish
// (stage set-up, GL context and shaders, starburst, read, detect, render, composite, write), split by
// stage from the pipeline's report; then frames per second on a synthetic 1080p sequence of a light
// moving in sub-pixel steps over a dim gradient. "process" is the whole `lensfx` program (the binary of this
// build, started by the shell) with the warm cache: the best of three runs.
//   bench_frame [--lens NAME] [--grid N] [--frames N (0: no sequence)] [--cold-only] [--gpu auto|device|surfaceless]
//               [--sequence-dir DIR (write the sequence there and keep it, e.g. to profile)] [IMAGE...]
// The starburst cache ($LENSFX_CACHE_DIR) is pointed at a fresh directory: each still runs cold (empty
// cache) then warm (the texture on disk), so both start-up costs are printed.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <exception>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <filter/flare_stage.h>
#include <filter/pipeline.h>
#include <filter/process_heap.h>

namespace fs = std::filesystem;
using namespace lensfx::filter;

namespace {

using Clock = std::chrono::steady_clock;

struct Run {
    double wall_s = 0.0;  // stage construction to the last frame written
    RunReport report;
};

Run run(const std::string& input, const std::string& output, const FlareSettings& settings) {
    const auto t0 = Clock::now();
    FlareStage stage(settings);
    PipelineOptions o;
    o.input = input;
    o.output = output;
    o.quiet = true;
    Run r;
    r.report = run_pipeline(o, {&stage});
    r.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
    return r;
}

double stage_ms(const FrameRecord& f, const std::string& name) {
    for (const auto& [n, ms] : f.stage_ms)
        if (n == name) return ms;
    return 0.0;
}

void print_header() {
    fmt::print("{:<22} {:>6} {:>8} {:>8} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7}\n", "image", "cache", "process",
               "total_s", "read", "detect", "direct", "ghosts", "starbst", "extend", "compos", "write");
}

// The wall time of a shell command, in seconds; throws when it fails.
double command_seconds(const std::string& command) {
    const auto t0 = Clock::now();
    if (std::system(command.c_str()) != 0) throw std::runtime_error("failed: " + command);
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// The best of `runs` whole `lensfx` processes on input -> output.
double process_seconds(const std::string& input, const std::string& output, const FlareSettings& s, int runs = 3) {
    const std::string command = fmt::format("{} -i '{}' -o '{}' --lens {} --grid {} --gpu {} -q", LENSFX_BINARY, input,
                                            output, s.lens, s.grid, s.gpu);
    double best = 1e300;
    for (int i = 0; i < runs; ++i) best = std::min(best, command_seconds(command));
    return best;
}

void print_frame(const std::string& label, const std::string& cache, double process_s, double total_s, const FrameRecord& f) {
    const std::string process = process_s > 0.0 ? fmt::format("{:.3f}", process_s) : "-";
    fmt::print("{:<22} {:>6} {:>8} {:>8.3f} {:>7.3f} {:>7.3f} {:>7.3f} {:>7.3f} {:>7.3f} {:>7.3f} {:>7.3f} {:>7.3f}\n", label,
               cache, process, total_s, f.read_ms / 1e3, stage_ms(f, "flare.detect") / 1e3, stage_ms(f, "flare.direct") / 1e3,
               stage_ms(f, "flare.ghosts") / 1e3, stage_ms(f, "flare.starburst") / 1e3,
               stage_ms(f, "flare.extended") / 1e3, stage_ms(f, "flare.composite") / 1e3, f.write_ms / 1e3);
}

// A dim gradient with one Gaussian light (sigma 1.5 px, constant flux) moving 0.37 px right and 0.11 px
// down per frame, written as RGB half EXR frames dir/seq.0001.exr...
void write_sequence(const fs::path& dir, int frames, int width, int height) {
    std::vector<float> rgb(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
    for (int f = 1; f <= frames; ++f) {
        const double cx = 0.3 * width + 0.37 * f, cy = 0.35 * height + 0.11 * f;
        for (int y = 0; y < height; ++y) {
            for (int x = 0; x < width; ++x) {
                const double bg = 0.02 + 0.1 * x / width;
                const double r2 = (x + 0.5 - cx) * (x + 0.5 - cx) + (y + 0.5 - cy) * (y + 0.5 - cy);
                const double light = 500.0 * std::exp(-r2 / (2.0 * 1.5 * 1.5));
                float* p = &rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 3];
                p[0] = static_cast<float>(bg + light);
                p[1] = static_cast<float>(0.9 * bg + 0.95 * light);
                p[2] = static_cast<float>(0.8 * bg + 0.85 * light);
            }
        }
        const std::string path = (dir / fmt::format("seq.{:04}.exr", f)).string();
        auto out = OIIO::ImageOutput::create(path);
        OIIO::ImageSpec spec(width, height, 3, OIIO::TypeDesc::HALF);
        spec.attribute("compression", "piz");
        if (!out || !out->open(path, spec) || !out->write_image(OIIO::TypeFloat, rgb.data()) || !out->close())
            throw std::runtime_error(fmt::format("{}: cannot write the benchmark sequence", path));
    }
}

}  // namespace

int main(int argc, char** argv) try {
    // As the lensfx program does: the in-process pipeline measured as users run it.
    const HeapWarmer warmer(tune_process_heap());
    std::setvbuf(stdout, nullptr, _IOLBF, 0);  // each line as soon as it is measured
    FlareSettings settings;
    settings.lens = "mld-double-gauss";
    int frames = 24;
    bool cold_only = false;
    std::string sequence_dir;
    std::vector<std::string> images;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc) throw std::runtime_error(a + " needs a value");
            return argv[++i];
        };
        if (a == "--lens") settings.lens = next();
        else if (a == "--grid") settings.grid = std::stoi(next());
        else if (a == "--frames") frames = std::stoi(next());
        else if (a == "--gpu") settings.gpu = next();
        else if (a == "--cold-only") cold_only = true;
        else if (a == "--sequence-dir") sequence_dir = next();
        else images.push_back(a);
    }
    if (images.empty()) {
        const std::string data = "/work/shared/data/hdr/";
        images = {data + "ScanLines/CandleGlass.exr", data + "ScanLines/StillLife.exr", data + "Tiles/GoldenGate.exr"};
    }
    const fs::path tmp = fs::temp_directory_path() / fmt::format("lensfx-bench-frame-{}", ::getpid());
    fs::create_directories(tmp / "cache");
    ::setenv("LENSFX_CACHE_DIR", (tmp / "cache").c_str(), 1);

    fmt::print("lens {}, grid {}, threshold {}, max lights {}; seconds\n", settings.lens, settings.grid,
               settings.threshold, settings.max_lights);
    print_header();
    for (const std::string& image : images) {
        fs::remove_all(tmp / "cache");
        for (const char* cache : {"cold", "warm"}) {
            if (cold_only && std::string(cache) == "warm") break;
            const Run r = run(image, (tmp / "out.exr").string(), settings);
            const bool warm = std::string(cache) == "warm";
            const double process = warm ? process_seconds(image, (tmp / "out.exr").string(), settings) : 0.0;
            print_frame(fs::path(image).stem().string(), cache, process, r.wall_s, r.report.frames.at(0));
        }
    }

    if (frames < 2) {
        fs::remove_all(tmp);
        return 0;
    }
    const fs::path seq = sequence_dir.empty() ? tmp / "seq" : fs::path(sequence_dir);
    fs::create_directories(seq);
    write_sequence(seq, frames, 1920, 1080);
    const Run r = run((seq / "seq.####.exr").string(), (seq / "out.####.exr").string(), settings);
    double process = 0.0;
    for (std::size_t i = 1; i < r.report.frames.size(); ++i) process += r.report.frames[i].process_ms;
    const double n = static_cast<double>(r.report.frames.size());
    fmt::print("\n1080p sequence, {} frames, one moving light (warm cache): {:.3f} s in all, {:.2f} frames/s, "
               "{:.3f} s per frame; flare stage {:.3f} s per frame after the first\n",
               r.report.frames.size(), r.wall_s, n / r.wall_s, r.wall_s / n, process / (n - 1) / 1e3);
    const double whole = process_seconds((seq / "seq.####.exr").string(), (seq / "out.####.exr").string(), settings, 1);
    fmt::print("the lensfx program on it: {:.3f} s in all, {:.3f} s per frame\n", whole, whole / n);
    print_header();
    print_frame("seq frame 2", "warm", 0.0, r.report.frames.at(1).process_ms / 1e3, r.report.frames.at(1));
    fs::remove_all(tmp);
    return 0;
} catch (const std::exception& e) {
    fmt::print(stderr, "bench_frame: {}\n", e.what());
    return 1;
}
