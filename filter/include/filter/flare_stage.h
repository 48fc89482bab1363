// The flare effect of `lensfx -i IN -o OUT --lens LENS`: the lights of each frame (detected and tracked, or
// read from a track file) are each rendered through the lens on the GPU and added to R, G, B in
// scene-linear light at their physical strength (DESIGN.md: a flare image holds sensor irradiance per unit
// light irradiance; the light's irradiance follows from the energy its own image recorded).
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include <detect/source.h>
#include <filter/frame.h>
#include <optics/lens.h>

namespace lensfx::filter {

struct FlareSettings {
    std::string lens;                 // preset name or lens file; empty: no flare stage
    std::string zoom;                 // "0.5" (zoom parameter) or "135mm" (label); empty: the first position
    std::optional<double> fstop;      // sets the stop so the lens's f-number is this
    std::optional<int> blades;        // overrides the lens's iris blade count (0 = round)
    std::string threshold = "20";     // detection threshold: absolute luminance, or "+6ev" above the median
    int max_lights = 16;
    std::string sensor = "36";        // sensor width in mm, or WxH; the height defaults to the frame's aspect
    std::optional<double> fov_deg;    // horizontal field of view; overrides the lens's focal length
    double gain = 1.0;                // artistic scale of the whole flare
    double source_gain = 1.0;         // lifts the strength of clipped sources
    bool flare_only = false;          // write the flare alone (on black)
    std::string tracks;               // render the lights of this track file instead of detecting
    std::string gpu = "auto";         // EGL platform: auto, device, surfaceless
    int grid = 16;                    // base ray grid per ghost, as gpu::GpuFlareOptions (adaptive on top)
    std::string parts = "ghosts,starburst";  // what to render: ghosts, starburst, or both
    double starburst_gain = 1.0;      // energy of the starburst relative to the light's recorded energy
    double starburst_scale = 1.0;     // size relative to the physical (wavelength x f-number) scale
};

// Adds --lens, --zoom, --fstop, --blades, --threshold, --max-lights, --sensor, --fov, --gain,
// --source-gain, --flare-only, --tracks, --gpu, --grid, --parts, --starburst-gain, --starburst-scale.
void add_flare_options(CLI::App& app, FlareSettings& settings);

// The optical mapping from frame pixels to light directions, and the strength of a light.
struct FlareGeometry {
    double focal_mm = 0.0;         // from the lens (paraxial EFL) or --fov
    double sensor_width_mm = 36.0;
    double sensor_height_mm = 24.0;
    int width = 0;                 // display window, pixels
    int height = 0;

    // Field angles (ax right, ay up, degrees) of a light imaged at display-window pixel position (x, y)
    // (pixel centres at +0.5; row 0 at the top), for a rectilinear mapping through focal_mm.
    std::array<double, 2> angles_at(double x, double y) const;
    double pixel_area_mm2() const;
};

struct FlareParts {
    bool ghosts = true;
    bool starburst = true;
};
// "ghosts", "starburst", "ghosts,starburst" (any order); throws std::invalid_argument naming a bad part.
FlareParts parse_parts(std::string_view text);

// Power (mm^2 per unit irradiance) that a collimated light at angles (ax, ay) delivers through the lens's
// direct path to the sensor, per RGB wavelength: pupil area seen along the beam x transmission, with
// vignetting by every clear aperture and the iris. The light's irradiance is its image's recorded energy
// (flux x pixel area) over this.
std::array<double, 3> direct_power(const optics::System& system, double ax_deg, double ay_deg, int rays = 64);

class FlareStage final : public Stage {
public:
    explicit FlareStage(FlareSettings settings);
    ~FlareStage() override;

    std::string_view name() const override { return "flare"; }
    void process(Frame& frame) override;

private:
    struct State;
    std::unique_ptr<State> state_;
};

}  // namespace lensfx::filter
