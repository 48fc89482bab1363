// Lens rays through the real prescription (not a thin lens): from points of the sensor, focused so that an
// object at the focus distance is sharp, back through every surface and the iris into the scene. Each ray
// becomes a straight line in screen space against inverse depth: pixel(w) = c + a w, w = 1 / depth (1/m),
// the form the layer trace works in (paper section 3.1, "Computing Lens Rays").
#pragma once
#include <array>
#include <vector>

#include <optics/lens.h>

namespace lensfx::dof {

inline constexpr std::array<double, 3> kRgbWavelengths_nm = {650.0, 550.0, 450.0};  // as the flare's RGB

// One wavelength the lens rays are traced at, and what the colour its rays gather adds to R, G and B.
struct Band {
    double wavelength_nm = 550.0;
    std::array<double, 3> weight{};
};

// A focus constraint of the focal surface (paper section 5.2): the object distance that is sharp at a
// raster position.
struct FocusPoint {
    double x = 0.0, y = 0.0;  // raster pixels
    double metres = 1.0;
};

// The camera: lens, focus and the raster the blur is computed over.
struct Camera {
    optics::System system;       // realised at the zoom and f-number
    double focus_m = 2.0;        // object distance from the entrance pupil that is sharp (on the axis)
    double sensor_width_mm = 36.0;
    int width = 0, height = 0;   // raster (the frame's data window)
    double centre_x = 0.0, centre_y = 0.0;  // optical axis in raster pixels (pixel i spans [i, i + 1))
    double tilt_x_deg = 0.0, tilt_y_deg = 0.0;  // sensor tilt (Scheimpflug): about the x axis, the y axis
    // A focal surface (empty: the plane of focus_m): each sensor point is moved to where the object distance
    // interpolated from these points is sharp, the points weighted by 1 / d^focus_power (d: raster distance;
    // the paper's moving least squares of degree 0, in inverse distance), tilt added on top.
    std::vector<FocusPoint> focus_points;
    double focus_power = 2.0;
    std::array<double, 3> wavelengths_nm = kRgbWavelengths_nm;  // per channel (all equal: no chromatic blur)
    // Spectral bands (--bands, flare::spectral_passes: CIE 1931 weights, each channel's summing to 1); empty:
    // one band per channel at wavelengths_nm.
    std::vector<Band> bands;

    double display_width = 0;    // display window width in pixels, which the sensor width spans (0: width)

    double pitch_mm() const { return sensor_width_mm / (display_width > 0 ? display_width : width); }
};

// Where the sensor sits so that an on-axis object focus_m from the entrance pupil is imaged sharply
// (paraxial, 587.56 nm), and the quantities the tests compare against.
struct Focus {
    double sensor_z_mm = 0.0;
    double efl_mm = 0.0;
    double entrance_pupil_z_mm = 0.0;        // from the first vertex
    double entrance_pupil_diameter_mm = 0.0;
};
Focus focus_of(const optics::System& system, double focus_m);

// A table of rays on a grid of sensor points (bilinear between them), `samples` rays per point and channel,
// spread over the exit pupil (R2 low-discrepancy order, so any run of consecutive samples is well spread).
// A ray is valid (weight 1) when it passes every clear aperture and the iris's blades; the blades, the
// cat's-eye vignetting, spherical aberration, field curvature, chromatic aberration and focus breathing all
// come from the exact trace.
struct RayTable {
    int grid_x = 0, grid_y = 0, samples = 0;
    int channels = 3;   // bands: RGB's three, or the spectral bands
    std::vector<std::array<float, 3>> channel_weight;  // per band, what its gathered colour adds to R, G, B
    int achromatic = 1; // the band nearest 550 nm: alpha, the uniform-colour test, and --no-chromatic-blur
    double cell_w = 0.0, cell_h = 0.0;  // raster pixels between grid points; grid point (0,0) at pixel (0,0)
    // [channel][gy][gx][sample]: (cx, ax, cy, ay) raster pixels and pixels per (1/m); weight 0 or 1
    std::vector<std::array<float, 4>> line;
    std::vector<float> weight;
    std::size_t at(int channel, int gx, int gy, int s) const {
        return ((static_cast<std::size_t>(channel) * static_cast<std::size_t>(grid_y) + static_cast<std::size_t>(gy)) *
                    static_cast<std::size_t>(grid_x) + static_cast<std::size_t>(gx)) * static_cast<std::size_t>(samples) +
               static_cast<std::size_t>(s);
    }
    double focus_w = 0.0;   // 1 / focus distance
    double max_slope = 0.0; // largest |a| over valid rays (pixels per 1/m): the blur's reach
    // largest distance at focus_w between a grid point's rays and their mean (tilt, a focal surface or
    // aberrations keep them from converging there): added to the reach where a pixel's rays must be bounded
    double focus_spread = 0.0;
};

// Largest distance between a grid point and where its rays cross focus_w on average (distortion, focus
// breathing, tilt): with the table's reach and focus spread it bounds how far from its pixel a ray can
// meet a surface.
double convergence_offset_px(const RayTable& table);

// The camera's bands: its spectral bands, or one per RGB channel (weight 1 into that channel only).
std::vector<Band> bands_of(const Camera& camera);

// grid: sensor points across the raster's width (rows follow the aspect). Throws std::invalid_argument
// for a focus inside the lens's focal length or a raster of no size.
RayTable make_ray_table(const Camera& camera, int samples, int grid = 17);

// One lens ray at raster position (px, py), sample s, channel c: bilinear between the four grid points;
// false when it is vignetted at all of them. Weight: the share of valid corners.
struct ScreenRay {
    float cx, ax, cy, ay, weight;
};
ScreenRay ray_at(const RayTable& table, int channel, double px, double py, int s);

// How many raster pixels of the scene (as the input image maps depth w = 1/m) one sensor pixel spans at
// the centre of the raster: above 1 when the focused lens magnifies (focus breathing). A point's gathered
// energy is its input energy over this squared.
double scene_scale(const RayTable& table, int channel, double w);

// The object distance (m) the camera's focal surface makes sharp at raster position (px, py): focus_m
// without focus points.
double focus_at(const Camera& camera, double px, double py);

// The R2 sequence point i in [0,1)^2 (Roberts 2018).
std::array<double, 2> r2(int i);

}  // namespace lensfx::dof
