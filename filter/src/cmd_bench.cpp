// `lensfx bench time-vs-error`: the GPU ghost renderer's time per flare next to its error against the
// dense CPU reference, for lens presets x light angles x quality settings (the default, a high setting,
// fixed grids without acceleration and the default with each acceleration switched off). Writes a CSV,
// prints each lens's Pareto front and optionally plots it.
//
// The error is measured on 32x32-pixel blocks: the reference's per-pixel shot noise (a finite number of
// rays per pixel) would otherwise dominate the difference, while the blocks still resolve each ghost's
// position and shape at the benchmark's 480x320.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <filter/image_io.h>
#include <fmt/core.h>
#include <gpu/acceleration.h>
#include <gpu/context.h>
#include <gpu/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/lens_file.h>
#include <optics/system.h>

#include "commands.h"
#include "text_pairs.h"

namespace lensfx::filter {
namespace {

constexpr int kErrorBlock = 32;
constexpr double kTimeTie = 1.05;
constexpr double kErrorTie = 1.01;

struct BenchArgs {
    bool quick = false;
    std::string csv;
    std::string plot;
    std::vector<std::string> lenses;
    std::string size = "480x320";
    int rays = 512;
    int repeat = 5;
    int threads = 2;
    std::string gpu = "auto";
    std::string from_csv;
};

struct Setting {
    std::string name;
    gpu::GpuFlareOptions options;
};

gpu::GpuFlareOptions fixed_grid(int grid) {
    gpu::GpuFlareOptions o;
    o.grid = grid;
    o.accel.bounding = gpu::Bounding::Coarse;  // the renderer's per-frame pupil bounds, as before the table
    o.accel.adaptive = false;
    o.accel.lod = false;
    o.accel.reduced = false;
    return o;
}

std::vector<Setting> settings() {
    std::vector<Setting> out;
    const gpu::GpuFlareOptions base;
    out.push_back({"default", base});
    gpu::GpuFlareOptions high = base;
    high.grid = 2 * base.grid;
    high.accel.ghost_threshold = base.accel.ghost_threshold / 10.0;
    out.push_back({"high", high});
    for (int grid : {16, 32, 64, 128}) out.push_back({fmt::format("grid{}", grid), fixed_grid(grid)});
    gpu::GpuFlareOptions o = base;
    o.accel.bounding = gpu::Bounding::Coarse;
    out.push_back({"bounding-coarse", o});
    o = base;
    o.accel.bounding = gpu::Bounding::None;
    out.push_back({"bounding-none", o});
    o = base;
    o.accel.adaptive = false;
    out.push_back({"no-adaptive", o});
    o = base;
    o.accel.lod = false;
    out.push_back({"no-lod", o});
    o = base;
    o.accel.reduced = false;
    out.push_back({"no-reduced", o});
    o = base;
    o.grid = base.grid / 2;
    out.push_back({fmt::format("base{}", o.grid), o});
    return out;
}

struct Row {
    std::string lens;
    std::array<double, 2> angle{};
    std::string setting;
    double ms = 0.0;
    double rel_l1 = 0.0;
    double power_err = 0.0;
};

struct Point {
    std::string setting;
    double ms = 0.0;
    double rel_l1 = 0.0;
    bool front = false;
};

// Mean over the angles per setting; a point is on the front when no other is at least as fast and as
// accurate and clearly better in one. Times within 5% and errors within 1% of each other count as ties:
// repeated runs on the shared 2-core machine differ by that much (settings whose images are identical,
// such as the LOD on a lens without dim ghosts, must not beat each other by noise).
std::vector<Point> pareto(const std::vector<Row>& rows, const std::string& lens) {
    std::map<std::string, std::array<double, 3>> sums;
    std::vector<std::string> order;
    for (const Row& r : rows) {
        if (r.lens != lens) continue;
        if (!sums.count(r.setting)) order.push_back(r.setting);
        auto& s = sums[r.setting];
        s[0] += r.ms;
        s[1] += r.rel_l1;
        s[2] += 1.0;
    }
    std::vector<Point> points;
    for (const std::string& name : order) {
        const auto& s = sums[name];
        points.push_back({name, s[0] / s[2], s[1] / s[2], false});
    }
    for (Point& p : points) {
        p.front = std::none_of(points.begin(), points.end(), [&](const Point& q) {
            const bool faster = q.ms < p.ms / kTimeTie;
            const bool more_accurate = q.rel_l1 < p.rel_l1 / kErrorTie;
            return q.ms <= p.ms * kTimeTie && q.rel_l1 <= p.rel_l1 * kErrorTie && (faster || more_accurate);
        });
    }
    return points;
}

// A 3x5 pixel font for the plot's labels: rows top to bottom, 3 bits each (left = 4).
const std::map<char, std::array<int, 5>>& glyphs() {
    static const std::map<char, std::array<int, 5>> g = {
        {'0', {7, 5, 5, 5, 7}}, {'1', {2, 6, 2, 2, 7}}, {'2', {7, 1, 7, 4, 7}}, {'3', {7, 1, 3, 1, 7}},
        {'4', {5, 5, 7, 1, 1}}, {'5', {7, 4, 7, 1, 7}}, {'6', {7, 4, 7, 5, 7}}, {'7', {7, 1, 1, 2, 2}},
        {'8', {7, 5, 7, 5, 7}}, {'9', {7, 5, 7, 1, 7}}, {'.', {0, 0, 0, 0, 2}}, {'-', {0, 0, 7, 0, 0}},
        {' ', {0, 0, 0, 0, 0}}, {':', {0, 2, 0, 2, 0}}, {'/', {1, 1, 2, 4, 4}}, {'=', {0, 7, 0, 7, 0}},
        {'a', {2, 5, 7, 5, 5}}, {'b', {6, 5, 6, 5, 6}}, {'c', {7, 4, 4, 4, 7}}, {'d', {6, 5, 5, 5, 6}},
        {'e', {7, 4, 6, 4, 7}}, {'f', {7, 4, 6, 4, 4}}, {'g', {7, 4, 5, 5, 7}}, {'h', {5, 5, 7, 5, 5}},
        {'i', {7, 2, 2, 2, 7}}, {'j', {1, 1, 1, 5, 7}}, {'k', {5, 5, 6, 5, 5}}, {'l', {4, 4, 4, 4, 7}},
        {'m', {5, 7, 7, 5, 5}}, {'n', {6, 5, 5, 5, 5}}, {'o', {7, 5, 5, 5, 7}}, {'p', {7, 5, 7, 4, 4}},
        {'q', {7, 5, 5, 7, 1}}, {'r', {6, 5, 6, 5, 5}}, {'s', {7, 4, 7, 1, 7}}, {'t', {7, 2, 2, 2, 2}},
        {'u', {5, 5, 5, 5, 7}}, {'v', {5, 5, 5, 5, 2}}, {'w', {5, 5, 7, 7, 5}}, {'x', {5, 5, 2, 5, 5}},
        {'y', {5, 5, 2, 2, 2}}, {'z', {7, 1, 2, 4, 7}}, {'(', {1, 2, 2, 2, 1}}, {')', {4, 2, 2, 2, 4}},
    };
    return g;
}

class Canvas {
public:
    Canvas(int w, int h) : w_(w), h_(h), rgb_(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3, 255) {}
    void dot(int x, int y, std::array<std::uint8_t, 3> c) {
        if (x < 0 || y < 0 || x >= w_ || y >= h_) return;
        std::uint8_t* p = rgb_.data() + (static_cast<std::size_t>(y) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(x)) * 3;
        p[0] = c[0];
        p[1] = c[1];
        p[2] = c[2];
    }
    void line(double x0, double y0, double x1, double y1, std::array<std::uint8_t, 3> c) {
        const int n = static_cast<int>(std::max(std::abs(x1 - x0), std::abs(y1 - y0))) + 1;
        for (int i = 0; i <= n; ++i) {
            const double t = static_cast<double>(i) / n;
            dot(static_cast<int>(std::lround(x0 + (x1 - x0) * t)), static_cast<int>(std::lround(y0 + (y1 - y0) * t)), c);
        }
    }
    void disc(double x, double y, int r, std::array<std::uint8_t, 3> c) {
        for (int dy = -r; dy <= r; ++dy) {
            for (int dx = -r; dx <= r; ++dx) {
                if (dx * dx + dy * dy <= r * r) dot(static_cast<int>(std::lround(x)) + dx, static_cast<int>(std::lround(y)) + dy, c);
            }
        }
    }
    void text(int x, int y, const std::string& s, std::array<std::uint8_t, 3> c, int scale = 2) {
        for (char ch : s) {
            const char key = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
            auto it = glyphs().find(key);
            if (it != glyphs().end()) {
                for (int row = 0; row < 5; ++row) {
                    for (int col = 0; col < 3; ++col) {
                        if (!(it->second[static_cast<std::size_t>(row)] & (4 >> col))) continue;
                        for (int sy = 0; sy < scale; ++sy) {
                            for (int sx = 0; sx < scale; ++sx) dot(x + col * scale + sx, y + row * scale + sy, c);
                        }
                    }
                }
            }
            x += 4 * scale;
        }
    }
    void write(const std::string& path) const {
        WriteOptions options;
        options.dither = colour::Dither::None;
        write_image(image_frame(w_, h_, 3, PixelType::uint8, rgb_.data()), path, options);
    }

private:
    int w_;
    int h_;
    std::vector<std::uint8_t> rgb_;
};

// One panel per lens: log time across, log relative L1 up; the front joined, the default red, high
// orange, fixed grids grey, the default with one acceleration off blue.
void write_plot(const std::vector<Row>& rows, const std::vector<std::string>& lenses, const std::string& path) {
    const int pw = 520;
    const int ph = 380;
    Canvas canvas(pw * static_cast<int>(lenses.size()), ph);
    for (std::size_t l = 0; l < lenses.size(); ++l) {
        const std::vector<Point> points = pareto(rows, lenses[l]);
        double xmin = 1e300, xmax = 0, ymin = 1e300, ymax = 0;
        for (const Point& p : points) {
            xmin = std::min(xmin, p.ms);
            xmax = std::max(xmax, p.ms);
            ymin = std::min(ymin, std::max(p.rel_l1, 1e-5));
            ymax = std::max(ymax, std::max(p.rel_l1, 1e-5));
        }
        const double lx0 = std::floor(std::log10(xmin)), lx1 = std::ceil(std::log10(xmax));
        // The errors span less than a decade: the error axis is fitted to them, ticked at 1, 2 and 5.
        const double ly0 = std::log10(ymin) - 0.1, ly1 = std::log10(ymax) + 0.1;
        const int ox = static_cast<int>(l) * pw + 70;
        const int oy = ph - 50;
        const int aw = pw - 100;
        const int ah = ph - 90;
        auto px = [&](double ms) { return ox + aw * (std::log10(ms) - lx0) / std::max(1.0, lx1 - lx0); };
        auto py = [&](double e) { return oy - ah * (std::log10(std::max(e, 1e-5)) - ly0) / (ly1 - ly0); };
        const std::array<std::uint8_t, 3> black{0, 0, 0};
        const std::array<std::uint8_t, 3> light{220, 220, 220};
        for (double d = lx0; d <= lx1; d += 1.0) {
            canvas.line(px(std::pow(10.0, d)), oy, px(std::pow(10.0, d)), oy - ah, light);
            canvas.text(static_cast<int>(px(std::pow(10.0, d))) - 12, oy + 8, fmt::format("{:g}", std::pow(10.0, d)), black);
        }
        for (double d = std::floor(ly0); d <= ly1; d += 1.0) {
            for (double m : {1.0, 2.0, 5.0}) {
                const double e = m * std::pow(10.0, d);
                if (std::log10(e) < ly0 || std::log10(e) > ly1) continue;
                canvas.line(ox, py(e), ox + aw, py(e), light);
                canvas.text(ox - 64, static_cast<int>(py(e)) - 5, fmt::format("{:g}", e), black);
            }
        }
        canvas.line(ox, oy, ox + aw, oy, black);
        canvas.line(ox, oy, ox, oy - ah, black);
        canvas.text(ox, 10, lenses[l], black, 3);
        canvas.text(ox + aw - 150, oy + 26, "ms per flare", black);
        canvas.text(ox - 64, 36, "rel l1 (32px blocks)", black);
        std::vector<Point> front;
        for (const Point& p : points) {
            if (p.front) front.push_back(p);
        }
        std::sort(front.begin(), front.end(), [](const Point& a, const Point& b) { return a.ms < b.ms; });
        for (std::size_t i = 1; i < front.size(); ++i) {
            canvas.line(px(front[i - 1].ms), py(front[i - 1].rel_l1), px(front[i].ms), py(front[i].rel_l1), {0, 150, 0});
        }
        for (const Point& p : points) {
            std::array<std::uint8_t, 3> c{40, 90, 220};
            if (p.setting == "default") c = {220, 20, 20};
            else if (p.setting == "high") c = {240, 140, 0};
            else if (p.setting.rfind("grid", 0) == 0) c = {120, 120, 120};
            canvas.disc(px(p.ms), py(p.rel_l1), 4, c);
            canvas.text(static_cast<int>(px(p.ms)) + 6, static_cast<int>(py(p.rel_l1)) - 4, p.setting, c, 1);
        }
    }
    canvas.write(path);
}

// Rows of a CSV this command wrote (the quoted angle holds a comma).
std::vector<Row> read_csv(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error(fmt::format("{}: cannot read", path));
    std::vector<Row> rows;
    std::string line;
    std::getline(in, line);
    for (int number = 2; std::getline(in, line); ++number) {
        Row r;
        char lens[256] = {};
        char setting[256] = {};
        if (std::sscanf(line.c_str(), "%255[^,],\"%lf,%lf\",%255[^,],%lf,%lf,%lf", lens, &r.angle[0], &r.angle[1], setting,
                        &r.ms, &r.rel_l1, &r.power_err) != 7) {
            throw std::runtime_error(fmt::format("{}:{}: not a time-vs-error row", path, number));
        }
        r.lens = lens;
        r.setting = setting;
        rows.push_back(r);
    }
    return rows;
}

void summarise(const std::vector<Row>& rows, const std::vector<std::string>& lenses) {
    for (const std::string& lens : lenses) {
        const std::vector<Point> points = pareto(rows, lens);
        fmt::print("{} (mean over the angles, {}px blocks)\n", lens, kErrorBlock);
        fmt::print("  {:<16} {:>9} {:>8}  front\n", "setting", "ms", "rel_l1");
        const Point* def = nullptr;
        const Point* g128 = nullptr;
        for (const Point& p : points) {
            fmt::print("  {:<16} {:9.1f} {:8.4f}  {}\n", p.setting, p.ms, p.rel_l1, p.front ? "yes" : "");
            if (p.setting == "default") def = &p;
            if (p.setting == "grid128") g128 = &p;
        }
        if (def && g128) {
            fmt::print("  default: {:.1f}x faster than grid128, rel_l1 {:.4f} vs {:.4f}; on the front: {}\n",
                       g128->ms / def->ms, def->rel_l1, g128->rel_l1, def->front ? "yes" : "NO");
        }
    }
}

void run_time_vs_error(const BenchArgs& args) {
    if (!args.from_csv.empty()) {
        const std::vector<Row> rows = read_csv(args.from_csv);
        std::vector<std::string> lenses;
        for (const Row& r : rows) {
            if (std::find(lenses.begin(), lenses.end(), r.lens) == lenses.end()) lenses.push_back(r.lens);
        }
        summarise(rows, lenses);
        if (!args.plot.empty()) write_plot(rows, lenses, args.plot);
        return;
    }
    std::vector<std::string> lenses = args.lenses;
    if (lenses.empty()) {
        lenses = args.quick ? std::vector<std::string>{"brendel-tessar"}
                            : std::vector<std::string>{"brendel-tessar", "angenieux-double-gauss", "cooke-triplet"};
    }
    std::vector<std::array<double, 2>> angles = {{8.0, 5.0}, {-3.0, 12.0}, {15.0, -6.0}};
    if (args.quick) angles.resize(2);
    const auto size = parse_pair_of<int>(args.size, 'x');
    if (!size) throw std::invalid_argument(fmt::format("--size {}: WxH expected", args.size));
    gpu::FlareView view;
    view.width = (*size)[0];
    view.height = (*size)[1];

    const gpu::Context context(gpu::parse_platform(args.gpu));
    gpu::FlareRenderer renderer(context);
    std::vector<Row> rows;
    using Clock = std::chrono::steady_clock;
    for (const std::string& name : lenses) {
        const optics::System system = optics::realize(optics::load_lens(name));
        for (const auto& angle : angles) {
            view.angle_x_deg = angle[0];
            view.angle_y_deg = angle[1];
            gpu::ReferenceOptions ro;
            ro.rays = args.rays;
            ro.threads = args.threads;
            ro.per_ghost_power = false;
            ro.ghost_bounds = true;
            auto start = Clock::now();
            const gpu::FlareImage reference = gpu::render_reference(system, view, ro);
            const double ref_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
            fmt::print(stderr, "{} ({}, {}): reference {}x{} rays per ghost and wavelength, {:.0f} ms\n", name, angle[0],
                       angle[1], args.rays, args.rays, ref_ms);
            // Every setting once untimed (fills its caches, e.g. the bounds table), then the timed rounds
            // interleaved so that the others' load on the machine spreads over all settings alike.
            std::vector<Setting> list = settings();
            std::vector<double> fastest(list.size(), 1e300);
            std::vector<gpu::FlareImage> images(list.size());
            std::vector<gpu::RenderStats> stats(list.size());
            for (Setting& setting : list) {
                setting.options.accel.cache_dir = "none";
                renderer.render(system, view, setting.options);
            }
            for (int k = 0; k < std::max(1, args.repeat); ++k) {
                for (std::size_t i = 0; i < list.size(); ++i) {
                    start = Clock::now();
                    images[i] = renderer.render(system, view, list[i].options);
                    fastest[i] = std::min(fastest[i], std::chrono::duration<double, std::milli>(Clock::now() - start).count());
                    stats[i] = renderer.last_stats();
                }
            }
            for (std::size_t i = 0; i < list.size(); ++i) {
                const gpu::FlareError error = gpu::compare_flare(images[i], reference, view, kErrorBlock);
                rows.push_back({name, angle, list[i].name, fastest[i], error.block_l1, error.total});
                fmt::print(stderr, "  {:<16} {:8.1f} ms  rel_l1 {:.4f}  power {:.4f}  ghosts drawn {} skipped {} reduced {}\n",
                           list[i].name, fastest[i], error.block_l1, error.total, stats[i].ghosts_drawn,
                           stats[i].ghosts_skipped, stats[i].ghosts_reduced);
            }
        }
    }

    std::ofstream csv(args.csv);
    if (!csv) throw std::runtime_error(fmt::format("{}: cannot write", args.csv));
    csv << "lens,angle,setting,ms,rel_l1,power_err\n";
    for (const Row& r : rows) {
        csv << fmt::format("{},\"{:g},{:g}\",{},{:.2f},{:.5f},{:.5f}\n", r.lens, r.angle[0], r.angle[1], r.setting, r.ms,
                           r.rel_l1, r.power_err);
    }
    if (!csv) throw std::runtime_error(fmt::format("{}: cannot write", args.csv));

    summarise(rows, lenses);
    if (!args.plot.empty()) write_plot(rows, lenses, args.plot);
}

}  // namespace

void register_bench_command(CLI::App& app) {
    auto args = std::make_shared<BenchArgs>();
    auto* bench = app.add_subcommand("bench", "Benchmarks");
    bench->require_subcommand(1);
    auto* tve = bench->add_subcommand("time-vs-error",
                                      "GPU ghost renderer: ms per flare next to the error against the dense CPU reference");
    tve->add_flag("--quick", args->quick, "One lens, two light angles");
    tve->add_option("--csv", args->csv, "Output CSV: lens, angle, setting, ms, rel_l1, power_err");
    tve->add_option("--from-csv", args->from_csv, "Summarise and plot an earlier run's CSV instead of measuring");
    tve->add_option("--plot", args->plot, "PNG plot of each lens's Pareto front");
    tve->add_option("--lens", args->lenses, "Lens presets or files (repeatable; default: three presets, one with --quick)");
    tve->add_option("--size", args->size, "Image WxH in pixels")->capture_default_str();
    tve->add_option("--rays", args->rays, "Reference: N x N rays per ghost and wavelength")->capture_default_str();
    tve->add_option("--repeat", args->repeat, "Timed renders per setting (the fastest is reported: others load the machine)")->capture_default_str();
    tve->add_option("--threads", args->threads, "Reference: worker threads")->capture_default_str();
    tve->add_option("--gpu", args->gpu, "EGL platform: auto, device or surfaceless")
        ->check(CLI::IsMember({"auto", "device", "surfaceless"}))->capture_default_str();
    tve->callback([args] {
        if (args->csv.empty() == args->from_csv.empty()) {
            throw std::invalid_argument("bench time-vs-error: give --csv FILE to measure or --from-csv FILE to summarise");
        }
        run_time_vs_error(*args);
    });
}

}  // namespace lensfx::filter
