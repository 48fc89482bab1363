// The standard anti-reflection designs against textbook reflectance values, the coating choices of the
// command line and their seeded thickness spread, and the designs in lens files.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include <optics/coating.h>
#include <optics/glass.h>
#include <optics/lens_file.h>
#include <optics/presets.h>
#include <optics/system.h>

using namespace lensfx::optics;

namespace {

Glass bk7() { return *catalog_glass("N-BK7"); }

Coating design(Coating::Design d, double nm = 550.0) {
    Coating c;
    c.kind = Coating::Kind::Design;
    c.design = d;
    c.design_wavelength_nm = nm;
    return c;
}

// Reflectance at normal incidence of air -> coating -> N-BK7 at a wavelength.
double reflectance(const Coating& c, double nm) {
    const ResolvedCoating r = resolve_coating(c, Glass::air(), bk7(), nm);
    return coated_reflectance(r, 1.0, bk7().index(nm), 1.0, nm, true).R;
}

double worst_over(const Coating& c, double from_nm, double to_nm) {
    double worst = 0.0;
    for (double nm = from_nm; nm <= to_nm; nm += 5.0) worst = std::max(worst, reflectance(c, nm));
    return worst;
}

}  // namespace

TEST(CoatingDesigns, MgF2QuarterWaveOnBk7) {
    Coating c;
    c.kind = Coating::Kind::QuarterWave;
    EXPECT_NEAR(reflectance(c, 550.0), 0.0126, 0.0003);  // (1.38^2 - 1.519) / (1.38^2 + 1.519), squared
    EXPECT_GT(reflectance(c, 420.0), reflectance(c, 550.0));
    EXPECT_GT(reflectance(c, 700.0), reflectance(c, 550.0));
}

TEST(CoatingDesigns, QuarterHalfQuarterIsBroadband) {
    const Coating c = design(Coating::Design::QuarterHalfQuarter);
    EXPECT_LT(worst_over(c, 450.0, 650.0), 0.005);
    const ResolvedCoating r = resolve_coating(c, Glass::air(), bk7(), 550.0);
    ASSERT_EQ(r.layers.size(), 3u);
    EXPECT_NEAR(r.layers[1].index * r.layers[1].thickness_nm, 275.0, 1e-9);  // the half wave
}

TEST(CoatingDesigns, VCoatIsZeroAtItsWavelengthOnly) {
    for (double nm : {480.0, 550.0, 620.0}) {
        const Coating c = design(Coating::Design::VCoat, nm);
        EXPECT_LT(reflectance(c, nm), 1e-5) << nm;
        EXPECT_GT(reflectance(c, nm + 120.0), 0.005) << nm;  // a V, coloured away from its minimum
    }
}

TEST(CoatingDesigns, FourLayerBroadband) {
    const Coating c = design(Coating::Design::Broadband4);
    EXPECT_LT(worst_over(c, 420.0, 680.0), 0.004);
    Coating single;
    single.kind = Coating::Kind::QuarterWave;
    EXPECT_LT(worst_over(c, 450.0, 650.0), 0.25 * worst_over(single, 450.0, 650.0));
    // On denser glass the thin pair thins, and it stays an anti-reflection coat.
    const Glass dense = glass_from_abbe(1.80, 40.0);
    const ResolvedCoating r = resolve_coating(c, Glass::air(), dense, 550.0);
    EXPECT_LT(coated_reflectance(r, 1.0, dense.index(550.0), 1.0, 550.0, true).R, 0.01);
}

TEST(CoatingDesigns, LayersFollowTheLightFromEitherSide) {
    // Glass before air: the layers are listed from the object side, so the glass-side layer comes first.
    const Coating c = design(Coating::Design::QuarterHalfQuarter);
    const ResolvedCoating front = resolve_coating(c, Glass::air(), bk7(), 550.0);
    const ResolvedCoating back = resolve_coating(c, bk7(), Glass::air(), 550.0);
    ASSERT_EQ(front.layers.size(), back.layers.size());
    EXPECT_DOUBLE_EQ(front.layers.front().index, back.layers.back().index);
    const double n = bk7().index(550.0);
    EXPECT_NEAR(coated_reflectance(back, n, 1.0, 1.0, 550.0, true).R, coated_reflectance(front, 1.0, n, 1.0, 550.0, true).R, 1e-12);
}

TEST(CoatingChoices, ParseAndApply) {
    EXPECT_EQ(parse_coating_choice("uncoated"), CoatingChoice::Uncoated);
    EXPECT_EQ(parse_coating_choice("none"), CoatingChoice::Uncoated);
    EXPECT_EQ(parse_coating_choice("multi"), CoatingChoice::Multi);
    EXPECT_THROW(parse_coating_choice("triple"), std::invalid_argument);
    const System base = realize(load_lens("cooke-triplet"));
    for (const auto& [choice, kind] : {std::pair{CoatingChoice::Uncoated, Coating::Kind::None},
                                       std::pair{CoatingChoice::Single, Coating::Kind::QuarterWave},
                                       std::pair{CoatingChoice::Multi, Coating::Kind::Design}}) {
        System s = base;
        choose_coatings(s, choice, 0.0);
        for (const auto& i : s.interfaces)
            if (!i.is_stop && i.before.is_air() != i.after.is_air()) {
                EXPECT_EQ(i.coating.kind, kind);
            }
    }
}

TEST(CoatingChoices, SpreadIsSeededPerSurface) {
    const System base = realize(load_lens("canon-70-200"));
    System a = base, b = base, c = base;
    choose_coatings(a, CoatingChoice::Lens, 0.03);
    choose_coatings(b, CoatingChoice::Lens, 0.03);
    choose_coatings(c, CoatingChoice::Lens, 0.03, 2);
    double sum2 = 0.0;
    int n = 0;
    bool differ = false;
    for (std::size_t i = 0; i < a.interfaces.size(); ++i) {
        EXPECT_EQ(a.interfaces[i].coating.layer_errors, b.interfaces[i].coating.layer_errors);
        differ = differ || a.interfaces[i].coating.layer_errors != c.interfaces[i].coating.layer_errors;
        for (double e : a.interfaces[i].coating.layer_errors) {
            sum2 += e * e;
            ++n;
        }
    }
    EXPECT_TRUE(differ);
    ASSERT_GT(n, 40);
    EXPECT_NEAR(std::sqrt(sum2 / n), 0.03, 0.01);
    // The errors change what the surfaces reflect.
    {
        const auto& s = a.interfaces[0];
        const double nm = 550.0;
        const double r0 = coated_reflectance(resolve_coating(base.interfaces[0].coating, s.before, s.after, nm), 1.0,
                                             s.after.index(nm), 1.0, nm, true).R;
        const double r1 = coated_reflectance(resolve_coating(s.coating, s.before, s.after, nm), 1.0, s.after.index(nm), 1.0, nm, true).R;
        EXPECT_NE(r0, r1);
    }
}

TEST(CoatingDesigns, LensFilesNameThem) {
    const std::string text = R"(name = "t"
coating = "broadband-4"
surfaces = [
  { r = 50, t = 5, sd = 10, glass = "N-BK7" },
  { r = -50, t = 2, sd = 10, coating = { design = "v-coat", wavelength = 510 } },
  { stop = true, t = 40, sd = 8 },
]
)";
    const Lens lens = parse_lens_toml(text, "t.toml");
    EXPECT_EQ(lens.surfaces[0].coating.kind, Coating::Kind::Design);
    EXPECT_EQ(lens.surfaces[0].coating.design, Coating::Design::Broadband4);
    EXPECT_EQ(lens.surfaces[1].coating.design, Coating::Design::VCoat);
    EXPECT_DOUBLE_EQ(lens.surfaces[1].coating.design_wavelength_nm, 510.0);
    const Lens again = parse_lens_toml(write_lens_toml(lens), "again.toml");
    EXPECT_EQ(again.surfaces[1].coating.design, Coating::Design::VCoat);
    EXPECT_DOUBLE_EQ(again.surfaces[1].coating.design_wavelength_nm, 510.0);
    EXPECT_EQ(again.surfaces[0].coating.design, Coating::Design::Broadband4);
    EXPECT_THROW(parse_lens_toml(R"(name = "t"
coating = { design = "triple" }
surfaces = [ { r = 50, t = 5, sd = 10, glass = "N-BK7" }, { stop = true, t = 40, sd = 8 } ]
)", "bad.toml"), LensFileError);
}
