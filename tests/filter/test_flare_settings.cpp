// The flare settings both flare commands share (filter/flare_settings.h): one lens assembly with one --blades
// rule, and --sensor.
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include <filter/flare_settings.h>
#include <optics/paraxial.h>

namespace lensfx::filter {
namespace {

TEST(RealizeLens, AppliesTheChoiceAndOneBladesRule) {
    LensChoice choice;
    choice.lens = "cooke-triplet";
    const RealizedLens plain = realize_lens(choice);
    choice.blades = 6;
    choice.fstop = 8.0;
    choice.coating = "uncoated";
    const RealizedLens chosen = realize_lens(choice);
    EXPECT_EQ(chosen.system.aperture.blades, 6);
    EXPECT_NEAR(optics::paraxial(chosen.system).f_number, 8.0, 1e-3);
    EXPECT_NE(chosen.text, plain.text);
    EXPECT_NE(chosen.text.find("blades 6"), std::string::npos);
    for (int bad : {-1, 1, 2, 65}) {
        choice.blades = bad;
        try {
            realize_lens(choice);
            ADD_FAILURE() << "--blades " << bad << " accepted";
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("--blades"), std::string::npos) << e.what();
        }
    }
    choice.blades = 0;
    EXPECT_EQ(realize_lens(choice).system.aperture.blades, 0);
}

TEST(ParseSensor, WidthAloneOrWidthByHeight) {
    EXPECT_EQ(parse_sensor("36"), (std::array<double, 2>{36.0, 0.0}));
    EXPECT_EQ(parse_sensor("23.5x15.6"), (std::array<double, 2>{23.5, 15.6}));
    for (const char* bad : {"", "x24", "36x", "36x24x2", "-36", "0", "36x-1", "36x0", "inf", "36mm"})
        EXPECT_THROW(parse_sensor(bad), std::invalid_argument) << bad;
}

}  // namespace
}  // namespace lensfx::filter
