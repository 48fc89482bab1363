// diag_measured OUT_DIR [LENS [SEED [END]]]: the fit test's synthetic sweep (240x160, 72x48 mm, 0..END (16) degrees by 1,
// background 1e-4, noise 2e-5), the fit, then for the test's angles the true ghosts beside the fitted
// model's (PPM: true | fitted | |difference|, one gain per row) with the figures of measured_fit_test and
// the physical lens's ghosts by power: what the fit misses and where.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include <fmt/core.h>

#include <flare/flare.h>
#include <gpu/context.h>
#include <gpu/flare_renderer.h>
#include <measured/fit.h>
#include <measured/predict.h>
#include <optics/presets.h>
#include <optics/system.h>

namespace {

using namespace lensfx;
constexpr int kW = 240, kH = 160;

flare::FlareView view_at(double ax, double ay) {
    flare::FlareView v;
    v.angle_x_deg = ax, v.angle_y_deg = ay, v.sensor_width_mm = 72.0, v.sensor_height_mm = 48.0, v.width = kW, v.height = kH;
    return v;
}

double sum(const std::vector<float>& v) { return std::accumulate(v.begin(), v.end(), 0.0, [](double s, float x) { return s + static_cast<double>(x); }); }

double block_l1(const std::vector<float>& fit, const std::vector<float>& truth) {
    double diff = 0.0, total = 0.0;
    for (int by = 0; by < kH; by += 8)
        for (int bx = 0; bx < kW; bx += 8)
            for (int c = 0; c < 3; ++c) {
                double a = 0.0, b = 0.0;
                for (int y = by; y < std::min(by + 8, kH); ++y)
                    for (int x = bx; x < std::min(bx + 8, kW); ++x) {
                        const std::size_t i = static_cast<std::size_t>((y * kW + x) * 3 + c);
                        a += static_cast<double>(fit[i]), b += static_cast<double>(truth[i]);
                    }
                diff += std::abs(a - b), total += b;
            }
    return diff / total;
}

// Images side by side, sqrt tone, `gain` times each value.
void write_row(const std::string& path, const std::vector<std::vector<float>>& images, double gain) {
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return;
    const int n = static_cast<int>(images.size());
    std::fprintf(f, "P6\n%d %d\n255\n", kW * n + 4 * (n - 1), kH);
    for (int y = 0; y < kH; ++y)
        for (int k = 0; k < n; ++k) {
            for (int x = 0; x < kW; ++x)
                for (int c = 0; c < 3; ++c) {
                    const double v = static_cast<double>(images[static_cast<std::size_t>(k)][static_cast<std::size_t>((y * kW + x) * 3 + c)]);
                    std::fputc(static_cast<int>(255.0 * std::clamp(std::sqrt(std::max(0.0, v * gain)), 0.0, 1.0)), f);
                }
            if (k + 1 < n)
                for (int x = 0; x < 12; ++x) std::fputc(128, f);
        }
    std::fclose(f);
}

double percentile(std::vector<float> v, double q) {
    const auto at = v.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), at, v.end());
    return static_cast<double>(*at);
}

}  // namespace

int main(int argc, char** argv) {
    const std::string out = argc > 1 ? argv[1] : "/tmp/diag";
    const std::string name = argc > 2 ? argv[2] : "petzval-kodak";
    const optics::System system = optics::realize(optics::load_preset(name), 0.0);
    const gpu::Context context(gpu::Platform::Surfaceless);
    gpu::FlareRenderer renderer(context);
    auto truth = [&](double ax, double ay) { return renderer.render(system, view_at(ax, ay), {}).rgb; };

    std::mt19937_64 random(argc > 3 ? std::stoul(argv[3]) : 19);
    std::normal_distribution<double> noise(0.0, 2e-5);
    const int end = argc > 4 ? std::stoi(argv[4]) : 16;
    std::vector<measured::SweepFrame> frames;
    for (int i = 0; i <= end; ++i) {
        measured::SweepFrame f{kW, kH, truth(i, 0.0), static_cast<double>(i)};
        for (float& v : f.rgb) v = static_cast<float>(static_cast<double>(v) + 1e-4 + noise(random));
        frames.push_back(std::move(f));
    }
    {
        // Each 16x16 block's smallest noise-free mean (G) over the sweep: is any block dark at some angle?
        std::vector<double> lowest(15 * 10, 1e9);
        for (int i = 0; i <= end; ++i) {
            const auto t = truth(i, 0.0);
            for (int b = 0; b < 150; ++b) {
                double s = 0.0;
                for (int y = (b / 15) * 16; y < (b / 15) * 16 + 16; ++y)
                    for (int x = (b % 15) * 16; x < (b % 15) * 16 + 16; ++x) s += static_cast<double>(t[static_cast<std::size_t>((y * kW + x) * 3 + 1)]);
                lowest[static_cast<std::size_t>(b)] = std::min(lowest[static_cast<std::size_t>(b)], s / 256.0);
            }
        }
        std::sort(lowest.begin(), lowest.end());
        fmt::print("block minima over the sweep (G): lowest {:.2e} {:.2e} {:.2e}, 10th {:.2e}, median {:.2e}\n", lowest[0], lowest[1], lowest[2], lowest[10], lowest[75]);
    }
    for (int i : {0, 4, 8, 12, 16}) write_row(fmt::format("{}/sweep-{:02d}.ppm", out, i), {frames[static_cast<std::size_t>(i)].rgb}, 2000.0);
    measured::FitOptions o;
    o.focal_length_mm = 100.0, o.sensor_width_mm = 72.0, o.sensor_height_mm = 48.0;
    o.progress = [](const std::string& s) { std::fprintf(stderr, "%s\n", s.c_str()); };
    const auto t0 = std::chrono::steady_clock::now();
    const measured::FitResult fit = measured::fit_sweep(frames, o);
    fmt::print("fit: {:.1f} s, {} ghosts\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), fit.lens.ghosts.size());
    for (const auto& f : fit.frames)
        fmt::print("  frame {:5.1f}: ghosts {} bg {:.3g} noise {:.3g} residual {:.3f} model {:.3f}\n", f.angle_deg, f.ghosts, f.background, f.noise, f.residual, f.model_residual);
    for (std::size_t g = 0; g < fit.lens.ghosts.size(); ++g) {
        const auto& mg = fit.lens.ghosts[g];
        const auto p = mg.at(0.5 * (mg.angle_min_deg + mg.angle_max_deg));
        fmt::print("  ghost {}: {:g}..{:g} deg; mid: M {:.2f} L {:.2f} R {:.2f} h {:.2f} Fi {:.2f} Fo {:.2f} Ib {:.2e} Ii {:.2e}\n", g, mg.angle_min_deg,
                   mg.angle_max_deg, p[measured::kPosition], p[measured::kLeft], p[measured::kRight], p[measured::kHeight], p[measured::kFallInside],
                   p[measured::kFallOutside], p[measured::kBorderG], p[measured::kInsideG]);
    }
    auto fitted = [&](double ax, double ay) {
        std::vector<float> rgb(static_cast<std::size_t>(kW * kH * 3), 0.0f);
        measured::render_add(fit.lens, measured::MeasuredView{ax, ay, 72.0, 48.0, kW, kH}, {1, 1, 1}, rgb.data());
        return rgb;
    };
    for (const auto& [ax, ay] : {std::pair{8.5, 0.0}, std::pair{11.5, 0.0}, std::pair{6.0, 6.5}, std::pair{-7.0, 8.0}, std::pair{2.5, 0.0}}) {
        const auto t = truth(ax, ay), f = fitted(ax, ay);
        std::vector<float> d(t.size());
        for (std::size_t i = 0; i < t.size(); ++i) d[i] = std::abs(t[i] - f[i]);
        const double gain = 0.5 / std::max(1e-12, percentile(t, 0.995));
        write_row(fmt::format("{}/cmp-{}-{}.ppm", out, ax, ay), {t, f, d}, gain);
        fmt::print("light ({}, {}): L1 {:.3f}, power {:.3f} (fit {:.4g}, true {:.4g})\n", ax, ay, block_l1(f, t), std::abs(sum(f) - sum(t)) / sum(t), sum(f), sum(t));
        gpu::GpuFlareOptions go;
        go.per_ghost_power = true;
        const auto image = renderer.render(system, view_at(ax, ay), go);
        std::vector<flare::GhostPower> ghosts = image.ghosts;
        std::sort(ghosts.begin(), ghosts.end(), [](const auto& a, const auto& b) { return a.power[1] > b.power[1]; });
        double total = 0.0;
        for (const auto& g : ghosts) total += g.power[1];
        std::string line = "  true ghosts by G power share:";
        for (std::size_t k = 0; k < std::min<std::size_t>(8, ghosts.size()); ++k)
            line += fmt::format(" ({},{}) {:.3f}", ghosts[k].first, ghosts[k].second, ghosts[k].power[1] / total);
        fmt::print("{}\n", line);
        std::vector<std::vector<float>> singles;
        for (std::size_t k = 0; k < std::min<std::size_t>(6, ghosts.size()); ++k) {
            flare::FlareView v = view_at(ax, ay);
            v.only_ghosts = {{ghosts[k].first, ghosts[k].second}};
            singles.push_back(renderer.render(system, v, {}).rgb);
            const auto& img = singles.back();
            double s = 0.0, sx = 0.0, peak = 0.0;
            int x0 = kW, x1 = -1, y0 = kH, y1 = -1;
            for (int y = 0; y < kH; ++y)
                for (int x = 0; x < kW; ++x) {
                    const double l = static_cast<double>(img[static_cast<std::size_t>((y * kW + x) * 3 + 1)]);
                    s += l, sx += l * x, peak = std::max(peak, l);
                    if (l > 1e-6) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
                }
            fmt::print("    ghost ({},{}): centroid x {:.1f}, lit box x {}..{} y {}..{}, peak {:.2e}, mean over lit {:.2e}\n", ghosts[k].first, ghosts[k].second,
                       sx / s, x0, x1, y0, y1, peak, s / std::max(1, (x1 - x0 + 1) * (y1 - y0 + 1)));
        }
        write_row(fmt::format("{}/ghosts-{}-{}.ppm", out, ax, ay), singles, gain);
        // The error split: the brightest true ghost against the fitted ghosts (the rest true), and the rest
        // against the fitted glows (the brightest true).
        {
            measured::MeasuredLens only_ghosts = fit.lens, only_glows = fit.lens;
            const std::size_t glows = static_cast<std::size_t>(o.glows);
            only_ghosts.ghosts.resize(fit.lens.ghosts.size() - glows);
            only_glows.ghosts.erase(only_glows.ghosts.begin(), only_glows.ghosts.end() - static_cast<std::ptrdiff_t>(glows));
            const auto& brightest = singles.front();
            std::vector<float> ghost_case(t.size()), glow_case(t.size());
            std::vector<float> fg(t.size(), 0.0f), fw(t.size(), 0.0f);
            measured::render_add(only_ghosts, measured::MeasuredView{ax, ay, 72.0, 48.0, kW, kH}, {1, 1, 1}, fg.data());
            measured::render_add(only_glows, measured::MeasuredView{ax, ay, 72.0, 48.0, kW, kH}, {1, 1, 1}, fw.data());
            for (std::size_t i = 0; i < t.size(); ++i) ghost_case[i] = t[i] - brightest[i] + fg[i], glow_case[i] = brightest[i] + fw[i];
            fmt::print("  error split: fitted ghosts for the brightest true one L1 {:.3f} power {:+.3f}; fitted glows for the rest L1 {:.3f} power {:+.3f}\n",
                       block_l1(ghost_case, t), (sum(ghost_case) - sum(t)) / sum(t), block_l1(glow_case, t), (sum(glow_case) - sum(t)) / sum(t));
        }
    }
    std::vector<double> predicted, physical;
    for (double a = 0.0; a <= end; a += 1.0) {
        predicted.push_back(measured::estimate(fitted(a, 0.0), kW, kH, {1e-3f}, 1.0).total);
        physical.push_back(sum(truth(a, 0.0)));
        fmt::print("  {:4.1f} deg: predicted total {:.4g}, physical sum {:.4g}\n", a, predicted.back(), physical.back());
    }
    return 0;
}
