// bench_memory: the peak resident memory (max RSS, from wait4's rusage of each child) and wall time of the
// lensfx program on the cases of issue 14: an 8K half RGB frame passed through, with a flare written as EXR
// and as PNG, an 8K sequence with --queue-depth 1 (and under --memory-limit 2500M), and `lensfx flare` on
// lenses of many surfaces (a Cooke triplet behind flat plates). Each case is one run of the program.
//   bench_memory [--binary PATH] [--size N (8192)] [--frames N (3)] [--lens NAME (angenieux-double-gauss)]
//                [--surfaces 100,300,1000 (empty: none)] [--no-limit-cases] [--no-frame-cases] [--dir DIR]
// It also runs the hostile sizes: tiny EXRs declaring 30000^2 and 10^6^2 display windows (passed through
// and flared) and a raw stream of --size 99999x99999; --no-frame-cases leaves out the 8K frame cases.
// --binary runs another build (e.g. an older one for before/after figures; cases with --memory-limit
// are skipped for a binary that does not know the option).
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <fmt/core.h>

#include "plate_lens.h"

namespace fs = std::filesystem;

namespace {

struct Options {
    std::string binary = LENSFX_BINARY;
    int size = 8192;
    int frames = 3;
    std::string lens = "angenieux-double-gauss";
    std::vector<int> surfaces{100, 300, 1000};
    bool limit_cases = true;
    bool frame_cases = true;
    fs::path dir;
};

struct Result {
    int exit_code = -1;
    double peak_gb = 0.0;  // max RSS, 10^9 bytes
    double wall_s = 0.0;
    std::string first_error_line;
};

// Runs `command` through /bin/sh with stdout to /dev/null and stderr to a file; the child's own rusage.
Result measure(const std::string& command, const fs::path& log) {
    const auto t0 = std::chrono::steady_clock::now();
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
        const std::string line = fmt::format("exec {} > /dev/null 2> \"{}\"", command, log.string());
        ::execl("/bin/sh", "sh", "-c", line.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    int status = 0;
    rusage usage{};
    ::wait4(pid, &status, 0, &usage);
    Result r;
    r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    r.peak_gb = static_cast<double>(usage.ru_maxrss) * 1024.0 / 1e9;  // ru_maxrss is in KiB on Linux
    std::ifstream in(log);
    std::getline(in, r.first_error_line);
    return r;
}

// An N x N half RGB frame: a dim gradient with one bright light (a 5 x 5 disc of 5000) off the centre, so
// the flare stage finds one light and draws its ghosts and starburst over the whole frame.
void make_frame(const fs::path& path, int n) {
    OIIO::ImageSpec spec(n, n, 3, OIIO::TypeHalf);
    spec.attribute("compression", "zip");
    std::vector<float> px(static_cast<std::size_t>(n) * static_cast<std::size_t>(n) * 3);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            for (int c = 0; c < 3; ++c)
                px[(static_cast<std::size_t>(y) * static_cast<std::size_t>(n) + static_cast<std::size_t>(x)) * 3 + static_cast<std::size_t>(c)] =
                    0.05f + 0.1f * static_cast<float>(x + y) / static_cast<float>(2 * n);
    const int lx = n * 7 / 10, ly = n * 3 / 10;
    for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx)
            if (dx * dx + dy * dy <= 5)
                for (int c = 0; c < 3; ++c)
                    px[(static_cast<std::size_t>(ly + dy) * static_cast<std::size_t>(n) + static_cast<std::size_t>(lx + dx)) * 3 + static_cast<std::size_t>(c)] = 5000.0f;
    auto out = OIIO::ImageOutput::create(path.string());
    if (!out || !out->open(path.string(), spec) || !out->write_image(OIIO::TypeFloat, px.data()) || !out->close())
        throw std::runtime_error(fmt::format("cannot write {}", path.string()));
}

// A half RGB EXR of 8 x 8 pixels (one light of 1000 on 0.1) at (4, 4) in a display window of `display`
// squared: a file of a few KB that declares a huge frame.
void make_windowed_frame(const fs::path& path, int display) {
    constexpr int n = 8;
    OIIO::ImageSpec spec(n, n, 3, OIIO::TypeHalf);
    spec.x = spec.y = 4;
    spec.full_width = spec.full_height = display;
    std::vector<float> px(n * n * 3, 0.1f);
    for (int c = 0; c < 3; ++c) px[static_cast<std::size_t>((n / 2 * n + n / 2) * 3 + c)] = 1000.0f;
    auto out = OIIO::ImageOutput::create(path.string());
    if (!out || !out->open(path.string(), spec) || !out->write_image(OIIO::TypeFloat, px.data()) || !out->close())
        throw std::runtime_error(fmt::format("cannot write {}", path.string()));
}

// A lens of `surfaces` surfaces (tests/memory/plate_lens.h) written to `dir`.
fs::path make_lens(const fs::path& dir, int surfaces) {
    const fs::path path = dir / fmt::format("plates-{}.toml", surfaces);
    std::ofstream(path) << lensfx::test::plate_lens_toml(surfaces);
    return path;
}

std::vector<int> parse_list(const std::string& text) {
    std::vector<int> out;
    std::stringstream ss(text);
    for (std::string item; std::getline(ss, item, ',');)
        if (!item.empty()) out.push_back(std::stoi(item));
    return out;
}

Options parse(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
            return argv[++i];
        };
        if (a == "--binary") o.binary = next();
        else if (a == "--size") o.size = std::stoi(next());
        else if (a == "--frames") o.frames = std::stoi(next());
        else if (a == "--lens") o.lens = next();
        else if (a == "--surfaces") o.surfaces = parse_list(next());
        else if (a == "--no-limit-cases") o.limit_cases = false;
        else if (a == "--no-frame-cases") o.frame_cases = false;
        else if (a == "--dir") o.dir = next();
        else throw std::invalid_argument("unknown argument " + a);
    }
    return o;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        const Options o = parse(argc, argv);
        const fs::path dir = o.dir.empty() ? fs::temp_directory_path() / fmt::format("lensfx-bench-memory-{}", ::getpid()) : o.dir;
        fs::create_directories(dir);
        const std::string bin = fmt::format("\"{}\"", o.binary);
        const fs::path cache = dir / "cache";
        fs::create_directories(cache);
        ::setenv("LENSFX_CACHE_DIR", cache.c_str(), 1);

        const fs::path frame = dir / "in.0001.exr";
        if (o.frame_cases && !fs::exists(frame)) make_frame(frame, o.size);
        for (int i = 2; o.frame_cases && i <= o.frames; ++i) {
            const fs::path copy = dir / fmt::format("in.{:04d}.exr", i);
            if (!fs::exists(copy)) fs::copy_file(frame, copy);
        }
        const std::string in = fmt::format("\"{}\"", frame.string());
        const std::string seq = fmt::format("\"{}\" --frames 1-{}", (dir / "in.####.exr").string(), o.frames);
        const std::string lens = fmt::format(" --lens {}", o.lens);
        auto out = [&](const std::string& name) { return fmt::format("\"{}\"", (dir / name).string()); };

        struct Case {
            std::string name, command;
        };
        std::vector<Case> cases;
        if (o.frame_cases) {
            cases = {
                {fmt::format("{0}x{0} pass-through", o.size), fmt::format("{} -i {} -o {}", bin, in, out("pass.exr"))},
                {fmt::format("{0}x{0} flare, EXR out", o.size), fmt::format("{} -i {} -o {}{}", bin, in, out("flare.exr"), lens)},
                {fmt::format("{0}x{0} flare, PNG out", o.size), fmt::format("{} -i {} -o {}{}", bin, in, out("flare.png"), lens)},
                {fmt::format("{0}x{0} x {1} frames, flare, --queue-depth 1", o.size, o.frames),
                 fmt::format("{} -i {} -o {} --queue-depth 1{}", bin, seq, out("seq.####.exr"), lens)},
            };
        }
        for (int display : {30000, 1000000}) {
            const fs::path tiny = dir / fmt::format("window-{}.exr", display);
            make_windowed_frame(tiny, display);
            const std::string t = fmt::format("\"{}\"", tiny.string());
            cases.push_back({fmt::format("8x8 data in a {0}x{0} display window, pass-through", display),
                             fmt::format("{} -i {} -o {}", bin, t, out("window-pass.exr"))});
            cases.push_back({fmt::format("8x8 data in a {0}x{0} display window, flare", display),
                             fmt::format("{} -i {} -o {}{}", bin, t, out("window-flare.exr"), lens)});
        }
        cases.push_back({"raw stream, --size 99999x99999", fmt::format("{} -i - -o - --pix-fmt gbrpf32le --size 99999x99999 < /dev/null", bin)});
        if (o.frame_cases && o.limit_cases) {
            cases.push_back({fmt::format("{0}x{0} x {1} frames, flare, --memory-limit 2500M", o.size, o.frames),
                             fmt::format("{} -i {} -o {} --memory-limit 2500M{}", bin, seq, out("lim.####.exr"), lens)});
        }
        for (int n : o.surfaces) {
            const fs::path lens_file = make_lens(dir, n);
            cases.push_back({fmt::format("lensfx flare, lens of {} surfaces", n),
                             fmt::format("{} flare --lens \"{}\" --angle 5,3 -o {}", bin, lens_file.string(), out("many.exr"))});
        }

        fmt::print("lensfx: {}\nframe: {}x{} half RGB, lens {}\n\n", o.binary, o.size, o.size, o.lens);
        fmt::print("{:<52} {:>5} {:>12} {:>8}  {}\n", "case", "exit", "peak RSS GB", "wall s", "stderr (first line)");
        for (const Case& c : cases) {
            const Result r = measure(c.command, dir / "stderr.txt");
            fmt::print("{:<52} {:>5} {:>12.2f} {:>8.1f}  {}\n", c.name, r.exit_code, r.peak_gb, r.wall_s,
                       r.first_error_line.substr(0, 160));
            std::fflush(stdout);
        }
        if (o.dir.empty()) fs::remove_all(dir);
    } catch (const std::exception& e) {
        fmt::print(stderr, "bench_memory: {}\n", e.what());
        return 1;
    }
    return 0;
}
