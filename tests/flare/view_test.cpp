// Fast checks of the flare model's definitions: the iris SDF, the upright image orientation, ghost selection.
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <gtest/gtest.h>

#include <flare/flare.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace lensfx::flare {
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

TEST(SensorView, PixelToAngleFollowsTheFocalLengthAndSensor) {
    SensorView g;
    g.focal_mm = 50.0;
    g.sensor_width_mm = 36.0;
    g.sensor_height_mm = 24.0;
    g.width = 1500;
    g.height = 1000;
    const auto centre = g.angles_at(750.0, 500.0);
    EXPECT_NEAR(centre[0], 0.0, 1e-12);
    EXPECT_NEAR(centre[1], 0.0, 1e-12);
    const auto corner = g.angles_at(1500.0, 0.0);  // top right: right of and above the axis
    EXPECT_NEAR(corner[0], std::atan(18.0 / 50.0) * 180.0 / std::numbers::pi, 1e-9);
    EXPECT_NEAR(corner[1], std::atan(12.0 / 50.0) * 180.0 / std::numbers::pi, 1e-9);
    EXPECT_NEAR(g.pixel_area_mm2(), 0.024 * 0.024, 1e-15);
}

}  // namespace
}  // namespace lensfx::flare
