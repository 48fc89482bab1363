// The colour stages of `lensfx -i IN -o OUT`: input -> working space first in the chain, working space ->
// display or scene-linear output last, and the session (config and pipeline) they share.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include <filter/colour/options.h>
#include <filter/colour/pipeline.h>
#include <filter/colour/transform.h>
#include <filter/frame.h>
#include <filter/gpu_session.h>

namespace lensfx::colour {

// What the colour stages of one run share: the config (loaded and checked when the run starts) and the
// ColourPipeline, made from the first frame's chromaticities. Stages run on one thread, in frame order.
class ColourSession {
public:
    // `output`: the -o argument; display-referred formats always get the display transform.
    ColourSession(const ColourArgs& args, const std::string& output);

    bool display_output() const { return display_output_; }
    // The output holds straight alpha (PNG...): colour is divided by alpha before the display transform.
    bool straight_alpha_output() const { return straight_alpha_output_; }
    const ColourConfig& config() const { return config_; }
    const ColourOptions& options() const { return options_; }  // display and view filled in
    // The pipeline for a frame: made from the first frame; a later frame whose chromaticities differ
    // from the first's is rejected (throws).
    const ColourPipeline& pipeline_for(const filter::Frame& frame);
    // Null before the first frame. The renderer reads working().rgb_to_xyz from here.
    const ColourPipeline* pipeline() const { return pipeline_ ? &*pipeline_ : nullptr; }

private:
    ColourConfig config_;
    ColourOptions options_;
    bool display_output_ = false;
    bool straight_alpha_output_ = false;
    std::optional<ColourPipeline> pipeline_;
    std::optional<std::array<float, 8>> first_chromaticities_;
};

// Input -> working space: first in the chain. Does nothing (and asks for no float buffer) unless the
// input is in a non-linear colour space (--colorspace).
class ColourInputStage final : public filter::Stage {
public:
    explicit ColourInputStage(std::shared_ptr<ColourSession> session) : session_(std::move(session)) {}
    std::string_view name() const override { return "colour-in"; }
    bool wants_rgb() const override { return !session_->options().colorspace.empty(); }
    void process(filter::Frame& frame) override;

private:
    std::shared_ptr<ColourSession> session_;
};

// Working space -> output: last in the chain. Display outputs: exposure, look, view, clamp (and the
// frame's colour metadata says display); scene-linear outputs: exposure, back to the input's space.
// The transform runs on the GPU (OCIO's shader) when `device` is "gpu" (the context is made if needed), or
// "auto" and the run's GPU session is active (the flare stage made a context, or --gpu was given); else on
// the CPU. Both agree within 1e-4.
class ColourOutputStage final : public filter::Stage {
public:
    explicit ColourOutputStage(std::shared_ptr<ColourSession> session,
                               std::shared_ptr<filter::GpuSession> gpu = nullptr, std::string device = "auto");
    ~ColourOutputStage() override;
    std::string_view name() const override { return "colour-out"; }
    bool wants_rgb() const override;
    void process(filter::Frame& frame) override;
    bool ran_on_gpu() const { return ran_on_gpu_; }  // the last frame's transform did

private:
    void apply(const ColourTransform& transform, std::unique_ptr<GpuColourTransform>& compiled, PixelSpan pixels);
    std::shared_ptr<ColourSession> session_;
    std::shared_ptr<filter::GpuSession> gpu_;
    std::string device_;
    std::unique_ptr<GpuColourTransform> gpu_display_, gpu_scene_;
    bool ran_on_gpu_ = false;
};

}  // namespace lensfx::colour
