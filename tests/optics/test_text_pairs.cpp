// The shared "A<sep>B" reader of sizes, sensors and angles (optics/text_pairs.h), used by lensfx and the benches.
#include <gtest/gtest.h>

#include <array>

#include <optics/text_pairs.h>

namespace lensfx {
namespace {

TEST(TextPairs, ReadsBothNumbersWholeOrNothing) {
    EXPECT_EQ(parse_pair_of<int>("1920x1080", 'x'), (std::array<int, 2>{1920, 1080}));
    EXPECT_EQ(parse_pair_of<double>("36x24.5", 'x'), (std::array<double, 2>{36.0, 24.5}));
    EXPECT_EQ(parse_pair_of<double>("8,-5", ','), (std::array<double, 2>{8.0, -5.0}));
    for (const char* bad : {"64x", "x48", "64x48x", "64", "64x48.5", "64xq", "", "8,5"})
        EXPECT_FALSE(parse_pair_of<int>(bad, 'x').has_value()) << bad;
}

}  // namespace
}  // namespace lensfx
