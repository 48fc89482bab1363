// What the flare is asked to do, as plain values: the lens choice both flare commands share (`lensfx` and
// `lensfx flare`) and realize in one way, and the flare stage's settings. The command-line options that fill
// them are declared here too, against a forward-declared CLI::App: this header pulls in no CLI11.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>

#include <filter/flare_controls.h>
#include <filter/ghost_options.h>
#include <filter/pupil_options.h>
#include <optics/memory_budget.h>
#include <optics/system.h>

namespace CLI {
class App;
}

namespace lensfx::filter {

// The lens of a flare: --lens, --zoom, --fstop, --blades, --coating, --coating-spread.
struct LensChoice {
    std::string lens;                 // preset name or lens file; empty: no flare stage
    std::string zoom;                 // "0.5" (zoom parameter) or "135mm" (label); empty: the first position
    std::optional<double> fstop;      // sets the stop so the lens's f-number is this
    std::optional<int> blades;        // overrides the lens's iris blade count (0 = round)
    std::string coating = "lens";     // uncoated, single, multi or lens (optics::CoatingChoice)
    double coating_spread = 0.03;     // relative thickness spread of every coating layer (seeded)
};

// A prescription realized as its LensChoice asks, and that choice in words (the lens as TOML, zoom, f-stop,
// blades, coatings): what tables computed from the system are keyed by.
struct RealizedLens {
    optics::System system;
    std::string text;
};
// Loads the lens, sets --blades (0 or 3 to 64; 1 and 2 are refused naming --blades), realizes it at --zoom and
// --fstop and applies the coatings. Throws naming the option or file at fault.
RealizedLens realize_lens(const LensChoice& choice);

struct FlareSettings : LensChoice {
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

// Adds --lens, the lens options (add_lens_options), --threshold, --max-lights, --sensor, --fov, --gain,
// --source-gain, --flare-only, --tracks, --gpu, --grid, --parts, --starburst-gain, --starburst-scale, --bands,
// --band-filter, --ringing, --flare-look, --min-light, --layer, --visibility, --no-scene-cull, the pupil's dirt
// (add_pupil_options), the renderer's accelerations (add_acceleration_options) and the compositor's controls
// (flare_controls.h).
void add_flare_options(CLI::App& app, FlareSettings& settings);
// --zoom, --fstop, --blades, --coating and --coating-spread (--lens is each command's own: required or not),
// worded and checked the same for both commands.
void add_lens_options(CLI::App& app, LensChoice& choice, const std::string& group);

// --coating and --coating-spread, and what they do to a realized system.
void add_coating_options(CLI::App& app, std::string& coating, double& spread, const std::string& group);
void apply_coatings(optics::System& system, const std::string& coating, double spread);

// A sensor's width and height in mm at least and at most: a phone's to large-format film's (20x24 in, 610 mm),
// with room. Beyond them the starburst's pixel arithmetic overflowed (lensfx flare --sensor 1e308 and 1e-10
// crashed, 1x1e308 never ended) and under 0.1 mm a light's ghosts take minutes.
inline constexpr double kMinSensorMm = 0.1, kMaxSensorMm = 1000.0;

// --sensor: "36" (the width, height 0: from the image's aspect) or "36x24" (mm), each given side within
// kMinSensorMm..kMaxSensorMm; throws std::invalid_argument naming the option otherwise.
std::array<double, 2> parse_sensor(const std::string& text);

struct FlareParts {
    bool ghosts = true;
    bool starburst = true;
};
// "ghosts", "starburst", "ghosts,starburst" (any order); throws std::invalid_argument naming a bad part.
FlareParts parse_parts(std::string_view text);

}  // namespace lensfx::filter
