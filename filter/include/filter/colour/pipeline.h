// The colour pipeline of a run: input space -> scene-linear working space (and its primaries, for the
// renderer's spectral-to-RGB conversion) -> scene-linear output or display (exposure, look, view, clamp).
#pragma once

#include <array>
#include <optional>
#include <string>

#include <filter/colour/config.h>
#include <filter/colour/matrix.h>
#include <filter/colour/transform.h>

namespace lensfx::colour {

// The scene-linear space the flare is rendered and composited in.
struct WorkingSpace {
    std::string name;             // the OCIO colour space
    Chromaticities primaries;     // measured through the config when not known by name
    Mat3 rgb_to_xyz;              // of `primaries`: for the renderer's spectral -> RGB (use inverse())
    bool is_input_space = false;  // the input is already scene-linear in this space (no conversion)
    bool primaries_assumed = false;  // the config cannot convert to ACES and no chromaticities: Rec.709 assumed
};

// Everything a run of the filter needs: input -> working, working -> scene-linear output (back to the
// input's space), working -> display (exposure, look, view, clamp).
class ColourPipeline {
public:
    // Checks every name against the config; throws with the valid choices.
    ColourPipeline(ColourConfig config, const ColourOptions& options,
                   const std::optional<std::array<float, 8>>& exr_chromaticities);

    const ColourConfig& config() const { return config_; }
    const std::string& input_space() const { return input_space_; }
    const WorkingSpace& working() const { return working_; }
    const std::string& display() const { return display_; }
    const std::string& view() const { return view_; }

    const ColourTransform& to_working() const { return to_working_; }
    const ColourTransform& to_scene_output() const { return from_working_; }
    const ColourTransform& to_display() const { return to_display_; }

private:
    ColourConfig config_;
    std::string input_space_;
    WorkingSpace working_;
    std::string display_;
    std::string view_;
    ColourTransform to_working_;
    ColourTransform from_working_;
    ColourTransform to_display_;
};

}  // namespace lensfx::colour
