// The colour stages of the filter and the session they share (filter/colour/stages.h).
#include <filter/colour/stages.h>

#include <cmath>
#include <stdexcept>

#include <fmt/core.h>

#include <filter/colour/quantise.h>
#include <flare/float_range.h>

namespace lensfx::colour {

ColourSession::ColourSession(const ColourArgs& args, const std::string& output)
    : config_(ColourConfig::load(args.options.ocio_config)),
      options_(args.options),
      display_output_(args.display_asked() || is_display_referred_format(output)),
      straight_alpha_output_(display_output_ && holds_straight_alpha(output)) {
    // Check every name now, before any frame is read.
    if (!options_.colorspace.empty()) config_.check_colour_space(options_.colorspace);
    options_ = config_.checked_output_names(options_);
}

const ColourPipeline& ColourSession::pipeline_for(const filter::Frame& frame) {
    const auto& chroma = frame.spec.chromaticities;
    if (!pipeline_) {
        pipeline_.emplace(config_, options_, chroma);
        first_chromaticities_ = chroma;
    } else if (options_.colorspace.empty() && chroma != first_chromaticities_) {
        throw std::runtime_error(fmt::format("its chromaticities ({}) differ from the first frame's ({})",
                                             chroma ? describe(*chroma) : "none",
                                             first_chromaticities_ ? describe(*first_chromaticities_) : "none"));
    }
    return *pipeline_;
}

namespace {

PixelSpan rgb_span(filter::Frame& frame) {
    return PixelSpan{frame.rgb.data(), static_cast<std::size_t>(frame.spec.width),
                     static_cast<std::size_t>(frame.spec.height), 3, 0};
}

}  // namespace

void ColourInputStage::process(filter::Frame& frame) {
    if (frame.rgb.empty()) return;  // no stage touches the pixels: nothing to resolve
    session_->pipeline_for(frame).to_working().apply(rgb_span(frame));
}

bool ColourOutputStage::wants_rgb() const {
    const auto& o = session_->options();
    return session_->display_output() || o.exposure_ev != 0.0 || !o.colorspace.empty();
}

ColourOutputStage::ColourOutputStage(std::shared_ptr<ColourSession> session, std::shared_ptr<filter::GpuSession> gpu,
                                     std::string device)
    : session_(std::move(session)), gpu_(std::move(gpu)), device_(std::move(device)) {
    if (device_ != "auto" && device_ != "cpu" && device_ != "gpu")
        throw std::invalid_argument(fmt::format("--colour-on must be auto, cpu or gpu, not \"{}\"", device_));
    if (device_ == "gpu" && !gpu_) gpu_ = std::make_shared<filter::GpuSession>();
}

ColourOutputStage::~ColourOutputStage() {
    // The compiled shaders belong to the shared context: release them while it is current.
    if ((gpu_display_ || gpu_scene_) && gpu_ && gpu_->context) gpu_->context->make_current();
}

void ColourOutputStage::apply(const ColourTransform& transform, std::unique_ptr<GpuColourTransform>& compiled,
                              PixelSpan pixels) {
    const bool gpu = !transform.is_identity() && gpu_ && (device_ == "gpu" || (device_ == "auto" && gpu_->active()));
    ran_on_gpu_ = gpu;
    if (!gpu) {
        transform.apply(pixels);
        return;
    }
    gpu_->get().make_current();
    if (!compiled) compiled = std::make_unique<GpuColourTransform>(transform);
    compiled->apply(pixels);
}

namespace {
// Divides the frame's scene-linear R, G, B by its alpha (premultiplied, as EXR holds it) where alpha is
// above 0, so that the display transform sees the surface's own colour: a straight-alpha file holds that.
// (Before, OpenImageIO divided the display code values instead, which brightened every soft edge.)
void unpremultiply(filter::Frame& frame) {
    const int a = frame.spec.channel_index("A");
    if (a < 0) return;
    const std::vector<float> alpha = filter::channels_as_float(frame, {a});
    if (alpha.size() * 3 != frame.rgb.size()) return;
    for (std::size_t i = 0; i < alpha.size(); ++i)
        if (alpha[i] > 0.0f)
            for (std::size_t c = 0; c < 3; ++c) frame.rgb[3 * i + c] /= alpha[i];
}

// Where the output transform ran, in the frame's metadata (EXR outputs keep it).
void record_device(filter::Frame& frame, bool gpu) { frame.spec.text["lensfx:colourTransformOn"] = gpu ? "gpu" : "cpu"; }
}  // namespace

void ColourOutputStage::process(filter::Frame& frame) {
    if (frame.rgb.empty()) return;
    const auto& p = session_->pipeline_for(frame);
    auto px = rgb_span(frame);
    if (session_->display_output()) {
        if (session_->straight_alpha_output()) {
            unpremultiply(frame);
            frame.spec.text.insert_or_assign("oiio:UnassociatedAlpha", std::string(1, '1'));  // the writer must not divide again
        }
        apply(p.to_display(), gpu_display_, px);
        record_device(frame, ran_on_gpu_);
        // The pixels are display code values now: the input's primaries no longer describe them.
        frame.spec.chromaticities.reset();
        const std::string& display = p.display();
        if (display == builtin::display_srgb && session_->config().is_builtin())
            frame.spec.text["oiio:ColorSpace"] = "sRGB";
        else if (display == builtin::display_rec709 && session_->config().is_builtin())
            frame.spec.text["oiio:ColorSpace"] = "Rec709";
        else
            frame.spec.text["oiio:ColorSpace"] = display;
        return;
    }
    const double ev = session_->options().exposure_ev;
    if (ev != 0.0) {
        const float s = static_cast<float>(std::exp2(ev));
        for (float& v : frame.rgb) v = flare::scaled_within_float(v, s);
    }
    apply(p.to_scene_output(), gpu_scene_, px);
    if (!p.to_scene_output().is_identity()) record_device(frame, ran_on_gpu_);
}

}  // namespace lensfx::colour
