// A measured lens (Walch et al. 2018, "data-driven lens flare"): each ghost is a shape of four cubic Bezier
// segments with axis-aligned control points, placed along the line through the light and the image centre,
// lit by a transfer function of its signed distance to its border, in R, G, B; every parameter is a
// degree-2 polynomial over the light's field angle. Radially symmetric: a light at roll phi turns the
// whole pattern by phi. Values are sensor irradiance for the capture's light (see MeasuredLens::capture).
#pragma once

#include <array>
#include <string>
#include <vector>

namespace lensfx::measured {

// The parameters of one ghost at one field angle (lengths in mm on the sensor).
enum Param : int {
    kPosition,      // M: centre along the light-centre axis, from the image centre towards the light
    kLeft,          // L: extent towards the image centre (towards -u)
    kRight,         // R: extent away from it
    kHeight,        // h: half height across the axis
    kCurveLeft,     // Cl: control points of the left segments, 0 (a corner) .. 1 (square); 0.5523 a circle
    kCurveRight,    // Cr: the same on the right
    kFallInside,    // Fi: distance over which the border level falls to the inside level
    kSlopeInside,   // Ei: exponent of that fall ((1 - t)^Ei)
    kFallOutside,   // Fo: distance over which the border level falls to 0 outside
    kSlopeOutside,  // Eo
    kBorderR, kBorderG, kBorderB,  // Ib per channel
    kInsideR, kInsideG, kInsideB,  // Ii per channel
    kParamCount
};
using GhostParams = std::array<double, kParamCount>;

// The TOML key of each parameter, in Param order.
const std::array<const char*, kParamCount>& param_names();
// The number of the shape parameters (they come first; the shade follows).
constexpr int kShapeParams = kFallInside;

// A circle-like ghost of radius r at position m, border and inside levels `level`, a sharp rim.
GhostParams disc_ghost(double m_mm, double r_mm, std::array<double, 3> level);
// Clamps sizes, curves, slopes and levels into their meaningful ranges (evaluated polynomials may stray).
GhostParams clamped(GhostParams p);

// Signed distance (mm, negative inside) of point (u, v) in the ghost's own frame (u along the axis from
// M, v across) to the ghost's border.
double signed_distance(const GhostParams& p, double u, double v);
// The ghost's value in channel c at signed distance d.
double intensity(const GhostParams& p, int c, double d);
// The weights (a, b) with intensity = Ib * a + Ii * b at distance d: the levels enter linearly.
std::array<double, 2> level_weights(const GhostParams& p, double d);

// A ghost's signed distance sampled on a grid over its own frame, for drawing: u from -(L + Fo) to R + Fo,
// |v| from 0 to h + Fo, at most kCells x kCells / 2 cells and none finer than the spacing asked for.
// Bilinear lookups stand in for the Bezier search of signed_distance (the distance is smooth across the
// border, so the edge stays sharp); beyond the grid the ghost is dark (the distance is Fo).
struct DistanceTable {
    static constexpr int kCells = 64;
    double u0 = 0.0, du = 1.0, dv = 1.0;
    int nu = 0, nv = 0;    // samples along u and v
    std::vector<float> d;  // nv rows of nu samples, row j at |v| = j dv
    double far = 0.0;      // the distance beyond the grid
    [[nodiscard]] double at(double u, double v) const;
};
DistanceTable distance_table(const GhostParams& p, double spacing_mm);

// A ghost over a range of field angles: each parameter c0 + c1 a + c2 a^2 (a in degrees).
struct MeasuredGhost {
    double angle_min_deg = 0.0;
    double angle_max_deg = 0.0;
    std::array<std::array<double, 3>, kParamCount> poly{};
    [[nodiscard]] bool covers(double angle_deg) const { return angle_deg >= angle_min_deg && angle_deg <= angle_max_deg; }
    [[nodiscard]] GhostParams at(double angle_deg) const;  // clamped
};

// How the photographs were taken (paper section 3.4.1, equation 2).
struct Capture {
    double f_number = 0.0;   // 0: not known
    double iso = 100.0;
    double exposure_s = 1.0;
    double light_energy = 1.0;  // the light's own image: sum of its pixels x pixel area (mm^2), capture units
};

struct MeasuredLens {
    std::string name;
    std::string source;        // how it was made (the fit's command)
    double focal_length_mm = 0.0;
    std::array<double, 2> sensor_mm{36.0, 24.0};  // of the capture
    Capture capture;
    std::vector<MeasuredGhost> ghosts;
};

// Paper equation 2: the factor from the capture's brightness to a target's (f-number, ISO, exposure, and
// the ratio of the lights' luminance x solid angle, target over capture).
double brightness_scale(const Capture& capture, const Capture& target, double light_ratio = 1.0);

// A view of the sensor: the light at (ax, ay) degrees (DESIGN.md conventions), the image's size.
struct MeasuredView {
    double angle_x_deg = 0.0;
    double angle_y_deg = 0.0;
    double sensor_width_mm = 36.0;
    double sensor_height_mm = 24.0;
    int width = 0;
    int height = 0;
    int max_reduction = 8;  // smooth ghosts drawn at most this much reduced (1: every ghost at full size)
    bool distance_tables = true;  // drawn from each ghost's DistanceTable (false: the exact Bezier search per pixel)
};

// The field angle (degrees off the axis) and roll (radians, 0 = light to the right, counter-clockwise) of
// a light at (ax, ay).
std::array<double, 2> field_and_roll(double ax_deg, double ay_deg);


// The length (mm) below which a ghost's image holds no detail, so that it can be drawn at a reduced size
// and upsampled: a ghost with a dark border (its border levels under 2% of its inside levels) whose level
// rises over Fi with Ei >= 1 is smooth at the smaller of Fi and its half width and height; one with an
// edge (a lit border) is not (0).
double smooth_scale_mm(const GhostParams& p);

// The reduction (1, 2, 4 or 8, at most the view's max_reduction) at which ghost p is drawn in the view: at
// least 8 samples of the reduced grid over its smooth scale.
int reduction_for(const GhostParams& p, const MeasuredView& view);

// Adds `scale[c]` x every ghost of `lens` at the view's light into `rgb` (width x height x 3, row 0 at the
// top): the CPU reference of the GPU renderer. Smooth ghosts (smooth_scale_mm) are drawn at their
// reduction on a grid of samples at the centres of reduction x reduction pixel blocks, one sample beyond
// the image each side, and added bilinearly interpolated.
void render_add(const MeasuredLens& lens, const MeasuredView& view, std::array<double, 3> scale, float* rgb);
// The samples a smooth ghost is drawn on at a reduction r: sample (i, j) at the centre of pixel block
// (i - 1, j - 1) of r x r pixels, one sample beyond the image each side.
struct ReducedGrid {
    int reduction = 1;
    int width = 0, height = 0;
    [[nodiscard]] double pixel_of(int sample) const;  // the full image's pixel coordinate of a sample (x or y)
};
ReducedGrid reduced_grid(const MeasuredView& view, int reduction);
// Adds ghost p (scaled, at roll) into the grid's samples (width x height x 3).
void render_reduced(const GhostParams& p, double roll_rad, const MeasuredView& view, const ReducedGrid& grid, float* samples);
// Adds the samples, bilinearly interpolated, into the full image.
void add_upsampled(const ReducedGrid& grid, const float* samples, const MeasuredView& view, float* rgb);
// The ghosts of `lens` at a field angle, their levels times scale.
std::vector<GhostParams> ghosts_at(const MeasuredLens& lens, double field_deg, std::array<double, 3> scale);

// One ghost at parameters p, the light on the +x meridian, over the pixel box [x0, x1) x [y0, y1) into a
// buffer of that box (rows of x1 - x0 pixels): what the fit draws.
void render_ghost_box(const GhostParams& p, double roll_rad, const MeasuredView& view, int x0, int y0, int x1, int y1,
                      float* rgb);
// The pixel box (clamped to the image) a ghost can light.
std::array<int, 4> ghost_box(const GhostParams& p, double roll_rad, const MeasuredView& view);

}  // namespace lensfx::measured
