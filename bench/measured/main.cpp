// bench_measured [LENS [MODEL.toml]]: renders a 41-frame sweep (0..20 degrees by 0.5, 240x160, 72x48 mm sensor, ghosts,
// background 1e-4, noise 2e-5) of a physical preset on the GPU, fits a measured lens to it and prints the
// fit's time, then the time per 960x640 flare of the measured lens (GPU and CPU) against the physical
// renderer's at the same light angles. With MODEL.toml: the fitted lens is written there, or read from it
// when it exists (no fit, to time the renderers alone).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <fmt/core.h>

#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <gpu/measured_renderer.h>
#include <measured/fit.h>
#include <measured/model_file.h>
#include <optics/paraxial.h>
#include <optics/presets.h>
#include <optics/stopwatch.h>
#include <optics/system.h>

namespace {

using Clock = std::chrono::steady_clock;
using lensfx::ms_since;

lensfx::flare::FlareView view_at(double angle, int w, int h) {
    lensfx::flare::FlareView v;
    v.angle_x_deg = angle, v.sensor_width_mm = 72.0, v.sensor_height_mm = 48.0, v.width = w, v.height = h;
    return v;
}

// The 41-frame sweep of `system` (noise seed 41) fitted, its time printed.
lensfx::measured::MeasuredLens fit_sweep_of(lensfx::gpu::FlareRenderer& physical, const lensfx::optics::System& system, const std::string& name) {
    using namespace lensfx;
    std::mt19937_64 random(41);
    std::normal_distribution<double> noise(0.0, 2e-5);
    std::vector<measured::SweepFrame> frames;
    for (int i = 0; i <= 40; ++i) {
        measured::SweepFrame f{240, 160, physical.render(system, view_at(0.5 * i, 240, 160), {}).rgb, 0.5 * i};
        for (float& v : f.rgb) v = static_cast<float>(static_cast<double>(v) + 1e-4 + noise(random));
        frames.push_back(std::move(f));
    }
    measured::FitOptions o;
    o.focal_length_mm = optics::paraxial(system).efl_mm, o.sensor_width_mm = 72.0, o.sensor_height_mm = 48.0;
    const auto t = Clock::now();
    const measured::FitResult fit = measured::fit_sweep(frames, o);
    fmt::print("{}: fit of a 41-frame 240x160 sweep: {:.1f} s, {} ghosts\n", name, ms_since(t) / 1000.0, fit.lens.ghosts.size());

    return fit.lens;
}

}  // namespace

int main(int argc, char** argv) {
    using namespace lensfx;
    const std::string name = argc > 1 ? argv[1] : "petzval-kodak";
    const optics::System system = optics::realize(optics::load_preset(name), 0.0);
    const gpu::Context context(gpu::Platform::Auto);
    gpu::FlareRenderer physical(context);
    const std::string model_path = argc > 2 ? argv[2] : "";
    const measured::MeasuredLens fitted =
        !model_path.empty() && std::filesystem::exists(model_path) ? measured::read_measured(model_path) : fit_sweep_of(physical, system, name);
    if (!model_path.empty() && !std::filesystem::exists(model_path)) std::ofstream(model_path) << measured::write_measured_toml(fitted);
    gpu::MeasuredRenderer gpu_measured(context);
    double physical_ms = 0.0, gpu_ms = 0.0, cpu_ms = 0.0, exact_ms = 0.0, table_diff = 0.0, gpu_diff = 0.0, total = 0.0;
    const std::vector<double> angles{3.0, 7.5, 11.0, 15.5};
    for (double a : angles) {
        const flare::FlareView view = view_at(a, 960, 640);
        physical.render(system, view, {});  // warm the lens's tables for this angle's ghosts
        auto t = Clock::now();
        physical.render(system, view, {});
        physical_ms += ms_since(t);
        // The measured lens as drawn (distance tables, smooth ghosts reduced) on the GPU and the CPU, and on
        // the CPU with the exact Bezier search per pixel (as before the tables).
        measured::MeasuredView mv{a, 0.0, 72.0, 48.0, 960, 640};
        std::vector<float> gpu(960 * 640 * 3, 0.0f), cpu(960 * 640 * 3, 0.0f), exact(960 * 640 * 3, 0.0f);
        gpu_measured.render_add(fitted, mv, {1, 1, 1}, gpu.data());  // warm
        std::fill(gpu.begin(), gpu.end(), 0.0f);
        t = Clock::now();
        gpu_measured.render_add(fitted, mv, {1, 1, 1}, gpu.data());
        gpu_ms += ms_since(t);
        t = Clock::now();
        measured::render_add(fitted, mv, {1, 1, 1}, cpu.data());
        cpu_ms += ms_since(t);
        mv.distance_tables = false;
        t = Clock::now();
        measured::render_add(fitted, mv, {1, 1, 1}, exact.data());
        exact_ms += ms_since(t);
        for (std::size_t i = 0; i < cpu.size(); ++i)
            table_diff += std::abs(static_cast<double>(cpu[i] - exact[i])), gpu_diff += std::abs(static_cast<double>(gpu[i] - cpu[i])), total += std::abs(static_cast<double>(exact[i]));
    }
    const double n = static_cast<double>(angles.size());
    fmt::print("960x640 flare, mean of {} angles: physical GPU {:.1f} ms; measured GPU {:.1f} ms ({:.1f}x faster than physical); measured CPU {:.1f} ms ({:.1f}x); "
               "measured CPU, exact Bezier search per pixel {:.1f} ms ({:.1f}x). Relative L1: tables to exact {:.2e}, GPU to CPU {:.2e}\n",
               angles.size(), physical_ms / n, gpu_ms / n, physical_ms / gpu_ms, cpu_ms / n, physical_ms / cpu_ms, exact_ms / n, physical_ms / exact_ms,
               table_diff / total, gpu_diff / total);
    return 0;
}
