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

#include <detect/source.h>
#include <filter/frame.h>
#include <filter/flare_controls.h>
#include <filter/flare_settings.h>
#include <filter/gpu_session.h>
#include <gpu/flare.h>
#include <optics/lens.h>
#include <optics/memory_budget.h>
#include <optics/starburst.h>

namespace lensfx::filter {

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

// Power (mm^2 per unit irradiance) that a collimated light at angles (ax, ay) delivers through the lens's
// direct path to the sensor, per channel: pupil area seen along the beam x transmission, with vignetting
// by every clear aperture and the iris, summed over the passes with their weights (empty: RGB mode's
// three wavelengths). The light's irradiance is its image's recorded energy (flux x pixel area) over this.
std::array<double, 3> direct_power(const optics::System& system, double ax_deg, double ay_deg, int rays = 64,
                                   const std::vector<gpu::SpectralPass>& passes = {});

// direct_power over the field: sampled at `samples` field angles from 0 to max_field_deg along +x and
// interpolated (cubic) at a light's field angle atan(hypot(tan ax, tan ay)). The lens is rotationally
// symmetric, so only a bladed iris clipped by another aperture makes the power depend on the azimuth.
// Samples are traced when a lookup first needs them, so a run pays only for the field its lights cross;
// save/load keep them on disk between runs.
class DirectPowerTable {
public:
    DirectPowerTable() = default;
    DirectPowerTable(const optics::System& system, double max_field_deg, int samples = 12, int rays = 96,
                     std::vector<gpu::SpectralPass> passes = {});
    [[nodiscard]] std::array<double, 3> at(double ax_deg, double ay_deg) const;
    [[nodiscard]] double max_field_deg() const { return max_field_deg_; }
    [[nodiscard]] bool empty() const { return power_.empty(); }
    [[nodiscard]] int traced() const;  // samples traced (or loaded) so far

    // A file holding `key` (what the table was made from) and the samples known; load() takes the known
    // samples of a file with the same key and sample count and returns whether it did.
    void save(const std::filesystem::path& path, const std::string& key) const;
    bool load(const std::filesystem::path& path, const std::string& key);

private:
    optics::System system_;
    std::vector<gpu::SpectralPass> passes_;
    int rays_ = 0;
    double max_field_deg_ = 0.0;
    mutable std::vector<std::array<double, 3>> power_;
    mutable std::vector<char> known_;
    const std::array<double, 3>& sample(int i) const;
};

// The fade of a light whose luminous flux is `relative` times the brightest light's: 0 below min_light,
// 1 from 2 x min_light, smooth in between, so a light crossing the limit fades instead of popping.
double min_light_fade(double relative, double min_light);

// Where computed textures are kept: gpu::default_cache_dir() ($LENSFX_CACHE_DIR, "none" = empty, else
// $XDG_CACHE_HOME/lensfx, else ~/.cache/lensfx).
std::string cache_directory();

// The starburst of an iris with these options, read from `cache_dir` when a file for exactly these is
// there, else computed and stored there (best effort: a cache that cannot be written is skipped; a damaged
// file is recomputed). Empty cache_dir: always computed.
optics::Starburst cached_starburst(const optics::Aperture& aperture, const optics::StarburstOptions& options,
                                   const std::string& cache_dir);

// What the passes depend on, for cache keys: wavelengths and weights at full precision.
std::string passes_key(const std::vector<gpu::SpectralPass>& passes);

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
