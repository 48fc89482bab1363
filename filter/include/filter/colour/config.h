// An OpenColorIO config (a file, $OCIO, or the built-in ACES config made in code) and the names a run asks
// of it: colour spaces, displays, views and looks, each checked with a message that lists the valid ones.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <OpenColorIO/OpenColorIO.h>

namespace lensfx::colour {

namespace OCIO = OCIO_NAMESPACE;

// What the user asked for on the command line.
struct ColourOptions {
    std::string ocio_config;   // --ocio FILE; empty: $OCIO, else the built-in config
    std::string colorspace;    // --colorspace NAME: the input's OCIO colour space; empty: from the file
    std::string display;       // --display; empty: the config's default display
    std::string view;          // --view; empty: the display's default view
    std::string look;          // --look: OCIO look(s) applied in scene-linear before the view, replacing the view's own
    double exposure_ev = 0.0;  // --exposure: scale by 2^EV in scene-linear before the display transform
};

// Names of the colour spaces, displays and views of the built-in config (used when there is no OCIO config).
namespace builtin {
inline constexpr std::string_view aces2065_1 = "ACES2065-1";
inline constexpr std::string_view acescg = "ACEScg";
inline constexpr std::string_view lin_rec709 = "Linear Rec.709 (sRGB)";
inline constexpr std::string_view lin_rec2020 = "Linear Rec.2020";
inline constexpr std::string_view lin_p3d65 = "Linear P3-D65";
inline constexpr std::string_view xyz_d65 = "CIE-XYZ-D65";
inline constexpr std::string_view display_srgb = "srgb";
inline constexpr std::string_view display_rec709 = "rec709";
inline constexpr std::string_view display_rec2100_pq = "rec2100-pq";
inline constexpr std::string_view view_sdr = "ACES 1.0 - SDR Video";
inline constexpr std::string_view view_hdr = "ACES 1.1 - HDR Video (1000 nits & Rec.2020 lim)";
inline constexpr std::string_view view_untonemapped = "Un-tone-mapped";
}  // namespace builtin

// An OpenColorIO config (a file or the built-in one) and what can be asked of it. Copyable, shares the config.
class ColourConfig {
public:
    // `path` empty: $OCIO when set, else the built-in config. Throws naming the file when it cannot be used.
    static ColourConfig load(const std::string& path);
    static ColourConfig builtin_config();

    const std::string& source() const { return source_; }  // the file, or "built-in"
    bool is_builtin() const { return builtin_; }

    std::vector<std::string> colour_spaces() const;
    std::vector<std::string> displays() const;
    std::vector<std::string> views(const std::string& display) const;
    std::vector<std::string> looks() const;
    std::string default_display() const;
    std::string default_view(const std::string& display) const;

    // The colour space of the input: `requested` (checked, also accepts roles) when not empty, else the one
    // matching the file's chromaticities, else linear Rec.709. With the built-in config any chromaticities
    // work (a colour space is added for them); with a file config known primaries are looked up by the
    // usual names. Throws naming the colour space or chromaticities and listing the valid ones.
    std::string input_space(const std::string& requested,
                            const std::optional<std::array<float, 8>>& exr_chromaticities);

    // Throwing checks with messages that list the valid names.
    void check_colour_space(const std::string& name) const;
    void check_display_view(const std::string& display, const std::string& view) const;
    void check_looks(const std::string& looks) const;
    // The display, view and looks of `options` checked (once, for the session and the pipeline alike), with
    // the config's default display and that display's default view filled in where they are empty.
    ColourOptions checked_output_names(ColourOptions options) const;

    const OCIO::ConstConfigRcPtr& ocio() const { return config_; }
    std::string serialize() const;  // the config as an .ocio file

private:
    OCIO::ConstConfigRcPtr config_;
    std::string source_;
    bool builtin_ = false;
};

}  // namespace lensfx::colour
