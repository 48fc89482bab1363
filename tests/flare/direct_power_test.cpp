// The direct power: the pupil area times the transmission, and its table against a dense trace of the
// direct path over a full-frame field.
#include <algorithm>
#include <numbers>
#include <cmath>
#include <optional>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <flare/direct_power.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/system.h>

using namespace lensfx;

TEST(DirectPower, IsThePupilAreaTimesTransmission) {
    optics::System system = optics::realize(optics::load_lens("mld-double-gauss"), 0.0, 4.0);
    system.aperture.blades = 0;  // a round iris, so the pupil is the paraxial circle
    const double epd = optics::paraxial(system).entrance_pupil_diameter_mm;
    const double area = std::numbers::pi * epd * epd / 4.0;
    const auto on_axis = flare::direct_power(system, 0.0, 0.0, 128);
    for (double p : on_axis) {
        EXPECT_GT(p, 0.85 * area);  // coated interfaces lose a few percent
        EXPECT_LT(p, 1.01 * area);
    }
    // Off axis the pupil is seen obliquely and vignetted: less power, never more.
    const auto off_axis = flare::direct_power(system, 15.0, 5.0, 128);
    for (std::size_t c = 0; c < 3; ++c) EXPECT_LT(off_axis[c], on_axis[c]);
    // Far outside the field nothing reaches the sensor.
    for (double p : flare::direct_power(system, 80.0, 0.0, 64)) EXPECT_EQ(p, 0.0);
    // Six straight blades with their corners on the stop circle pass a hexagon: 3 sqrt(3) / (2 pi) of it.
    system.aperture.blades = 6;
    const auto hexagon = flare::direct_power(system, 0.0, 0.0, 128);
    for (std::size_t c = 0; c < 3; ++c)
        EXPECT_NEAR(hexagon[c] / on_axis[c], 3.0 * std::sqrt(3.0) / (2.0 * std::numbers::pi), 0.01);
}

// Stopped far down, the pupil is a few samples of the entrance square across (at f/500 none of 96^2 passed, and
// every light was said to lie outside the field): it is sampled again round the beam, on and off axis.
TEST(DirectPower, ATinyPupilIsFound) {
    for (const double f_number : {64.0, 500.0}) {
        optics::System system = optics::realize(optics::load_lens("mld-double-gauss"), 0.0, f_number);
        system.aperture.blades = 0;
        const double epd = optics::paraxial(system).entrance_pupil_diameter_mm;
        const double area = std::numbers::pi * epd * epd / 4.0;
        for (double p : flare::direct_power(system, 0.0, 0.0, 96)) {
            EXPECT_GT(p, 0.85 * area) << "f/" << f_number;
            EXPECT_LT(p, 1.03 * area) << "f/" << f_number;
        }
        for (double p : flare::direct_power(system, 10.0, 4.0, 96)) EXPECT_GT(p, 0.5 * area) << "f/" << f_number << " off axis";
    }
}

TEST(DirectPower, TableIsWithinOnePercentOfADenseTrace) {
    // Across a full-frame 36 x 24 mm field (a 50 mm lens: corners at 23 degrees), at azimuths off the
    // table's axis, for a round and a bladed iris.
    for (const char* name : {"mld-double-gauss", "brendel-tessar"}) {
        for (int blades : {0, 6}) {
            optics::System system = optics::realize(optics::load_lens(name), 0.0, std::nullopt);
            system.aperture.blades = blades;
            const double focal = optics::paraxial(system).efl_mm;
            const double corner = std::atan(std::hypot(18.0, 12.0) / focal) * 180.0 / 3.14159265358979323846;
            const flare::DirectPowerTable table(system, corner * 1.02);
            const double on_axis = flare::direct_power(system, 0.0, 0.0, 256)[1];
            for (const auto& [fx, fy] : std::vector<std::pair<double, double>>{{0.1, 0.05}, {0.45, 0.3}, {-0.8, 0.6}, {0.95, -0.97}, {0.3, -0.9}}) {
                const double ax = std::atan(fx * 18.0 / focal) * 180.0 / 3.14159265358979323846;
                const double ay = std::atan(fy * 12.0 / focal) * 180.0 / 3.14159265358979323846;
                const auto dense = flare::direct_power(system, ax, ay, 256);
                const auto fast = table.at(ax, ay);
                for (std::size_t c = 0; c < 3; ++c)
                    EXPECT_NEAR(fast[c], dense[c], 0.01 * std::max(dense[c], 0.05 * on_axis))
                        << name << " blades " << blades << " at (" << ax << ", " << ay << ") channel " << c;
            }
        }
    }
}
