// The coarse pass's estimate of one ghost from its traced grid (gpu/coarse_estimate.h), on grids made by hand: a
// ghost within the sensor keeps the peak of its whole cells; a veil wider than the frame (one ray within the circle
// round the sensor, the rest landing far around it) gets the peak of its cells that reach the sensor and a box
// within the square round that circle, where it had none (issue 17: nikon-80-200's veils were drawn whole); and a
// sliver the iris cuts in every cell stays unknown.
#include <array>
#include <cmath>
#include <functional>
#include <vector>

#include <gtest/gtest.h>

#include <gpu/coarse_estimate.h>

namespace lensfx::gpu {
namespace {

constexpr int kRes = 4;                        // 5 x 5 vertices over the square
constexpr double kSensorRadius = 21.6;         // mm: a 36 x 24 sensor's circle
const PupilRect kSquare{-1.0, -1.0, 1.0, 1.0};  // entrance plane, mm: cells 0.5 mm a side

// A grid of traced vertices (ghost_trace_comp's 12 floats: sensor x, y, r_rel, transmission, three stop uvs, valid,
// w), each from `at(ix, iy)`: its sensor position and the uv of its one stop crossing.
struct Landing {
    double x, y;
    double u = 0.0, v = 0.0;
};
std::vector<float> grid_of(const std::function<Landing(int, int)>& at) {
    std::vector<float> out;
    for (int iy = 0; iy <= kRes; ++iy)
        for (int ix = 0; ix <= kRes; ++ix) {
            const Landing l = at(ix, iy);
            const std::array<float, 12> v{static_cast<float>(l.x), static_cast<float>(l.y), 0.5f, 0.01f, static_cast<float>(l.u),
                                          static_cast<float>(l.v), 0.0f, 0.0f, 0.0f, 0.0f, 1.0f, 0.0f};
            out.insert(out.end(), v.begin(), v.end());
        }
    return out;
}

GhostEstimate estimate(const std::vector<float>& grid) {
    optics::Aperture round;
    round.blades = 0;
    return coarse_estimate(grid.data(), kRes, kSquare, 1, round, 1.0, kSensorRadius);
}

// Every cell's power: transmission x cell area x cos(angle).
constexpr double kCellPower = 0.01 * 0.5 * 0.5;

TEST(CoarseEstimate, AGhostWithinTheSensorKeepsItsWholeCellsPeak) {
    const GhostEstimate e = estimate(grid_of([](int ix, int iy) { return Landing{2.0 * (ix - 2), 2.0 * (iy - 2)}; }));
    EXPECT_NEAR(e.peak, kCellPower / 4.0, 1e-6 * kCellPower);  // 2 x 2 mm cells (the transmission a float)
    EXPECT_DOUBLE_EQ(e.sensor.x0, -4.0);
    EXPECT_DOUBLE_EQ(e.sensor.x1, 4.0);
    EXPECT_DOUBLE_EQ(e.extent_mm, 8.0);
}

TEST(CoarseEstimate, AVeilWiderThanTheFrameGetsThePeakOfItsCellsOverTheSensor) {
    // 100 mm between neighbours on the sensor: only the centre ray lands within the circle.
    const GhostEstimate e = estimate(grid_of([](int ix, int iy) { return Landing{100.0 * (ix - 2), 100.0 * (iy - 2)}; }));
    ASSERT_FALSE(e.rect.empty());                       // its one passing ray
    EXPECT_NEAR(e.peak, kCellPower / 1e4, 1e-10 * kCellPower);  // the four cells round the centre, 100 x 100 mm each
    EXPECT_DOUBLE_EQ(e.sensor.x0, -kSensorRadius);      // their bounds, within the square round the circle
    EXPECT_DOUBLE_EQ(e.sensor.y0, -kSensorRadius);
    EXPECT_DOUBLE_EQ(e.sensor.x1, kSensorRadius);
    EXPECT_DOUBLE_EQ(e.sensor.y1, kSensorRadius);
    EXPECT_DOUBLE_EQ(e.extent_mm, 2.0 * kSensorRadius);
}

// A small bright cell of the veil's rays (1 mm^2 on the sensor: its irradiance 10,000 times the others') counts only
// where the renderer draws it and where it lands on the sensor: outside the ghost's rectangle (the one passing ray's
// cells, [1, 2] x [1, 2]) it is not drawn, and beside the square round the sensor's circle it adds nothing there.
constexpr double kBrightCell = kCellPower / 1.0;
Landing bright_corner(int ix, int iy, double x, double y) { return Landing{x + (ix % 2 == 0 ? -0.5 : 0.5), y + (iy % 2 == 0 ? -0.5 : 0.5)}; }

TEST(CoarseEstimate, AVeilsCellsCountOnlyWithinItsRectangle) {
    // Cell (0, 0), outside the rectangle, lands 28 mm from the centre (beyond the circle, within the square).
    const GhostEstimate e = estimate(grid_of([](int ix, int iy) {
        if (ix <= 1 && iy <= 1) return bright_corner(ix, iy, -20.0, -20.0);
        return Landing{100.0 * (ix - 2), 100.0 * (iy - 2)};
    }));
    ASSERT_GT(e.peak, 0.0);
    EXPECT_LT(e.peak, 0.01 * kBrightCell);
}

TEST(CoarseEstimate, AVeilsCellsBesideTheSensorAddNothing) {
    // Two passing rays, at (1, 1) and (3, 3), make the rectangle every cell; cell (2, 0), none of whose corners
    // pass, lands 100 mm right of the centre.
    const GhostEstimate e = estimate(grid_of([](int ix, int iy) {
        if ((ix == 1 && iy == 1) || (ix == 3 && iy == 3)) return Landing{0.5 * (ix - 2), 0.5 * (iy - 2)};
        if (ix >= 2 && iy <= 1) return bright_corner(ix, iy, 100.0, 0.0);
        return Landing{100.0 * (ix - 2) + 50.0, 100.0 * (iy - 2) + 50.0};  // (2, 2) too beyond the circle
    }));
    ASSERT_GT(e.peak, 0.0);
    EXPECT_LT(e.peak, 0.01 * kBrightCell);
}

TEST(CoarseEstimate, AVeilCutByTheIrisEverywhereStaysUnknown) {
    // The rays beyond the circle are outside the iris (stop uv 3 radii out): no cell gets through whole.
    const GhostEstimate e = estimate(grid_of([](int ix, int iy) {
        const bool centre = ix == 2 && iy == 2;
        return Landing{100.0 * (ix - 2), 100.0 * (iy - 2), centre ? 0.0 : 3.0, 0.0};
    }));
    ASSERT_FALSE(e.rect.empty());
    EXPECT_EQ(e.peak, 0.0);
    EXPECT_GT(e.sensor.x0, -1e-9);  // the one passing ray's point, no more
    EXPECT_LT(e.sensor.x1, 1e-9);
}

TEST(CoarseEstimate, AFinerPassTeachesAnUnknownGhostItsPeakAndBox) {
    GhostEstimate coarse;
    coarse.sensor = {1.0, 1.0, 1.0, 1.0};
    GhostEstimate fine;
    fine.peak = 2e-6;
    fine.sensor = {-3.0, 0.0, 2.0, 4.0};
    learn_peak(coarse, fine);
    EXPECT_EQ(coarse.peak, 2e-6);
    EXPECT_DOUBLE_EQ(coarse.sensor.x0, -3.0);
    EXPECT_DOUBLE_EQ(coarse.sensor.y1, 4.0);
}

}  // namespace
}  // namespace lensfx::gpu
