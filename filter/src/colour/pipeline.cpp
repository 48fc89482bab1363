// The colour pipeline of a run (filter/colour/pipeline.h): the working space and its primaries, and the
// transforms into it, back out of it and to the display.
#include <filter/colour/pipeline.h>

#include <cmath>
#include <stdexcept>
#include <string_view>

#include <fmt/core.h>

#include "ocio_parts.h"

namespace lensfx::colour {

namespace {

// The input's colour space is scene-linear: measured through the config where it can convert to ACES, else
// trusted from the colour space's encoding or its being the scene_linear role.
bool is_scene_linear(const OCIO::ConstConfigRcPtr& cfg, const std::string& space, bool measured_linear) {
    if (cfg->getColorSpace(OCIO::ROLE_INTERCHANGE_SCENE)) return measured_linear;
    const auto cs = cfg->getColorSpace(space.c_str());
    const auto scene_linear = cfg->getColorSpace(OCIO::ROLE_SCENE_LINEAR);
    return std::string_view(cs->getEncoding()) == "scene-linear" ||
           (scene_linear && std::string_view(scene_linear->getName()) == cs->getName());
}

// The scene_linear role's colour space, where a non-linear input is worked on.
std::string scene_linear_role(const ColourConfig& config, const std::string& input_space) {
    const auto scene_linear = config.ocio()->getColorSpace(OCIO::ROLE_SCENE_LINEAR);
    if (!scene_linear)
        throw std::runtime_error(fmt::format(
            "input colour space '{}' is not scene-linear and OCIO config {} has no scene_linear role to work in",
            input_space, config.source()));
    return scene_linear->getName();
}

// Primaries measured through OCIO (an RGB -> ACES2065-1 matrix), snapped to the exact values when they are
// one of the known sets; ACES spaces come out Bradford-adapted to D65 and get their own (native) white.
Chromaticities measured_primaries(const Mat3& to_ap0) {
    const Chromaticities adapted = primaries_of(multiply(ap0_to_xyz_d65_matrix(), to_ap0));
    const std::array<float, 8> measured = packed(adapted);
    Chromaticities primaries = adapted;
    if (const auto k = identify_primaries(measured)) primaries = chromaticities(*k);
    for (auto k : {KnownPrimaries::AcesAP0, KnownPrimaries::AcesAP1}) {
        const Chromaticities native = chromaticities(k);
        const std::array<float, 8> as_measured =
            packed(primaries_of(multiply(bradford(native.wx, native.wy, d65_x, d65_y), rgb_to_xyz(native))));
        bool same = true;
        for (std::size_t i = 0; i < 8 && same; ++i)
            same = std::abs(static_cast<double>(as_measured[i]) - static_cast<double>(measured[i])) < 2e-3;
        if (same) primaries = native;
    }
    return primaries;
}

// The working space's name, whether it is the input's own, and its primaries: from the file's
// chromaticities when the input space came from them, else measured, else Rec.709 (assumed).
WorkingSpace working_space(const ColourConfig& config, const std::string& input_space, const ColourOptions& options,
                           const std::optional<std::array<float, 8>>& exr_chromaticities) {
    const auto& cfg = config.ocio();
    WorkingSpace w;
    auto to_ap0 = measure_to_ap0(cfg, input_space);
    if (is_scene_linear(cfg, input_space, to_ap0.has_value())) {
        w.name = input_space;
        w.is_input_space = true;
    } else {
        w.name = scene_linear_role(config, input_space);
        to_ap0 = measure_to_ap0(cfg, w.name);
    }
    if (exr_chromaticities && options.colorspace.empty()) {
        const auto known = identify_primaries(*exr_chromaticities);
        w.primaries = known ? chromaticities(*known) : widened(*exr_chromaticities);
    } else if (to_ap0) {
        w.primaries = measured_primaries(*to_ap0);
    } else {
        w.primaries = chromaticities(KnownPrimaries::Rec709);
        w.primaries_assumed = true;
    }
    w.rgb_to_xyz = rgb_to_xyz(w.primaries);
    return w;
}

// Working space -> display: exposure, the look(s) (replacing the view's own), the display's view; clamped.
ColourTransform display_transform(const ColourConfig& config, const std::string& working,
                                  const ColourOptions& checked) {
    auto group = OCIO::GroupTransform::Create();
    if (checked.exposure_ev != 0.0) {
        const double s = std::exp2(checked.exposure_ev);
        group->appendTransform(matrix_transform({s, 0, 0, 0, s, 0, 0, 0, s}));
    }
    auto dvt = OCIO::DisplayViewTransform::Create();
    dvt->setSrc(working.c_str());
    dvt->setDisplay(checked.display.c_str());
    dvt->setView(checked.view.c_str());
    if (!checked.look.empty()) {
        auto lt = OCIO::LookTransform::Create();
        lt->setSrc(working.c_str());
        lt->setDst(working.c_str());
        lt->setLooks(checked.look.c_str());
        group->appendTransform(lt);
        dvt->setLooksBypass(true);
    }
    group->appendTransform(dvt);
    try {
        return ColourTransform(config.ocio()->getProcessor(group), true);
    } catch (const OCIO::Exception& e) {
        throw std::runtime_error(fmt::format("OCIO config {}: display '{}' view '{}'{}: {}", config.source(),
                                             checked.display, checked.view,
                                             checked.look.empty() ? "" : " look '" + checked.look + "'", e.what()));
    }
}

}  // namespace

ColourPipeline::ColourPipeline(ColourConfig config, const ColourOptions& options,
                               const std::optional<std::array<float, 8>>& exr_chromaticities)
    : config_(std::move(config)) {
    input_space_ = config_.input_space(options.colorspace, exr_chromaticities);
    working_ = working_space(config_, input_space_, options, exr_chromaticities);
    if (!working_.is_input_space) {
        to_working_ = make_transform(config_, input_space_, working_.name);
        from_working_ = make_transform(config_, working_.name, input_space_);
    }
    const ColourOptions checked = config_.checked_output_names(options);
    display_ = checked.display;
    view_ = checked.view;
    to_display_ = display_transform(config_, working_.name, checked);
}

}  // namespace lensfx::colour
