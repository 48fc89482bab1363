// Every preset, lights on the axis, at the field corner and at three times it, wide open and f/32: the
// ghost image (one wavelength, grid 32) is finite and non-negative everywhere.
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include <gpu/context.h>
#include <gpu/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/presets.h>
#include <optics/system.h>

namespace lensfx::gpu {
namespace {

class GhostStress : public ::testing::TestWithParam<std::string> {};

TEST_P(GhostStress, FiniteAndNonNegative) {
    const optics::Lens lens = optics::load_lens(GetParam());
    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    GpuFlareOptions options;
    options.grid = 32;
    for (const double fstop : {0.0, 32.0}) {
        std::optional<optics::System> realized;
        try {
            realized = optics::realize(lens, 0.0, fstop > 0 ? std::optional<double>(fstop) : std::nullopt);
        } catch (const std::invalid_argument&) {
            continue;  // faster than the lens can open
        }
        const optics::System& system = *realized;
        const double efl = optics::paraxial(system).efl_mm;
        const double half_diagonal = std::atan(std::hypot(18.0, 12.0) / efl) * 180.0 / std::numbers::pi;
        for (const double scale : {0.0, 1.0, 3.0}) {
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
                    << GetParam() << " f/" << fstop << " angle " << angle << ": " << v;
            }
        }
    }
}

INSTANTIATE_TEST_SUITE_P(AllPresets, GhostStress, ::testing::ValuesIn(optics::preset_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) {
                             std::string name = param.param;
                             for (char& ch : name) {
                                 if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                             }
                             return name;
                         });

}  // namespace
}  // namespace lensfx::gpu
