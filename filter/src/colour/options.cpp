// The colour options of the filter and their command-line flags (filter/colour/options.h).
#include <filter/colour/options.h>

#include <stdexcept>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <filter/option_checks.h>

namespace lensfx::colour {

Dither ColourArgs::dither_mode() const {
    if (dither == "none") return Dither::None;
    if (dither == "ordered") return Dither::Ordered;
    if (dither == "blue-noise") return Dither::BlueNoise;
    throw std::runtime_error(fmt::format("--dither must be none, ordered or blue-noise, not \"{}\"", dither));
}

bool ColourArgs::display_asked() const {
    return !options.display.empty() || !options.view.empty() || !options.look.empty();
}

void add_colour_options(CLI::App& app, ColourArgs& args) {
    ColourOptions& o = args.options;
    const char* group = "Colour";
    app.add_option("--colorspace,--colourspace", o.colorspace,
                   "OCIO colour space of the input (default: from the EXR chromaticities, else linear Rec.709)")
        ->group(group);
    app.add_option("--ocio", o.ocio_config, "OCIO config file (default: $OCIO, else the built-in ACES config)")
        ->group(group);
    app.add_option("--display", o.display,
                   "Display to tone map for (built-in config: srgb, rec709, rec2100-pq); also applies it to "
                   "scene-linear outputs")
        ->group(group);
    app.add_option("--view", o.view, "View of the display (default: the display's first)")->group(group);
    app.add_option("--look", o.look, "OCIO look(s) applied before the view, replacing the view's own")->group(group);
    app.add_option("--exposure", o.exposure_ev, "Exposure in stops, applied in scene-linear before the display")
        ->check(CLI::Range(-64.0, 64.0))
        ->check(filter::finite_number())
        ->group(group);
    app.add_option("--bits", args.bits, "Bits per channel of display-referred files: 8 or 16 (JPEG: 8)")
        ->check(CLI::IsMember({8, 16}))
        ->group(group);
    app.add_option("--dither", args.dither, "Dither when quantising display outputs: none, ordered, blue-noise")
        ->check(CLI::IsMember({"none", "ordered", "blue-noise"}))
        ->group(group);
    app.add_option("--colour-on,--color-on", args.device,
                   "Where the output colour transform runs: auto (the GPU when the flare stage or --gpu made a GL "
                   "context), cpu, gpu")
        ->check(CLI::IsMember({"auto", "cpu", "gpu"}))
        ->capture_default_str()
        ->group(group);
}

}  // namespace lensfx::colour
