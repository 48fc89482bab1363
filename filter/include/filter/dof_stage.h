// The lens blur of `lensfx -i IN -o OUT --dof --lens LENS --focus M`: the frame's layers (from its Z
// channel, or deep EXR samples) traced through the lens on the GPU (dof/renderer.h). With the flare, the
// lights are found on the sharp plate and the flare is added after the blur: DofStage blurs and keeps the
// sharp plate for the flare, DofComposeStage (after the flare) swaps the blurred plate in under it.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include <filter/flare_settings.h>
#include <filter/flare_stage.h>
#include <filter/frame.h>
#include <filter/gpu_session.h>

namespace lensfx::filter {

struct DofSettings {
    bool enabled = false;              // --dof
    std::optional<double> focus_m;     // object distance from the entrance pupil that is sharp
    std::string depth_channel = "Z";
    double depth_scale = 1.0;          // metres per depth unit
    std::string deep;                  // deep EXR files (comma-separated) whose samples are the layers
    int rays = 32;                     // lens rays per pixel and channel
    int max_rays = 0;                  // where the blur is wide, up to this many (0: 4 x rays, at most 256)
    bool chromatic = true;
    std::string tilt;                  // "AX,AY" degrees of sensor tilt (Scheimpflug)
    std::vector<std::string> focus_points;  // "X,Y,METRES" each (display-window pixels): a focal surface
    bool dof_only = false;             // blur without the flare
    // Shared with the flare (FlareSettings): the one lens of the run, realized as the flare's (realize_lens).
    LensChoice lens;
    std::string sensor = "36";
    std::optional<double> fov_deg;
    std::string cache_dir;             // --cache-dir: the ray table's file (empty: the default, "none": no file)
    int bands = 0;                     // --bands: 0 RGB (650/550/450 nm), else spectral bands (CIE 1931, Rec. 709)
    MemoryBudget memory;               // --memory-limit: deep inputs are sized against it
};

// --dof, --focus, --depth-channel, --depth-scale, --deep, --dof-rays, --dof-max-rays, --no-chromatic-blur, --tilt, --focus-point,
// --dof-only.
void add_dof_options(CLI::App& app, DofSettings& settings);

struct DofShared;  // the sharp and blurred plates of the current frame, between the two stages

class DofStage final : public Stage {
public:
    // flare_follows: keep R, G, B sharp for the flare stage and leave the swap to DofComposeStage.
    // `working_rgb_to_xyz`: the working space's primaries, which --bands mixes into (as the flare's; null
    // or empty: Rec. 709).
    DofStage(DofSettings settings, std::shared_ptr<GpuSession> gpu, bool flare_follows,
             FlareStage::PrimariesSource working_rgb_to_xyz = nullptr);
    ~DofStage() override;
    std::string_view name() const override { return "dof"; }
    void process(Frame& frame) override;
    std::vector<std::pair<std::string, double>> part_times() const override;
    std::shared_ptr<DofShared> shared() const;

private:
    struct State;
    std::unique_ptr<State> state_;
};

// After the flare: R, G, B = blurred plate + (what the flare added to the sharp plate).
class DofComposeStage final : public Stage {
public:
    explicit DofComposeStage(std::shared_ptr<DofShared> shared) : shared_(std::move(shared)) {}
    std::string_view name() const override { return "dof-compose"; }
    void process(Frame& frame) override;

private:
    std::shared_ptr<DofShared> shared_;
};

// The stages of --dof: the blur (before the flare) and, when the flare runs too, the compose (after it);
// both null without --dof. The lens (realize_lens: zoom, f-stop, blades, coatings), sensor and field of view
// are the flare's. `flare_runs` is set to whether the flare stage should run (--lens given and not --dof-only).
// A deep EXR as a flat frame (R, G, B, A, Z as float, each pixel's samples composited front to back,
// Z the nearest sample's): the pipeline's view of a deep input; the lens blur reads its samples again.
Frame read_deep_exr_frame(const std::string& path, const MemoryBudget& budget);

struct DofStages {
    std::unique_ptr<Stage> blur, compose;
};
DofStages make_dof_stages(DofSettings settings, const FlareSettings& flare, std::shared_ptr<GpuSession> gpu, bool& flare_runs,
                          FlareStage::PrimariesSource working_rgb_to_xyz = nullptr);

}  // namespace lensfx::filter
