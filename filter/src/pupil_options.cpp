#include <filter/pupil_options.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <filter/image_io.h>
#include <filter/option_checks.h>
#include <fmt/core.h>

namespace lensfx::filter {

void add_pupil_options(CLI::App& app, PupilSettings& s) {
    const std::string group = "Iris dirt (starburst)";
    app.add_option("--dust", s.dust, "Dust specks on the pupil (section 5 of the flare paper): rainbow speckle")->group(group)->check(CLI::Range(0.0, 1e6))->check(finite_number());
    app.add_option("--dust-size", s.dust_size, "Mean dust radius, as a fraction of the stop radius")->capture_default_str()->group(group)->check(CLI::Range(1e-4, 0.5))->check(finite_number());
    app.add_option("--dust-opacity", s.dust_opacity, "Dust opacity (1 = opaque)")->capture_default_str()->group(group)->check(CLI::Range(0.0, 1.0))->check(finite_number());
    app.add_option("--scratches", s.scratches, "Scratches on the pupil: streaks across their direction")->group(group)->check(CLI::Range(0, 100000));
    app.add_option("--scratch-length", s.scratch_length, "Mean scratch length, in stop radii")->capture_default_str()->group(group)->check(CLI::Range(1e-3, 4.0))->check(finite_number());
    app.add_option("--scratch-width", s.scratch_width, "Scratch width, in stop radii")->capture_default_str()->group(group)->check(CLI::Range(1e-4, 0.5))->check(finite_number());
    app.add_option("--scratch-angle", s.scratch_angle_deg, "Mean scratch direction, degrees counter-clockwise from horizontal")->capture_default_str()->group(group)->check(finite_number());
    app.add_option("--scratch-spread", s.scratch_spread_deg, "Spread of scratch directions in degrees (180 = any)")->capture_default_str()->group(group)->check(CLI::Range(0.0, 180.0))->check(finite_number());
    app.add_option("--dirt-seed", s.seed, "Seed of the dust and scratches (the same seed, the same dirt)")->capture_default_str()->group(group);
    app.add_option("--aperture-image", s.aperture_image, "Greyscale image (white = clear) replacing the iris shape")->group(group);
}

optics::StarburstOptions starburst_options(const PupilSettings& s) {
    optics::StarburstOptions o;
    o.dirt.dust_density = s.dust / std::numbers::pi;
    o.dirt.dust_radius = s.dust_size;
    o.dirt.dust_opacity = s.dust_opacity;
    o.dirt.scratches = s.scratches;
    o.dirt.scratch_length = s.scratch_length;
    o.dirt.scratch_width = s.scratch_width;
    o.dirt.scratch_angle_deg = s.scratch_angle_deg;
    o.dirt.scratch_spread_deg = s.scratch_spread_deg;
    o.dirt.seed = s.seed;
    if (!s.aperture_image.empty()) o.image = read_aperture_image(s.aperture_image);
    return o;
}

optics::ApertureImage read_aperture_image(const std::string& path) {
    Frame frame;
    try {
        frame = read_image(path);
    } catch (const std::exception& e) {
        throw std::runtime_error(fmt::format("--aperture-image {}: {}", path, e.what()));
    }
    const ImageSpec& spec = frame.spec;
    std::vector<int> all(static_cast<std::size_t>(spec.nchannels()));
    for (int c = 0; c < spec.nchannels(); ++c) all[static_cast<std::size_t>(c)] = c;
    const std::vector<float> pixels = channels_as_float(frame, all);
    const int colours = std::clamp(spec.nchannels() - (spec.channel_index("A") >= 0 ? 1 : 0), 1, 3);
    const auto width = static_cast<std::size_t>(spec.width), channels = static_cast<std::size_t>(spec.nchannels());
    const auto transmission = [&](int x, int y) {  // the pixel's mean over its colours, 0 to 1 (not finite: 0)
        const float* p = &pixels[(static_cast<std::size_t>(y) * width + static_cast<std::size_t>(x)) * channels];
        float sum = 0.0f;
        for (int c = 0; c < colours; ++c) sum += p[c];
        const float v = sum / static_cast<float>(colours);
        return std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
    };

    // Blocks of `step` x `step` pixels averaged, so that the square the image is centred in (the stop's) is at most
    // kMaxApertureSide a side: a 20000 x 1 image padded whole took 1.6 GB, whatever --memory-limit said.
    const int step = std::max(1, (std::max(spec.width, spec.height) + kMaxApertureSide - 1) / kMaxApertureSide);
    const int w = (spec.width + step - 1) / step, h = (spec.height + step - 1) / step;
    optics::ApertureImage image;
    const int side = std::max(w, h);
    image.width = image.height = side;
    image.value.assign(static_cast<std::size_t>(side) * static_cast<std::size_t>(side), 0.0f);
    const int ox = (side - w) / 2;
    const int oy = (side - h) / 2;
    for (int by = 0; by < h; ++by) {
        for (int bx = 0; bx < w; ++bx) {
            float sum = 0.0f;
            int n = 0;
            for (int y = by * step; y < std::min(spec.height, (by + 1) * step); ++y)
                for (int x = bx * step; x < std::min(spec.width, (bx + 1) * step); ++x) sum += transmission(x, y), ++n;
            image.value[static_cast<std::size_t>(by + oy) * static_cast<std::size_t>(side) + static_cast<std::size_t>(bx + ox)] =
                sum / static_cast<float>(n);
        }
    }
    return image;
}

}  // namespace lensfx::filter
