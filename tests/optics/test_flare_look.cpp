// Flare looks: the TOML format with its errors, and the per-ghost styles it yields (seeded jitter of the
// right size, explicit styles on top, unknown ghosts named).
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include <optics/flare_look.h>
#include <optics/ghosts.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace lensfx::optics {
namespace {

std::string error_of(const std::string& text) {
    try {
        parse_flare_look(text, "look.toml");
    } catch (const LensFileError& e) {
        return e.what();
    }
    return "";
}

TEST(FlareLook, ParsesStylesAndSymmetry) {
    const FlareLook look = parse_flare_look(R"(
[symmetry]
jitter_mm = 0.1
seed = 9
[[ghost]]
surfaces = [7, 1]
gain = 2
colour = [1.0, 0.5, 0.25]
offset_mm = [0.3, -0.2]
)", "look.toml");
    EXPECT_DOUBLE_EQ(look.symmetry_jitter_mm, 0.1);
    EXPECT_EQ(look.seed, 9u);
    ASSERT_EQ(look.ghosts.size(), 1u);
    EXPECT_EQ(look.ghosts[0].first, 6);
    EXPECT_EQ(look.ghosts[0].second, 0);
    EXPECT_DOUBLE_EQ(look.ghosts[0].gain[2], 0.5);
    EXPECT_DOUBLE_EQ(look.ghosts[0].offset_mm[1], -0.2);
    EXPECT_NO_THROW(read_flare_look(std::string(LENSFX_SOURCE_DIR) + "/presets/looks/decentred-warm.toml"));
}

TEST(FlareLook, ErrorsNameTheFileLineAndField) {
    EXPECT_NE(error_of("[[ghost]]\nsurfaces = [3]\n").find("look.toml:2: ghost 1: surfaces"), std::string::npos);
    EXPECT_NE(error_of("[[ghost]]\nsurfaces = [1, 2]\ncolour = [1, 2]\n").find("colour"), std::string::npos);
    EXPECT_NE(error_of("[[ghost]]\nsurfaces = [1, 2]\ngian = 2\n").find("gian: unknown field"), std::string::npos);
    EXPECT_NE(error_of("[symmetry]\njitter_mm = -1\n").find("symmetry.jitter_mm"), std::string::npos);
    EXPECT_NE(error_of("[[ghost]\n").find("look.toml:1"), std::string::npos);
    EXPECT_THROW(read_flare_look("/no/such/look.toml"), LensFileError);
}

// Issue 14: gains beyond float range or not finite, and a second entry for one ghost (whose gains would
// multiply the first's unseen), are refused by name.
TEST(FlareLook, HostileGainsAndDuplicateGhostsAreRefused) {
    EXPECT_NE(error_of("[[ghost]]\nsurfaces = [2, 1]\ngain = 1e39\n").find("ghost 1: gain"), std::string::npos);
    EXPECT_NE(error_of("[[ghost]]\nsurfaces = [2, 1]\ngain = nan\n").find("gain"), std::string::npos);
    EXPECT_NE(error_of("[[ghost]]\nsurfaces = [2, 1]\ncolour = [1, inf, 1]\n").find("colour"), std::string::npos);
    EXPECT_NE(error_of("[[ghost]]\nsurfaces = [2, 1]\noffset_mm = [nan, 0]\n").find("offset_mm"), std::string::npos);
    EXPECT_NE(error_of("[[ghost]]\nsurfaces = [1e30, 1]\n").find("surfaces"), std::string::npos);
    EXPECT_NE(error_of("[[ghost]]\nsurfaces = [3, 1]\n[[ghost]]\nsurfaces = [1, 3]\n").find("ghost 2: surfaces: ghost 1,3 is already styled by ghost 1"),
              std::string::npos)
        << error_of("[[ghost]]\nsurfaces = [3, 1]\n[[ghost]]\nsurfaces = [1, 3]\n");
}

TEST(FlareLook, JitterIsSeededPerGhostWithTheStatedSize) {
    const System system = realize(load_lens("nikon-80-200"));
    const std::vector<Ghost> ghosts = enumerate_ghosts(system);
    FlareLook look;
    look.symmetry_jitter_mm = 0.2;
    look.seed = 3;
    const std::vector<GhostStyle> a = ghost_styles(look, ghosts);
    ASSERT_EQ(a.size(), ghosts.size());
    double sum2 = 0.0;
    for (const GhostStyle& s : a) sum2 += s.offset_mm[0] * s.offset_mm[0] + s.offset_mm[1] * s.offset_mm[1];
    EXPECT_NEAR(std::sqrt(sum2 / static_cast<double>(a.size())), 0.2, 0.03) << ghosts.size() << " ghosts";
    // The same ghost gets the same offset when rendered alone.
    const std::vector<GhostStyle> one = ghost_styles(look, {ghosts[17]});
    ASSERT_EQ(one.size(), 1u);
    EXPECT_EQ(one[0].offset_mm, a[17].offset_mm);
    look.seed = 4;
    EXPECT_NE(ghost_styles(look, ghosts)[17].offset_mm, a[17].offset_mm);

    look.symmetry_jitter_mm = 0.0;
    look.ghosts = {{ghosts[5].second, ghosts[5].first, {2.0, 2.0, 0.0}, {0.1, 0.0}}};
    const std::vector<GhostStyle> styled = ghost_styles(look, ghosts);
    ASSERT_EQ(styled.size(), 1u);
    EXPECT_EQ(styled[0].first, ghosts[5].first);
    EXPECT_DOUBLE_EQ(styled[0].gain[0], 2.0);
    look.ghosts = {{system.stop, 0, {1.0, 1.0, 1.0}, {}}};
    EXPECT_THROW(ghost_styles(look, ghosts), std::invalid_argument);
}

}  // namespace
}  // namespace lensfx::optics
