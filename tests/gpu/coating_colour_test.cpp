// Coatings as colour: with the coating its preset documents, the Canon zoom's 20 brightest coloured ghosts
// (each ghost's RGB power on the image, saturation over 0.2) span at least 120 degrees of hue; with one
// MgF2 layer on every surface they all come out the same magenta (some 45 degrees).
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/coating.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace lensfx::gpu {
namespace {

struct Colour {
    double power, hue, saturation;
};

Colour colour_of(const std::array<double, 3>& rgb) {
    const double hi = std::max({rgb[0], rgb[1], rgb[2]}), lo = std::min({rgb[0], rgb[1], rgb[2]});
    Colour c{rgb[0] + rgb[1] + rgb[2], 0.0, hi > 0.0 ? (hi - lo) / hi : 0.0};
    if (hi <= lo) return c;
    const double d = hi - lo;
    double h = hi == rgb[0] ? (rgb[1] - rgb[2]) / d : hi == rgb[1] ? 2.0 + (rgb[2] - rgb[0]) / d : 4.0 + (rgb[0] - rgb[1]) / d;
    c.hue = std::fmod(60.0 * h + 360.0, 360.0);
    return c;
}

// Degrees of the hue circle the hues cover: 360 less the widest gap between neighbours.
double hue_span(std::vector<double> hues) {
    std::sort(hues.begin(), hues.end());
    double gap = 0.0;
    for (std::size_t i = 0; i < hues.size(); ++i)
        gap = std::max(gap, std::fmod(hues[(i + 1) % hues.size()] - hues[i] + 360.0, 360.0));
    return 360.0 - gap;
}

double brightest_coloured_span(optics::CoatingChoice choice) {
    optics::System system = optics::realize(optics::load_lens("canon-70-200"));
    optics::choose_coatings(system, choice, choice == optics::CoatingChoice::Lens ? 0.03 : 0.0);
    FlareView view;
    view.width = 240;
    view.height = 160;
    view.angle_x_deg = 12.0;
    view.angle_y_deg = 7.0;
    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    GpuFlareOptions options;
    options.per_ghost_power = true;
    const FlareImage image = renderer.render(system, view, options);
    std::vector<Colour> coloured;
    for (const GhostPower& g : image.ghosts) {
        const Colour c = colour_of(g.power);
        if (c.power > 0.0 && c.saturation > 0.2) coloured.push_back(c);
    }
    std::sort(coloured.begin(), coloured.end(), [](const Colour& a, const Colour& b) { return a.power > b.power; });
    EXPECT_GE(coloured.size(), 20u);
    std::vector<double> hues;
    for (std::size_t i = 0; i < std::min<std::size_t>(20, coloured.size()); ++i) hues.push_back(coloured[i].hue);
    return hue_span(hues);
}

TEST(CoatingColour, CanonZoomGhostsSpanTheHues) {
    const double documented = brightest_coloured_span(optics::CoatingChoice::Lens);
    RecordProperty("hue_span_documented", std::to_string(documented));
    EXPECT_GE(documented, 120.0);
    const double single = brightest_coloured_span(optics::CoatingChoice::Single);
    RecordProperty("hue_span_single", std::to_string(single));
    EXPECT_LT(single, 90.0);
}

}  // namespace
}  // namespace lensfx::gpu
