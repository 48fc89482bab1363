// The fit tests' synthetic capture (issue 19), shared with bench/measured: a physical preset's ghosts
// rendered by the GPU ghost renderer on a 240x160 image of a 72x48 mm sensor, the light moving right along
// the horizontal meridian, with a background level of 1e-4 and sensor noise of sigma 2e-5 added per seed.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <measured/accuracy.h>
#include <measured/fit.h>
#include <measured/model.h>
#include <measured/predict.h>
#include <optics/presets.h>
#include <optics/system.h>

namespace lensfx::measured::synthetic {

constexpr int kImageWidth = 240, kImageHeight = 160;
constexpr double kSensorW = 72.0, kSensorH = 48.0;
constexpr double kBackground = 1e-4, kNoise = 2e-5;

inline flare::FlareView view_at(double ax, double ay, int width = kImageWidth, int height = kImageHeight) {
    flare::FlareView v;
    v.angle_x_deg = ax, v.angle_y_deg = ay;
    v.sensor_width_mm = kSensorW, v.sensor_height_mm = kSensorH;
    v.width = width, v.height = height;
    return v;
}

// The lens the fit is not told about, and its ghost images.
struct PhysicalLens {
    explicit PhysicalLens(const std::string& preset = "petzval-kodak") : system(optics::realize(optics::load_preset(preset), 0.0)) {}
    gpu::Context context{gpu::Platform::Surfaceless};
    optics::System system;
    gpu::FlareRenderer renderer{context};
    std::vector<float> render(double ax, double ay) { return renderer.render(system, view_at(ax, ay), gpu::GpuFlareOptions{}).rgb; }
};

// The noise-free frames of a sweep from 0 to end_deg by step_deg (rendered once; each seed adds its noise).
inline std::vector<SweepFrame> clean_sweep(PhysicalLens& lens, double end_deg, double step_deg) {
    std::vector<SweepFrame> frames;
    for (int i = 0; i * step_deg <= end_deg + 1e-9; ++i) frames.push_back({kImageWidth, kImageHeight, lens.render(i * step_deg, 0.0), i * step_deg});
    return frames;
}

// The clean frames with the background and one noise draw (seed) added.
inline std::vector<SweepFrame> captured(std::vector<SweepFrame> frames, std::uint64_t seed) {
    std::mt19937_64 random(seed);
    std::normal_distribution<double> noise(0.0, kNoise);
    for (SweepFrame& f : frames)
        for (float& v : f.rgb) v = static_cast<float>(static_cast<double>(v) + kBackground + noise(random));
    return frames;
}

// What the photographer knows: the lens's nominal focal length and the sensor.
inline FitOptions fit_options() {
    FitOptions o;
    o.focal_length_mm = 100.0;
    o.sensor_width_mm = kSensorW, o.sensor_height_mm = kSensorH;
    return o;
}

inline std::vector<float> render_fitted(const MeasuredLens& lens, double ax, double ay) {
    std::vector<float> rgb(static_cast<std::size_t>(kImageWidth * kImageHeight * 3), 0.0f);
    render_add(lens, MeasuredView{ax, ay, kSensorW, kSensorH, kImageWidth, kImageHeight}, {1, 1, 1}, rgb.data());
    return rgb;
}

// The check angles: between the sweep's samples on the meridian and off it.
inline const std::vector<std::pair<double, double>>& check_angles() {
    static const std::vector<std::pair<double, double>> angles{{8.5, 0.0}, {11.5, 0.0}, {6.0, 6.5}, {-7.0, 8.0}};
    return angles;
}

struct Accuracy {
    double l1 = 0.0, power = 0.0;
};

inline Accuracy accuracy_at(PhysicalLens& lens, const MeasuredLens& fitted, double ax, double ay) {
    const std::vector<float> truth = lens.render(ax, ay), fit = render_fitted(fitted, ax, ay);
    return {block_l1(fit, truth, kImageWidth, kImageHeight), power_error(fit, truth)};
}

// Spearman of predict's total (a flat grey scene of 1e-3) against the physical ghost power, 0..end by 1.
inline double predicted_rank_correlation(PhysicalLens& lens, const MeasuredLens& fitted, double end_deg) {
    std::vector<double> predicted, physical;
    for (double a = 0.0; a <= end_deg + 1e-9; a += 1.0) {
        predicted.push_back(estimate(render_fitted(fitted, a, 0.0), kImageWidth, kImageHeight, {1e-3f}, 1.0).total);
        const std::vector<float> truth = lens.render(a, 0.0);
        physical.push_back(estimate(truth, kImageWidth, kImageHeight, {1e-3f}, 1.0).total);
    }
    return spearman(predicted, physical);
}

}  // namespace lensfx::measured::synthetic
