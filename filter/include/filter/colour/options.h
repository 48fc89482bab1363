// The colour options of `lensfx -i IN -o OUT` and the command-line flags that set them.
#pragma once

#include <string>

#include <filter/colour/config.h>
#include <filter/dither.h>

namespace CLI {
class App;
}

namespace lensfx::colour {

// The colour options of one run of the filter, as the command line gives them.
struct ColourArgs {
    ColourOptions options;
    int bits = 8;                       // --bits: 8 or 16 for display-referred files (PNG, TIFF; JPEG is 8)
    std::string dither = "blue-noise";  // --dither: none, ordered, blue-noise
    std::string device = "auto";        // --colour-on: auto (GPU when the run has a GL context), cpu, gpu
    Dither dither_mode() const;
    // A display transform was asked for (--display, --view or --look): scene-linear outputs get it too.
    bool display_asked() const;
};

// Adds --colorspace, --ocio, --display, --view, --look, --exposure, --bits, --dither, --colour-on to the filter.
void add_colour_options(CLI::App& app, ColourArgs& args);

}  // namespace lensfx::colour
