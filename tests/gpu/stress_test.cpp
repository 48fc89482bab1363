// Every preset, wide open and at f/32, the light on the axis and at 1, 2 and 4 times the field limit (the
// 36 x 24 mm frame's half diagonal; capped at 85 degrees): the ghost image (one wavelength, grid 32) is
// finite and non-negative everywhere, and a light beyond the field puts no more ghost power on the image
// than the same light on the axis. Not asserted: that power falls with the angle; it need not (a lens's
// ghosts can gather more light further out: mld-double-gauss wide open, 3 times as much at 4 times the
// limit as at 2 times).
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>

#include <fmt/core.h>
#include <gtest/gtest.h>

#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/presets.h>
#include <optics/system.h>

namespace lensfx::gpu {
namespace {

// (preset, f-number; 0 = wide open): one test each, so that no test of a big zoom runs for minutes.
class GhostStress : public ::testing::TestWithParam<std::tuple<std::string, double>> {};

TEST_P(GhostStress, FiniteNonNegativeAndNoBrighterBeyondTheField) {
    const auto& [name, fstop] = GetParam();
    const optics::Lens lens = optics::load_lens(name);
    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    GpuFlareOptions options;
    options.grid = 32;
    std::optional<optics::System> realized;
    try {
        realized = optics::realize(lens, 0.0, fstop > 0 ? std::optional<double>(fstop) : std::nullopt);
    } catch (const std::invalid_argument& e) {
        GTEST_SKIP() << e.what();  // faster than the lens can open
    }
    const optics::System& system = *realized;
    const double efl = optics::paraxial(system).efl_mm;
    const double half_diagonal = std::atan(std::hypot(18.0, 12.0) / efl) * 180.0 / std::numbers::pi;
    double axial_power = 0.0;
    for (const double scale : {0.0, 1.0, 2.0, 4.0}) {
        FlareView view;
        view.width = 48;
        view.height = 32;
        view.wavelength_nm = 550.0;
        const double angle = std::min(scale * half_diagonal, 85.0);
        view.angle_x_deg = angle * 0.8;
        view.angle_y_deg = angle * 0.6;
        FlareImage image;
        try {
            image = renderer.render(system, view, options);
        } catch (const std::runtime_error& e) {
            // The renderer refuses aspheric prescriptions with a message naming the surface.
            ASSERT_NE(std::string(e.what()).find("aspheric"), std::string::npos) << e.what();
            GTEST_SKIP() << e.what();
        }
        for (float v : image.rgb) {
            ASSERT_TRUE(std::isfinite(v) && v >= 0.0f)
                << name << " f/" << fstop << " angle " << angle << ": " << v;
        }
        const double power = image.total_power(view)[0];
        RecordProperty(fmt::format("power_x{}", scale), fmt::format("{:.4e}", power));
        if (scale == 0.0) axial_power = power;
        if (scale > 1.0) {
            EXPECT_LE(power, axial_power) << name << " f/" << fstop << ": ghost power with the light at "
                                          << angle << " degrees above the axial light's";
        }
    }
}

INSTANTIATE_TEST_SUITE_P(AllPresets, GhostStress,
                         ::testing::Combine(::testing::ValuesIn(optics::preset_names()), ::testing::Values(0.0, 32.0)),
                         [](const ::testing::TestParamInfo<std::tuple<std::string, double>>& param) {
                             std::string name = std::get<0>(param.param);
                             for (char& ch : name) {
                                 if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                             }
                             const double fstop = std::get<1>(param.param);
                             return name + (fstop > 0 ? fmt::format("_f{}", fstop) : std::string("_open"));
                         });

}  // namespace
}  // namespace lensfx::gpu
