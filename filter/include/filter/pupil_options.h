// What the iris lets through besides its shape (flare paper section 5), as the command line states it:
// dust, scratches and a greyscale aperture image, for the starburst of `lensfx` and `lensfx flare`.
#pragma once

#include <string>


#include <optics/imperfections.h>
#include <optics/starburst.h>

namespace CLI {
class App;
}

namespace lensfx::filter {

struct PupilSettings {
    double dust = 0.0;            // dust specks over the pupil's unit disc
    double dust_size = 0.01;      // mean speck radius, in stop radii
    double dust_opacity = 1.0;
    int scratches = 0;
    double scratch_length = 0.5;  // stop radii
    double scratch_width = 0.004;
    double scratch_angle_deg = 0.0;
    double scratch_spread_deg = 180.0;
    unsigned long long seed = 1;
    std::string aperture_image;   // greyscale transmission image replacing the iris shape
};

// Adds --dust, --dust-size, --dust-opacity, --scratches, --scratch-length, --scratch-width,
// --scratch-angle, --scratch-spread, --dirt-seed and --aperture-image to `app`.
void add_pupil_options(CLI::App& app, PupilSettings& settings);

// The starburst options the settings ask for; reads the aperture image (throws naming the file).
optics::StarburstOptions starburst_options(const PupilSettings& settings);

// A greyscale transmission image (the mean of its colour channels, clamped to [0, 1], alpha ignored),
// padded with opaque borders to a square centred on the image so the iris keeps the image's aspect. An image
// wider or taller than kMaxApertureSide is averaged down in blocks to fit it (the starburst samples the stop
// some 400 times across). Throws std::runtime_error naming the file when it cannot be read or is empty.
inline constexpr int kMaxApertureSide = 2048;
optics::ApertureImage read_aperture_image(const std::string& path);

}  // namespace lensfx::filter
