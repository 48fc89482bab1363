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
#include <flare/flare.h>
#include <optics/lens.h>
#include <optics/memory_budget.h>
#include <optics/starburst.h>

namespace lensfx::filter {

// The frame as the lens sees it (sensor, pixels, the mapping from pixels to light directions).
using FlareGeometry = flare::SensorView;

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
    // The GL targets of a prescription's ghosts at the display window (gpu::render_target_bytes): kept for
    // the next frame, and above 4K, where they are released, most of their memory stays with the driver
    // (llvmpipe gave back 0.07 of 0.72 GB at 8K); and the footprint FFTs' arrays the frames so far kept
    // (flare::ConvolveScratch, at most some 50 MB).
    std::size_t held_bytes(const ImageSpec& spec) const override;
    // Lights per frame so far, and the brightest luminance seen (for the end-of-run line).
    [[nodiscard]] const LightSummary& summary() const;

private:
    struct State;
    std::unique_ptr<State> state_;
};

// The working space's XYZ -> RGB as the optics core's rows: the inverse of what `working_rgb_to_xyz` gives,
// or Rec. 709's when it is null or gives nothing (the flare's and the lens blur's spectral weights).
optics::Mat3 working_xyz_to_rgb(const FlareStage::PrimariesSource& working_rgb_to_xyz);

}  // namespace lensfx::filter
