// The flare effect of `lensfx -i IN -o OUT --lens LENS`: the lights of each frame (detected and tracked, or
// read from a track file) are each rendered through the lens on the GPU and added to R, G, B in
// scene-linear light at their physical strength (DESIGN.md: a flare image holds sensor irradiance per unit
// light irradiance; the light's irradiance follows from the energy its own image recorded).
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include <detect/source.h>
#include <filter/frame.h>
#include <filter/flare_controls.h>
#include <filter/ghost_options.h>
#include <filter/gpu_session.h>
#include <filter/pupil_options.h>
#include <flare/flare.h>
#include <optics/lens.h>
#include <optics/memory_budget.h>
#include <optics/starburst.h>

namespace lensfx::filter {

struct FlareSettings {
    std::string lens;                 // preset name or lens file; empty: no flare stage
    std::string zoom;                 // "0.5" (zoom parameter) or "135mm" (label); empty: the first position
    std::optional<double> fstop;      // sets the stop so the lens's f-number is this
    std::optional<int> blades;        // overrides the lens's iris blade count (0 = round)
    std::string coating = "lens";     // uncoated, single, multi or lens (optics::CoatingChoice)
    double coating_spread = 0.03;     // relative thickness spread of every coating layer (seeded)
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
    int bands = 0;                    // 0: RGB (3 wavelengths); kMinBands..kMaxBands: spectral bands
    bool band_filter = false;         // blur between bands (paper section 4.2); one render per ghost and band
    PupilSettings pupil;              // dust, scratches, aperture image (the starburst's pupil)
    bool ringing = false;             // ghosts shaded by the iris with its diffraction ringing
    std::string flare_look;           // per-ghost colour/gain/offset and imperfect symmetry (TOML)
    double min_light = 1e-3;          // lights dimmer than this fraction of the brightest are skipped
    std::string layer;                // write the flare as channels LAYER.R/G/B instead of adding it
    AccelerationSettings accel;       // the ghost renderer's switches (all on by default)
    double visibility = 1.0;          // scene culling: the culled ghosts add at most this many visible levels
    bool no_scene_cull = false;       // draw every ghost the level of detail keeps, however dim against the plate
    FlareControls controls;           // --ghost-gain, --extended-gain, --matte, --matte-channel, --add-light
    MemoryBudget memory;              // --memory-limit: the lens tables and each frame's flare are sized against it
};

// Adds --lens, --zoom, --fstop, --blades, --coating, --coating-spread, --threshold, --max-lights, --sensor, --fov, --gain,
// --source-gain, --flare-only, --tracks, --gpu, --grid, --parts, --starburst-gain, --starburst-scale, --bands,
// --band-filter, --ringing, --flare-look, --min-light, --layer, --visibility, --no-scene-cull, the pupil's dirt (add_pupil_options), the
// renderer's accelerations (add_acceleration_options) and the compositor's controls (flare_controls.h).
void add_flare_options(CLI::App& app, FlareSettings& settings);

// --coating and --coating-spread (both commands), and what they do to a realized system.
void add_coating_options(CLI::App& app, std::string& coating, double& spread, const std::string& group);
void apply_coatings(optics::System& system, const std::string& coating, double spread);

// The frame as the lens sees it (sensor, pixels, the mapping from pixels to light directions).
using FlareGeometry = flare::SensorView;

struct FlareParts {
    bool ghosts = true;
    bool starburst = true;
};
// "ghosts", "starburst", "ghosts,starburst" (any order); throws std::invalid_argument naming a bad part.
FlareParts parse_parts(std::string_view text);

// The working space's primaries as the renderers take them: XYZ -> RGB (inverse of RGB -> XYZ, row-major).
optics::Mat3 xyz_to_rgb_of(const std::array<double, 9>& rgb_to_xyz);

// The fade of a light whose luminous flux is `relative` times the brightest light's: 0 below min_light,
// 1 from 2 x min_light, smooth in between, so a light crossing the limit fades instead of popping.
double min_light_fade(double relative, double min_light);

class FlareStage final : public Stage {
public:
    // `gpu`: the run's shared GL context (a private one when null). `working_rgb_to_xyz`: the working
    // space's RGB -> XYZ (row-major), asked at each frame (the colour stages know it from the first frame);
    // when null or empty, linear Rec.709. The starburst and the spectral weights use its primaries.
    using PrimariesSource = std::function<std::optional<std::array<double, 9>>()>;
    explicit FlareStage(FlareSettings settings, std::shared_ptr<GpuSession> gpu = nullptr,
                        PrimariesSource working_rgb_to_xyz = nullptr);
    ~FlareStage() override;

    std::string_view name() const override { return "flare"; }
    void process(Frame& frame) override;
    // detect, direct (light strengths), starburst, ghosts, extended (footprint convolution), composite.
    std::vector<std::pair<std::string, double>> part_times() const override;
    // lights (rendered), and when the detector ran: sources, brightest (luminance), threshold.
    std::vector<std::pair<std::string, double>> frame_figures() const override;
    // Lights per frame so far, and the brightest luminance seen (for the end-of-run line).
    [[nodiscard]] const LightSummary& summary() const;

private:
    struct State;
    std::unique_ptr<State> state_;
};

}  // namespace lensfx::filter
