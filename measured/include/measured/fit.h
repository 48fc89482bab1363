// Fitting a measured lens to a sweep of photographs of a point light (Walch et al. 2018, section 3.3): the
// light moves right along the horizontal meridian, frame i at angle_deg. Ghosts are found on the line
// through the light and the centre, each started at a key frame, fitted by gradient descent on the mean
// squared error plus the smoothed Laplacian edge cost, tracked from frame to frame and turned into
// degree-2 polynomials over the angle. In colour; a background level and sensor noise are expected.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <measured/model.h>

namespace lensfx::measured {

// One photograph of the sweep: linear R, G, B, row 0 at the top.
struct SweepFrame {
    int width = 0;
    int height = 0;
    std::vector<float> rgb;
    double angle_deg = 0.0;
};

struct FitOptions {
    double focal_length_mm = 50.0;   // pixel -> angle: x = f tan(angle) on the sensor
    double sensor_width_mm = 36.0;
    double sensor_height_mm = 24.0;
    double edge_weight = 0.5;        // of the edge cost against the MSE (both relative to the frame's own)
    int key_iterations = 120;        // gradient-descent passes at a ghost's key frame
    int track_iterations = 30;        // at the frames tracked from it (seeded by the neighbour's fit)
    int polynomial_iterations = 20;   // passes of the track's polynomials fitted to all its frames at once (0: none)
    double max_level_ratio = 64.0;   // a ghost's peak level changing more over its track: fitted in pieces
    int max_ghosts = 16;
    int glows = 2;                   // wide soft glows fitted to what the ghosts leave (faint ghosts wider than the frame)
    double min_snr = 6.0;            // a ghost's level on the axis against the noise (after smoothing)
    double light_radius = 0.02;      // around the light's own image nothing is a ghost: fraction of the width
    int min_frames = 3;              // a ghost seen in fewer frames is dropped
    int threads = 0;                 // 0: one per core
    Capture capture;                 // f-number, ISO, exposure (light_energy is measured)
    std::function<void(const std::string&)> progress;  // one line per step, for stderr
};

struct FrameFit {
    double angle_deg = 0.0;
    int ghosts = 0;            // fitted ghosts in this frame
    double background = 0.0;   // the level taken off (luminance)
    double noise = 0.0;        // its standard deviation (luminance, per pixel)
    double residual = 0.0;     // sum |frame - background - model| / sum |frame - background| over the ghosts' boxes
    double model_residual = 0.0;  // the same for the polynomial model at this angle
};

struct FitResult {
    MeasuredLens lens;
    std::vector<FrameFit> frames;
};

// Throws std::invalid_argument for frames of different sizes, fewer than 3 frames or unsorted angles.
FitResult fit_sweep(const std::vector<SweepFrame>& frames, const FitOptions& options);

}  // namespace lensfx::measured
