// Fast checks of the flare definitions (iris SDF, image orientation, ghost selection) and one small
// GPU-against-reference comparison.
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <gtest/gtest.h>

#include <gpu/context.h>
#include <gpu/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace lensfx::gpu {
namespace {

TEST(ApertureSdf, RoundIsTheUnitCircle) {
    const optics::Aperture round{};
    EXPECT_DOUBLE_EQ(aperture_sdf(round, 0.0, 0.0), -1.0);
    EXPECT_NEAR(aperture_sdf(round, 0.6, 0.8), 0.0, 1e-12);
    EXPECT_NEAR(aperture_sdf(round, 2.0, 0.0), 1.0, 1e-12);
}

TEST(ApertureSdf, PolygonCornersOnTheCircleFirstEdgeAtTheBottom) {
    optics::Aperture pentagon;
    pentagon.blades = 5;
    const double apothem = std::cos(std::numbers::pi / 5);
    EXPECT_NEAR(aperture_sdf(pentagon, 0.0, -apothem), 0.0, 1e-12);  // bottom edge, horizontal
    EXPECT_NEAR(aperture_sdf(pentagon, 0.0, 1.0), 0.0, 1e-12);       // the opposite corner
    EXPECT_LT(aperture_sdf(pentagon, 0.0, 0.0), 0.0);
    EXPECT_GT(aperture_sdf(pentagon, 0.0, -0.9), 0.0);  // inside the circle, outside the polygon
    pentagon.rotation_deg = 36.0;  // a half turn of the pattern: the corner is now at the bottom
    EXPECT_NEAR(aperture_sdf(pentagon, 0.0, -1.0), 0.0, 1e-12);
    EXPECT_NEAR(aperture_sdf(pentagon, 0.0, apothem), 0.0, 1e-12);
}

TEST(ApertureSdf, CurvedBladesLieBetweenPolygonAndCircle) {
    optics::Aperture hexagon;
    hexagon.blades = 6;
    optics::Aperture curved = hexagon;
    curved.blade_curvature = 0.5;
    optics::Aperture circle = hexagon;
    circle.blade_curvature = 1.0;
    const double apothem = std::cos(std::numbers::pi / 6);
    const double y = -(apothem + 1.0) / 2.0;  // between the straight edge and the circle
    EXPECT_GT(aperture_sdf(hexagon, 0.0, y), 0.0);
    EXPECT_NEAR(aperture_sdf(circle, 0.0, y), aperture_sdf(optics::Aperture{}, 0.0, y), 1e-12);
    EXPECT_LT(aperture_sdf(curved, 0.0, -apothem), 0.0);   // arcs bulge outwards
    EXPECT_GT(aperture_sdf(curved, 0.0, -0.999), 0.0);     // but stay inside the circle
    EXPECT_NEAR(aperture_sdf(curved, std::sin(std::numbers::pi / 6), -apothem), 0.0, 1e-9);  // through the corner
}

TEST(FlareView, SensorImageIsTurnedUpright) {
    FlareView view;
    view.width = 360;
    view.height = 240;
    // A point low and left on the sensor is high and right in the photograph.
    const auto [px, py] = sensor_to_pixel(view, -9.0, -6.0);
    EXPECT_NEAR(px, 270.0, 1e-9);
    EXPECT_NEAR(py, 60.0, 1e-9);
    const auto centre = sensor_to_pixel(view, 0.0, 0.0);
    EXPECT_NEAR(centre[0], 180.0, 1e-9);
    EXPECT_NEAR(centre[1], 120.0, 1e-9);
}

TEST(FlareView, UnknownGhostIsNamed) {
    const optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    FlareView view;
    view.only_ghosts = {{system.stop, 0}};
    EXPECT_THROW(selected_ghosts(system, view), std::invalid_argument);
}

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

}  // namespace
}  // namespace lensfx::gpu
