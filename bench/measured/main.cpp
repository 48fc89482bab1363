// bench_measured [LENS]: renders a 41-frame sweep (0..20 degrees by 0.5, 240x160, 72x48 mm sensor, ghosts,
// background 1e-4, noise 2e-5) of a physical preset on the GPU, fits a measured lens to it and prints the
// fit's time, then the time per 960x640 flare of the measured lens (GPU and CPU) against the physical
// renderer's at the same light angles.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <fmt/core.h>

#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <gpu/measured_renderer.h>
#include <measured/fit.h>
#include <optics/paraxial.h>
#include <optics/presets.h>
#include <optics/system.h>

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

lensfx::flare::FlareView view_at(double angle, int w, int h) {
    lensfx::flare::FlareView v;
    v.angle_x_deg = angle, v.sensor_width_mm = 72.0, v.sensor_height_mm = 48.0, v.width = w, v.height = h;
    return v;
}

}  // namespace

int main(int argc, char** argv) {
    using namespace lensfx;
    const std::string name = argc > 1 ? argv[1] : "petzval-kodak";
    const optics::System system = optics::realize(optics::load_preset(name), 0.0);
    const gpu::Context context(gpu::Platform::Auto);
    gpu::FlareRenderer physical(context);
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
    auto t = Clock::now();
    const measured::FitResult fit = measured::fit_sweep(frames, o);
    fmt::print("{}: fit of a 41-frame 240x160 sweep: {:.1f} s, {} ghosts\n", name, ms_since(t) / 1000.0, fit.lens.ghosts.size());

    gpu::MeasuredRenderer gpu_measured(context);
    double physical_ms = 0.0, full_ms = 0.0, gpu_ms = 0.0, cpu_ms = 0.0, diff = 0.0, total = 0.0;
    const std::vector<double> angles{3.0, 7.5, 11.0, 15.5};
    for (double a : angles) {
        const flare::FlareView view = view_at(a, 960, 640);
        physical.render(system, view, {});  // warm the lens's tables for this angle's ghosts
        t = Clock::now();
        physical.render(system, view, {});
        physical_ms += ms_since(t);
        // The measured lens with every ghost at full size (as before the smooth ones were reduced) and as drawn.
        measured::MeasuredView mv{a, 0.0, 72.0, 48.0, 960, 640};
        std::vector<float> full(960 * 640 * 3, 0.0f), reduced(960 * 640 * 3, 0.0f), cpu(960 * 640 * 3, 0.0f);
        mv.max_reduction = 1;
        gpu_measured.render_add(fit.lens, mv, {1, 1, 1}, full.data());  // warm
        std::fill(full.begin(), full.end(), 0.0f);
        t = Clock::now();
        gpu_measured.render_add(fit.lens, mv, {1, 1, 1}, full.data());
        full_ms += ms_since(t);
        mv.max_reduction = 8;
        gpu_measured.render_add(fit.lens, mv, {1, 1, 1}, reduced.data());  // warm
        std::fill(reduced.begin(), reduced.end(), 0.0f);
        t = Clock::now();
        gpu_measured.render_add(fit.lens, mv, {1, 1, 1}, reduced.data());
        gpu_ms += ms_since(t);
        t = Clock::now();
        measured::render_add(fit.lens, mv, {1, 1, 1}, cpu.data());
        cpu_ms += ms_since(t);
        for (std::size_t i = 0; i < full.size(); ++i) diff += std::abs(static_cast<double>(reduced[i] - full[i])), total += std::abs(static_cast<double>(full[i]));
    }
    const double n = static_cast<double>(angles.size());
    fmt::print("960x640 flare, mean of {} angles: physical GPU {:.1f} ms; measured GPU, every ghost full size {:.1f} ms ({:.1f}x faster than physical), "
               "smooth ghosts reduced {:.1f} ms ({:.1f}x faster than physical, {:.1f}x than full size; relative L1 to full size {:.2e}); measured CPU {:.1f} ms\n",
               angles.size(), physical_ms / n, full_ms / n, physical_ms / full_ms, gpu_ms / n, physical_ms / gpu_ms, full_ms / gpu_ms, diff / total, cpu_ms / n);
    return 0;
}
