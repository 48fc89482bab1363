// `lensfx bench time-vs-error`: the GPU ghost renderer's time per flare next to its error against the
// dense CPU reference, for lens presets x light angles x quality settings (the default, a high setting,
// fixed grids without acceleration and the default with each acceleration switched off). Writes a CSV,
// prints each lens's Pareto front and optionally writes the fronts as CSV (plotted by bench/plot_time_vs_error.gp).
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

#include <fmt/core.h>
#include <gpu/acceleration.h>
#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/lens_file.h>
#include <optics/system.h>
#include <optics/text_pairs.h>

#include "commands.h"

namespace lensfx::filter {
namespace {

constexpr int kErrorBlock = 32;
constexpr double kTimeTie = 1.05;
constexpr double kErrorTie = 1.01;

struct BenchArgs {
    bool quick = false;
    std::string csv;
    std::string means;
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

// Each lens's mean points as CSV (lens, setting, ms, rel_l1, front: 1 on the Pareto front), what
// bench/plot_time_vs_error.gp plots.
void write_means(const std::vector<Row>& rows, const std::vector<std::string>& lenses, const std::string& path) {
    std::ofstream out(path);
    out << "lens,setting,ms,rel_l1,front\n";
    for (const std::string& lens : lenses)
        for (const Point& p : pareto(rows, lens))
            out << fmt::format("{},{},{:.3f},{:.6f},{}\n", lens, p.setting, p.ms, p.rel_l1, p.front ? 1 : 0);
    if (!out) throw std::runtime_error(fmt::format("{}: cannot write", path));
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
        if (!args.means.empty()) write_means(rows, lenses, args.means);
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
    flare::FlareView view;
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
            flare::ReferenceOptions ro;
            ro.rays = args.rays;
            ro.threads = args.threads;
            ro.per_ghost_power = false;
            ro.ghost_bounds = true;
            auto start = Clock::now();
            const flare::FlareImage reference = flare::render_reference(system, view, ro);
            const double ref_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
            fmt::print(stderr, "{} ({}, {}): reference {}x{} rays per ghost and wavelength, {:.0f} ms\n", name, angle[0],
                       angle[1], args.rays, args.rays, ref_ms);
            // Every setting once untimed (fills its caches, e.g. the bounds table), then the timed rounds
            // interleaved so that the others' load on the machine spreads over all settings alike.
            std::vector<Setting> list = settings();
            std::vector<double> fastest(list.size(), 1e300);
            std::vector<flare::FlareImage> images(list.size());
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
                const flare::FlareError error = flare::compare_flare(images[i], reference, view, kErrorBlock);
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
    if (!args.means.empty()) write_means(rows, lenses, args.means);
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
    tve->add_option("--from-csv", args->from_csv, "Summarise an earlier run's CSV instead of measuring");
    tve->add_option("--means", args->means, "Output CSV of each setting's mean over the angles and whether it is on the "
                                            "lens's Pareto front (lens, setting, ms, rel_l1, front), for bench/plot_time_vs_error.gp");
    tve->add_option("--lens", args->lenses, "Lens presets or files (repeatable; default: three presets, one with --quick)");
    tve->add_option("--size", args->size, "Image WxH in pixels")->capture_default_str();
    tve->add_option("--rays", args->rays, "Reference: N x N rays per ghost and wavelength")->capture_default_str()->check(CLI::Range(1, 4096));
    tve->add_option("--repeat", args->repeat, "Timed renders per setting (the fastest is reported: others load the machine)")->capture_default_str()->check(CLI::Range(1, 1000));
    tve->add_option("--threads", args->threads, "Reference: worker threads")->capture_default_str()->check(CLI::Range(0, 1024));
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
