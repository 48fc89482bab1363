// Small GPU-against-reference comparisons: one ghost, a styled ghost, ringing.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <gtest/gtest.h>

#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace lensfx::gpu {
namespace {

using namespace lensfx::flare;  // the view, the reference and the comparisons the GPU image is held to

// One ghost of the Cooke triplet at one wavelength: the GPU image holds the reference's power and lies
// where the reference puts it.
TEST(FlareRenderer, OneGhostMatchesTheReference) {
    const optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    FlareView view;
    view.angle_x_deg = 6.0;
    view.angle_y_deg = 4.0;
    view.width = 72;
    view.height = 48;
    view.wavelength_nm = 550.0;
    const std::vector<optics::Ghost> ghosts = optics::enumerate_ghosts(system);
    ASSERT_FALSE(ghosts.empty());
    view.only_ghosts = {{ghosts[0].first, ghosts[0].second}};

    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    const FlareImage image = renderer.render(system, view);
    ReferenceOptions reference_options;
    reference_options.rays = 300;
    const FlareImage reference = render_reference(system, view, reference_options);
    const FlareError error = compare_flare(image, reference, view);
    ASSERT_GT(reference.total_power(view)[1], 0.0);
    EXPECT_LT(error.total, 0.02);
    EXPECT_LT(error.block_l1, 0.10);
    for (float v : image.rgb) ASSERT_TRUE(std::isfinite(v) && v >= 0.0f);
}

struct Moments {
    double power = 0.0, x = 0.0, y = 0.0;
};
Moments moments(const FlareImage& image, int c) {
    Moments m;
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const double v = image.at(x, y, c);
            m.power += v;
            m.x += v * (x + 0.5);
            m.y += v * (y + 0.5);
        }
    if (m.power > 0.0) {
        m.x /= m.power;
        m.y /= m.power;
    }
    return m;
}

// A ghost's style: gains per channel scale its power exactly; an offset moves it rigidly on the sensor.
TEST(FlareRenderer, GhostStyleScalesAndMovesOneGhost) {
    const optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    FlareView view;
    view.angle_x_deg = 3.0;
    view.angle_y_deg = 2.0;
    view.width = 72;
    view.height = 48;
    view.wavelength_nm = 550.0;
    // Surfaces 1 and 7: a small, concentrated ghost well inside the frame. Surfaces 1 and 3: a wash.
    view.only_ghosts = {{0, 6}};

    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    GpuFlareOptions options;
    options.grid = 64;
    const FlareImage plain = renderer.render(system, view, options);
    options.styles = {{0, 6, {2.0, 0.5, 0.0}, {1.5, 1.0}}, {0, 2, {0.0, 0.0, 0.0}, {}}};  // the wash is not drawn
    const FlareImage styled = renderer.render(system, view, options);
    view.only_ghosts.push_back({0, 2});
    const FlareImage with_hidden = renderer.render(system, view, options);
    EXPECT_EQ(styled.rgb, with_hidden.rgb) << "a ghost with zero gain adds nothing";

    const Moments m0 = moments(plain, 0);
    ASSERT_GT(m0.power, 0.0);
    const Moments r = moments(styled, 0);
    EXPECT_NEAR(r.power / m0.power, 2.0, 0.02);
    EXPECT_NEAR(moments(styled, 1).power / m0.power, 0.5, 0.005);
    EXPECT_EQ(moments(styled, 2).power, 0.0);
    // 1.5 mm right and 1 mm up at 0.5 mm per pixel.
    EXPECT_NEAR(r.x - m0.x, 3.0, 0.1);
    EXPECT_NEAR(r.y - m0.y, -2.0, 0.1);
}

// The high quality mode shades ghosts by the iris with its ringing: the same energy (the FrFT keeps it),
// with fringes that change the picture.
TEST(FlareRenderer, RingingKeepsTheEnergyAndAddsFringes) {
    optics::System system = optics::realize(optics::load_lens("brendel-tessar"), 0.0, 11.0);
    FlareView view;
    view.angle_x_deg = 2.0;
    view.angle_y_deg = 1.0;
    view.width = 180;
    view.height = 120;
    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    GpuFlareOptions options;
    options.grid = 96;
    const FlareImage sharp = renderer.render(system, view, options);
    options.ringing = true;
    const FlareImage ringing = renderer.render(system, view, options);
    for (int c = 0; c < 3; ++c) {
        const double p0 = moments(sharp, c).power;
        const double p1 = moments(ringing, c).power;
        ASSERT_GT(p0, 0.0);
        EXPECT_NEAR(p1 / p0, 1.0, 0.03) << "channel " << c;
    }
    double changed = 0.0, total = 0.0;
    for (std::size_t i = 0; i < sharp.rgb.size(); ++i) {
        ASSERT_TRUE(std::isfinite(ringing.rgb[i]) && ringing.rgb[i] >= 0.0f);
        changed += std::abs(static_cast<double>(ringing.rgb[i]) - static_cast<double>(sharp.rgb[i]));
        total += static_cast<double>(sharp.rgb[i]);
    }
    EXPECT_GT(changed / total, 0.01);
}

// A caustic ghost on dense grids: its triangles fall from several pixels to well under one across the
// caustic. Drawn with area coverage both grids give the same smooth image (each pixel the light of the part
// of it a triangle covers), so their gradients agree; point-sampled triangles handing over to splats drew a
// dotted ring where the triangles passed a pixel and fine rings beating against the pixels inside it, at
// places that moved with the grid (gradient error 0.86 between these two renders; 0.035 with area coverage).
TEST(FlareRenderer, CausticGhostOnDenseGridsIsTheSameSmoothImage) {
    const optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    FlareView view;
    view.angle_x_deg = 14.0;
    view.angle_y_deg = 9.0;
    view.width = 480;
    view.height = 320;
    view.wavelength_nm = 550.0;
    view.only_ghosts = {{6, 0}};  // surfaces 1 and 7: the caustic at the lower left
    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    GpuFlareOptions dense;
    dense.accel.bounding = Bounding::None;
    dense.accel.adaptive = dense.accel.lod = dense.accel.reduced = false;
    dense.grid = 256;
    const FlareImage coarser = renderer.render(system, view, dense);
    dense.grid = 512;
    const FlareImage finer = renderer.render(system, view, dense);
    const double power = finer.total_power(view)[1];
    ASSERT_GT(power, 0.0);
    EXPECT_NEAR(coarser.total_power(view)[1] / power, 1.0, 0.005);
    const double gradient = gradient_error(coarser, finer);
    RecordProperty("gradient_error", std::to_string(gradient));
    EXPECT_LT(gradient, 0.1);
}

// A ghost whose rim is a thin bright line (pbrt's double Gauss, surfaces 5 and 7: the large ghost of
// CandleGlass.exr's flame): the default grid's cells crowd into slivers and sub-pixel triangles along it.
// Drawn with area coverage, each with its own flux, they add up to the line a dense grid draws; pixel centres
// caught the slivers by chance, and 3 x 3 point splats of the sub-pixel ones drew the line as dots 4.3x
// brighter than its peak on a 256-cell grid.
TEST(FlareRenderer, ThinBrightRimIsALineNotDots) {
    const optics::System system = optics::realize(optics::load_lens("pbrt-dgauss-50"));
    FlareView view;
    view.angle_x_deg = -5.5;
    view.angle_y_deg = 0.1;
    view.width = 1000;
    view.height = 810;
    view.sensor_height_mm = 36.0 * 810 / 1000;
    view.wavelength_nm = 550.0;
    view.only_ghosts = {{6, 4}};
    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    const FlareImage image = renderer.render(system, view);
    GpuFlareOptions dense;
    dense.accel.bounding = Bounding::None;
    dense.accel.adaptive = dense.accel.lod = dense.accel.reduced = false;
    dense.grid = 256;
    const FlareImage reference = renderer.render(system, view, dense);
    auto peak = [](const FlareImage& f) { return static_cast<double>(*std::max_element(f.rgb.begin(), f.rgb.end())); };
    const double power = reference.total_power(view)[1];
    ASSERT_GT(power, 0.0);
    EXPECT_NEAR(image.total_power(view)[1] / power, 1.0, 0.01);
    RecordProperty("peak_ratio", std::to_string(peak(image) / peak(reference)));
    EXPECT_LT(peak(image), 1.5 * peak(reference));
}

// A ghost's light where a lens's rim or the iris cuts it: each pixel there takes the share of it inside the cut (a
// ramp a pixel wide), as the dense reference's rays do, not all or nothing by its centre, which drew the cut as a
// staircase. Measured on the pixels a strong step passes (their 4 neighbours differ by more than twice): where the
// pixel lies between its darkest and brightest neighbour. Cut at the centre, a pixel is one side or the other
// (near 0 or 1); by its share, between. Cases: canon-70-200's ghost 12,19 of pan1080's fill light, whose hole
// edge a rim cuts (drawn by its indices); nikon-80-200's 1,8, cut by the iris's blades (area coverage); the
// CandleGlass ghost of pbrt-dgauss-50 (the thin-rim ghost).
struct CutCase {
    const char* lens;
    double ax, ay;
    int first, second;  // the ghost's surfaces, 0-based
    int width, height;
    double wavelength_nm;
};

class CutEdges : public ::testing::TestWithParam<CutCase> {};

TEST_P(CutEdges, TakeTheShareOfThePixelInsideTheCut) {
    const CutCase& c = GetParam();
    const optics::System system = optics::realize(optics::load_lens(c.lens));
    FlareView view;
    view.angle_x_deg = c.ax;
    view.angle_y_deg = c.ay;
    view.width = c.width;
    view.height = c.height;
    view.sensor_height_mm = view.sensor_width_mm * c.height / c.width;
    view.wavelength_nm = c.wavelength_nm;
    view.only_ghosts = {{c.first, c.second}};
    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    const FlareImage image = renderer.render(system, view);
    const int w = view.width, h = view.height;
    auto at = [&](int x, int y) { return static_cast<double>(image.rgb[(static_cast<std::size_t>(y) * w + x) * 3 + 1]); };
    // Pixel (x, y) where, along (dx, dy), the light steps from one plateau to another (each side's next pixel within
    // 30% of its neighbour, the sides four times apart): not a caustic's line one pixel wide.
    int steps = 0, between = 0;
    auto judge = [&](int x, int y, int dx, int dy) {
        const double a = at(x - dx, y - dy), b = at(x + dx, y + dy);
        const double a2 = at(x - 2 * dx, y - 2 * dy), b2 = at(x + 2 * dx, y + 2 * dy);
        const double lo = std::min(a, b), hi = std::max(a, b);
        const double lo2 = a < b ? a2 : b2, hi2 = a < b ? b2 : a2;
        if (!(hi > 4.0 * lo && hi2 > 0.7 * hi && hi2 < 1.3 * hi && lo2 < 1.3 * lo + 0.05 * hi)) return;
        ++steps;
        const double t = (at(x, y) - lo) / (hi - lo);
        between += t > 0.1 && t < 0.9;
    };
    for (int y = 2; y + 2 < h; ++y)
        for (int x = 2; x + 2 < w; ++x) {
            judge(x, y, 1, 0);
            judge(x, y, 0, 1);
        }
    ASSERT_GT(steps, 50) << "too few steps to judge";
    const double share = static_cast<double>(between) / steps;
    RecordProperty("step_pixels", std::to_string(steps));
    RecordProperty("between_share", std::to_string(share));
    EXPECT_GT(share, 0.2);  // measured: 0.24, 0.57, 0.51; cut at pixel centres 0.11, 0.17, 0.10
}

INSTANTIATE_TEST_SUITE_P(Ghosts, CutEdges,
                         ::testing::Values(CutCase{"canon-70-200", 5.09, 2.73, 11, 18, 1920, 1080, 650.0},
                                           CutCase{"nikon-80-200", 11.41, 7.68, 0, 7, 960, 640, 550.0},
                                           CutCase{"pbrt-dgauss-50", -5.5, 0.1, 6, 4, 1000, 810, 550.0}));

// FlareRenderer::prepare (the filter's warm-up on the context's worker) changes nothing drawn: a prepared
// renderer's images are bit for bit a fresh one's, at the warm-up's own size (whose targets it drew into) and at
// a frame's, for a lens with every ghost and for one ghost alone (too few ghosts to warm up with).
TEST(FlareRenderer, APreparedRendererDrawsWhatAFreshOneDraws) {
    const optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    const Context context(Platform::Surfaceless);
    for (const int side : {kWarmUpSide, 96}) {
        for (const bool one_ghost : {false, true}) {
            FlareView view;
            view.angle_x_deg = 8.0;
            view.angle_y_deg = -3.0;
            view.width = side;
            view.height = side;
            if (one_ghost) {
                const std::vector<optics::Ghost> ghosts = optics::enumerate_ghosts(system);
                view.only_ghosts = {{ghosts[0].first, ghosts[0].second}};
            }
            FlareRenderer fresh(context);
            const FlareImage expected = fresh.render(system, view);
            FlareRenderer prepared(context);
            prepared.prepare(system, view, {});
            const FlareImage image = prepared.render(system, view);
            double power = 0.0;
            for (const float v : expected.rgb) power += static_cast<double>(v);
            EXPECT_GT(power, 0.0) << side << (one_ghost ? " one ghost" : "");
            EXPECT_EQ(image.rgb, expected.rgb) << side << (one_ghost ? " one ghost" : "");
        }
    }
}

}  // namespace
}  // namespace lensfx::gpu
