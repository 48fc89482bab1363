// Lens files, importers, presets, realize() and paraxial analysis (the `lensfx lens` commands: tests/filter).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <numbers>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <optics/importers.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/presets.h>
#include <optics/system.h>

namespace fs = std::filesystem;
using namespace lensfx::optics;

namespace {

const fs::path kReference = fs::path(LENSFX_SHARED_DIR) / "reference" / "lenses";

// Message of the LensFileError thrown by parsing `text`, or "" when it parses.
std::string parse_error(const std::string& text) {
    try {
        parse_lens_toml(text, "bad.toml");
    } catch (const LensFileError& e) {
        return e.what();
    }
    return {};
}

const char* kSinglet = R"(
name = "test singlet"
surfaces = [
  { stop = true, t = 5, sd = 5 },
  { r = 50, t = 6, sd = 10, nd = 1.5 },
  { r = -50, t = 40, sd = 10 },
]
)";

}  // namespace

// ---------------------------------------------------------------- paraxial against published numbers

TEST(Paraxial, CodeVDoubleGaussOfModernLensDesign) {
    const System sys = with_entrance_pupil_diameter(realize(load_preset("mld-double-gauss")), 50.0, kLineD_nm);
    const Paraxial p = paraxial(sys, kLineD_nm);
    // CODE V's values are given to 4 decimals.
    EXPECT_NEAR(p.efl_mm, 100.0038, 2e-4);
    EXPECT_NEAR(p.bfl_mm, 61.4875, 2e-4);
    EXPECT_NEAR(p.ffl_mm, -29.3208, 2e-4);
    EXPECT_NEAR(p.f_number, 2.0001, 1e-4);
    EXPECT_NEAR(p.entrance_pupil_diameter_mm, 50.0, 1e-12);
}

TEST(Paraxial, CookeTripletAt550nm) {
    const System sys = with_entrance_pupil_diameter(realize(load_preset("cooke-triplet")), 10.0, 550.0);
    const Paraxial p = paraxial(sys, 550.0);
    EXPECT_NEAR(p.efl_mm, 49.99978, 2e-5);
    EXPECT_NEAR(p.f_number, 4.99998, 2e-5);
}

TEST(Paraxial, ThickSingletMatchesTheLensmakerFormula) {
    const Lens lens = parse_lens_toml(kSinglet, "singlet");
    const Paraxial p = paraxial(realize(lens));
    const double n = 1.5, r1 = 50, r2 = -50, d = 6;
    const double power = (n - 1) * (1 / r1 - 1 / r2 + (n - 1) * d / (n * r1 * r2));
    const double f = 1 / power;
    EXPECT_NEAR(p.efl_mm, f, 1e-10);
    EXPECT_NEAR(p.bfl_mm, f * (1 - (n - 1) * d / (n * r1)), 1e-10);
    // The first vertex is the stop, 5 mm in front of the lens.
    EXPECT_NEAR(p.ffl_mm, 5.0 - f * (1 + (n - 1) * d / (n * r2)), 1e-10);
    // Stop in front of everything: the entrance pupil is the stop itself.
    EXPECT_NEAR(p.entrance_pupil_mm, 0.0, 1e-12);
    EXPECT_NEAR(p.entrance_pupil_diameter_mm, 10.0, 1e-12);
    EXPECT_NEAR(p.f_number, f / 10.0, 1e-12);
    // Exit pupil: the stop imaged by the lens (object 5 mm before the first vertex), by Newton's equation
    // measured from the principal planes.
    const double h2 = -f * (n - 1) * d / (n * r1);       // rear principal plane from the last vertex
    const double h1 = -f * (n - 1) * d / (n * r2);       // front principal plane from the first vertex
    const double s = -(5.0 + h1);                       // object distance from the front principal plane
    const double s_image = 1.0 / (1.0 / f + 1.0 / s);   // Gaussian: 1/s' - 1/s = 1/f
    EXPECT_NEAR(p.exit_pupil_mm, h2 + s_image, 1e-9);
    EXPECT_NEAR(p.exit_pupil_diameter_mm, 10.0 * std::abs(s_image / s), 1e-9);
}

TEST(Paraxial, DispersionMovesTheFocus) {
    const System sys = realize(load_preset("mld-double-gauss"));
    EXPECT_LT(paraxial(sys, 486.13).efl_mm, paraxial(sys, 656.27).efl_mm);  // more power in the blue
}

TEST(Paraxial, FieldOfViewOnFullFrame) {
    Paraxial p;
    p.efl_mm = 50.0;
    const FieldOfView fov = field_of_view(p, 36.0, 24.0);
    EXPECT_NEAR(fov.horizontal_deg, 2 * std::atan(18.0 / 50.0) * 180 / std::numbers::pi, 1e-12);
    EXPECT_NEAR(fov.diagonal_deg, 46.7930, 1e-4);
}

// ---------------------------------------------------------------- presets

TEST(Presets, EveryPresetHasASourceAndParses) {
    const auto names = preset_names();
    EXPECT_GE(names.size(), 13u);
    for (const auto& name : names) {
        SCOPED_TRACE(name);
        const Lens lens = load_preset(name);
        EXPECT_FALSE(lens.source.empty());
        EXPECT_FALSE(lens.stated_focal_mm.empty());
        EXPECT_GE(lens.stop_index(), 0);
    }
}

TEST(Presets, FigureFifteenAndRequiredLensesArePresent) {
    for (const char* name : {"canon-70-200", "nikon-80-200", "itoh-zoom", "angenieux-double-gauss", "kreitzer-tele",
                             "brendel-tessar", "pbrt-dgauss-50", "pbrt-telephoto-250", "pbrt-fisheye-10", "pbrt-wide-22",
                             "cooke-triplet", "mld-double-gauss", "petzval-kodak"})
        EXPECT_TRUE(preset_text(name).has_value()) << name;
}

TEST(Presets, ParaxialFocalLengthWithinOnePercentOfTheStatedValueAtEveryZoomPosition) {
    for (const auto& name : preset_names()) {
        const Lens lens = load_preset(name);
        const int columns = lens.zoom_positions();
        ASSERT_TRUE(lens.stated_focal_mm.size() == 1 || static_cast<int>(lens.stated_focal_mm.size()) == columns) << name;
        for (int k = 0; k < columns; ++k) {
            const double zoom = columns > 1 ? static_cast<double>(k) / (columns - 1) : 0.0;
            const double stated = lens.stated_focal_mm[lens.stated_focal_mm.size() == 1 ? 0 : static_cast<std::size_t>(k)];
            const double efl = paraxial(realize(lens, zoom)).efl_mm;
            EXPECT_NEAR(efl / stated, 1.0, 0.01) << name << " zoom column " << k << ": EFL " << efl << " vs " << stated;
        }
    }
}

TEST(Presets, StopOpensAboutAsWideAsTheStatedFNumberAndStopsDown) {
    for (const auto& name : preset_names()) {
        const Lens lens = load_preset(name);
        for (double zoom : {0.0, 1.0}) {
            const double open = paraxial(realize(lens, zoom)).f_number;
            if (lens.stated_f_number > 0.0) {
                EXPECT_LE(open, lens.stated_f_number * 1.05) << name;
            }
            EXPECT_NEAR(paraxial(realize(lens, zoom, 2.0 * open)).f_number, 2.0 * open, 1e-9 * open) << name;
        }
    }
}

// The f-number a lens is marked with (`lens list`) is accepted as wide open even where the prescription's is a
// little wider (pbrt-dgauss-50 is marked f/2 and opens to f/2.03); anything wider than rounding is refused.
TEST(Presets, TheMarkedFNumberOpensTheStopWide) {
    for (const auto& name : preset_names()) {
        const Lens lens = load_preset(name);
        if (!(lens.stated_f_number > 0.0)) continue;
        const System open = realize(lens, 0.0);
        const double widest = paraxial(open).f_number;
        if (lens.stated_f_number < widest / 1.03) continue;  // marked wider than the prescription opens
        const System marked = realize(lens, 0.0, lens.stated_f_number);
        EXPECT_NEAR(paraxial(marked).f_number, std::max(lens.stated_f_number, widest), 1e-6 * widest) << name;
    }
    const Lens dgauss = load_preset("pbrt-dgauss-50");
    EXPECT_NEAR(paraxial(realize(dgauss, 0.0, 2.0)).f_number, paraxial(realize(dgauss, 0.0)).f_number, 1e-9);
    EXPECT_THROW(realize(dgauss, 0.0, 1.9), std::invalid_argument);
}

TEST(Presets, WriterRoundTripsEveryPreset) {
    for (const auto& name : preset_names()) {
        SCOPED_TRACE(name);
        const Lens a = load_preset(name);
        const std::string text = write_lens_toml(a);
        const Lens b = parse_lens_toml(text, "round-trip");
        EXPECT_EQ(write_lens_toml(b), text);
        ASSERT_EQ(a.surfaces.size(), b.surfaces.size());
        for (std::size_t i = 0; i < a.surfaces.size(); ++i) {
            EXPECT_EQ(a.surfaces[i].radius_mm, b.surfaces[i].radius_mm);
            EXPECT_EQ(a.surfaces[i].thickness_mm, b.surfaces[i].thickness_mm);
            EXPECT_EQ(a.surfaces[i].semi_diameter_mm, b.surfaces[i].semi_diameter_mm);
            EXPECT_TRUE(same_medium(a.surfaces[i].medium, b.surfaces[i].medium));
            EXPECT_EQ(a.surfaces[i].coating.kind, b.surfaces[i].coating.kind);
        }
        EXPECT_EQ(paraxial(realize(a)).efl_mm, paraxial(realize(b)).efl_mm);
    }
}

TEST(Presets, PresetFilesInTheSourceTreeAreTheEmbeddedOnes) {
    for (const auto& name : preset_names()) {
        const fs::path p = fs::path(LENSFX_SOURCE_DIR) / "presets" / "lenses" / (name + ".toml");
        ASSERT_TRUE(fs::exists(p)) << p;
        EXPECT_EQ(paraxial(realize(load_lens(p.string()))).efl_mm, paraxial(realize(load_preset(name))).efl_mm) << name;
    }
}

// Neighbouring surfaces must not cross inside their clear apertures: a glass element keeps a positive edge,
// an air gap does not close (except the stop plane, which may sit inside a surface's sag).
TEST(Presets, NeighbouringSurfacesDoNotCrossWithinTheirApertures) {
    const auto sag = [](double r, double h) {
        return r == 0.0 ? 0.0 : r - std::copysign(std::sqrt(std::max(r * r - h * h, 0.0)), r);
    };
    for (const auto& name : preset_names()) {
        const Lens lens = load_preset(name);
        for (double zoom : {0.0, 0.5, 1.0}) {
            const System sys = realize(lens, zoom);
            for (std::size_t i = 0; i + 1 < sys.interfaces.size(); ++i) {
                const auto& a = sys.interfaces[i];
                const auto& b = sys.interfaces[i + 1];
                if (a.is_stop || b.is_stop) continue;
                const double h = std::min(a.semi_diameter_mm, b.semi_diameter_mm);
                const double edge = (b.z_mm + sag(b.radius_mm, h)) - (a.z_mm + sag(a.radius_mm, h));
                EXPECT_GE(edge, 0.0) << name << " zoom " << zoom << ": surfaces " << i + 1 << " and " << i + 2;
            }
        }
    }
}

TEST(Presets, DefaultCoatingGoesOnAirGlassInterfacesOnly) {
    const Lens lens = load_preset("canon-70-200");
    // Surface 13 is cemented to 14 (N-FK5 | N-SF57): no coating there; surface 1 is air | LAFN7 and
    // takes the file's default (a four-layer broadband at 550 nm), surface 7 its own.
    EXPECT_EQ(lens.surfaces[0].coating.kind, Coating::Kind::Design);
    EXPECT_EQ(lens.surfaces[0].coating.design, Coating::Design::Broadband4);
    EXPECT_DOUBLE_EQ(lens.surfaces[0].coating.design_wavelength_nm, 550.0);
    EXPECT_DOUBLE_EQ(lens.surfaces[6].coating.design_wavelength_nm, 600.0);
    // A lens of the 1950s keeps its single MgF2 layer.
    const Lens tessar = load_preset("brendel-tessar");
    EXPECT_EQ(tessar.surfaces[0].coating.kind, Coating::Kind::QuarterWave);
    EXPECT_DOUBLE_EQ(tessar.surfaces[0].coating.layer_index, 1.38);
    EXPECT_EQ(lens.surfaces[13].coating.kind, Coating::Kind::None);
    EXPECT_EQ(lens.surfaces[static_cast<std::size_t>(lens.stop_index())].coating.kind, Coating::Kind::None);
}

// ---------------------------------------------------------------- realize and zoom

TEST(Realize, LaysOutVerticesMediaStopAndSensor) {
    const Lens lens = parse_lens_toml(kSinglet, "singlet");
    const System sys = realize(lens);
    ASSERT_EQ(sys.interfaces.size(), 3u);
    EXPECT_EQ(sys.stop, 0);
    EXPECT_DOUBLE_EQ(sys.interfaces[1].z_mm, 5.0);
    EXPECT_DOUBLE_EQ(sys.interfaces[2].z_mm, 11.0);
    EXPECT_TRUE(sys.interfaces[1].before.is_air());
    EXPECT_DOUBLE_EQ(sys.interfaces[1].after.nd, 1.5);
    EXPECT_DOUBLE_EQ(sys.interfaces[2].before.nd, 1.5);
    EXPECT_TRUE(sys.interfaces[2].after.is_air());
    EXPECT_NEAR(sys.sensor_z_mm, 11.0 + paraxial(sys).bfl_mm, 1e-12);
}

TEST(Realize, StopRadiusGivesTheRequestedFNumber) {
    const Lens lens = load_preset("mld-double-gauss");
    for (double n : {2.2, 2.8, 5.6, 16.0}) {
        const System sys = realize(lens, 0.0, n);
        EXPECT_NEAR(paraxial(sys).f_number, n, 1e-12);
        EXPECT_LE(sys.interfaces[5].semi_diameter_mm, lens.surfaces[5].semi_diameter_mm);
    }
    EXPECT_THROW(realize(lens, 0.0, 1.4), std::invalid_argument);  // wider than the clear stop
}

TEST(Realize, ZoomInterpolatesThicknessesAndLabelsMapToZoom) {
    const Lens lens = load_preset("canon-70-200");
    EXPECT_EQ(lens.zoom_positions(), 3);
    const auto mid = thicknesses_at(lens, 0.25);
    EXPECT_NEAR(mid[5], 0.5 * (8.78 + 26.15), 1e-12);
    EXPECT_DOUBLE_EQ(zoom_for_label(lens, 135.0), 0.5);
    EXPECT_DOUBLE_EQ(parse_zoom(lens, "200mm"), 1.0);
    EXPECT_DOUBLE_EQ(parse_zoom(lens, "0.25"), 0.25);
    EXPECT_THROW(parse_zoom(lens, "1.5"), std::invalid_argument);
    EXPECT_THROW(parse_zoom(lens, "300mm"), std::invalid_argument);
    EXPECT_THROW(thicknesses_at(lens, std::nan("")), std::invalid_argument);
}

// ---------------------------------------------------------------- the file format and its errors

TEST(LensFile, ReadsEveryMediumKindCoatingsAndAspheres) {
    const Lens lens = parse_lens_toml(R"(
name = "kinds"
source = "test"
focal_length = [50, 100]
f_number = 2.8
zoom_labels = [50, 100]
coating = "none"
aperture = { blades = 7, rotation = 10, curvature = 0.5 }
surfaces = [
  { r = 40, t = 5, sd = 12, glass = "N-BK7", coating = "mgf2" },
  { r = -40, t = [2, 8], sd = 12, coating = { index = 1.38, wavelength = 500, offset = 0.05 } },
  { stop = true, t = 5, sd = 8 },
  { r = inf, t = 3, sd = 10, nd = 1.6, vd = 40, label = "flint" },
  { r = 0, t = 2, sd = 10, sellmeier = [1.03961212, 0.00600069867, 0.231792344, 0.0200179144, 1.01046945, 103.560653], label = "bk7 by hand" },
  { r = -60, t = 30, sd = 10, k = -1, asph = [1e-6, -2e-9], coating = { layers = [ { nd = 1.38, nm = 99.6 }, { glass = "N-BK7", nm = 20 } ] } },
]
)", "kinds.toml");
    ASSERT_EQ(lens.surfaces.size(), 6u);
    EXPECT_EQ(lens.zoom_positions(), 2);
    EXPECT_EQ(lens.aperture.blades, 7);
    EXPECT_EQ(lens.surfaces[0].medium.formula, Glass::Formula::Sellmeier);
    EXPECT_NEAR(lens.surfaces[0].medium.index(kLineD_nm), 1.5168, 1e-4);
    EXPECT_EQ(lens.surfaces[0].coating.kind, Coating::Kind::QuarterWave);
    EXPECT_DOUBLE_EQ(lens.surfaces[1].coating.thickness_offset, 0.05);
    EXPECT_EQ(lens.surfaces[3].medium.formula, Glass::Formula::Abbe);
    EXPECT_EQ(lens.surfaces[3].radius_mm, 0.0);
    EXPECT_NEAR(lens.surfaces[4].medium.index(kLineD_nm), lens.surfaces[0].medium.index(kLineD_nm), 1e-6);
    EXPECT_EQ(lens.surfaces[5].coating.kind, Coating::Kind::Stack);
    ASSERT_EQ(lens.surfaces[5].coating.layers.size(), 2u);
    EXPECT_EQ(lens.surfaces[5].aspheric.size(), 2u);
    EXPECT_DOUBLE_EQ(lens.surfaces[5].conic, -1.0);
    // Round trip of the non-default kinds.
    const Lens back = parse_lens_toml(write_lens_toml(lens), "again");
    EXPECT_EQ(write_lens_toml(back), write_lens_toml(lens));
    EXPECT_EQ(back.surfaces[5].coating.layers[1].thickness_nm, 20.0);
}

TEST(LensFile, ErrorsNameTheLineAndTheField) {
    const std::string head = "name = \"bad\"\nsurfaces = [\n";  // surface rows start on line 3
    const auto error_for = [&](const std::string& rows) { return parse_error(head + rows + "]\n"); };

    std::string e = error_for("  { r = 50, t = 5, sd = 10, nd = 1.5 },\n  { r = -50, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("no aperture stop"), std::string::npos) << e;

    e = error_for("  { stop = true, t = 1, sd = 5 },\n  { r = 50, t = -5, sd = 10, nd = 1.5 },\n  { r = -50, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("bad.toml:4:"), std::string::npos) << e;
    EXPECT_NE(e.find("surface 2: t: negative thickness"), std::string::npos) << e;

    // No lens is 10 m thick or wide: 1e300 once gave a focal length of 0 and a flare of nothing, without a word.
    e = error_for("  { stop = true, t = 1, sd = 5 },\n  { r = 50, t = 1e300, sd = 10, nd = 1.5 },\n  { r = -50, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("bad.toml:4:"), std::string::npos) << e;
    EXPECT_NE(e.find("surface 2: t: 1e+300 mm is beyond any lens"), std::string::npos) << e;
    e = error_for("  { stop = true, t = 1, sd = 5 },\n  { r = 0, t = 5, sd = 1e30, nd = 1.5 },\n  { r = 0, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("surface 2: sd: 1e+30 mm is beyond any lens"), std::string::npos) << e;
    e = parse_error("name = \"bad\"\nf_number = -5\nsurfaces = [\n  { stop = true, t = 1, sd = 5 },\n  { r = 50, t = 5, sd = 10, nd = 1.5 },\n  { r = -50, t = 40, sd = 10 },\n]\n");
    EXPECT_NE(e.find("f_number: -5 must be positive"), std::string::npos) << e;

    e = error_for("  { stop = true, t = 1, sd = 5 },\n  { r = 50, t = 5, sd = 10, glass = \"UNOBTAINIUM\" },\n  { r = -50, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("bad.toml:4:"), std::string::npos) << e;
    EXPECT_NE(e.find("glass: unknown glass 'UNOBTAINIUM'"), std::string::npos) << e;

    e = error_for("  { stop = true, t = [1, 2], sd = 5 },\n  { r = 50, t = [5, 6, 7], sd = 10, nd = 1.5 },\n  { r = -50, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("bad.toml:4:"), std::string::npos) << e;
    EXPECT_NE(e.find("surface 2: t: 3 zoom columns where the rows before have 2"), std::string::npos) << e;

    e = error_for("  { stop = true, t = 1, sd = 5 },\n  { r = nan, t = 5, sd = 10, nd = 1.5 },\n  { r = -50, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("bad.toml:4:"), std::string::npos) << e;
    EXPECT_NE(e.find("surface 2: r:"), std::string::npos) << e;

    e = error_for("  { stop = true, t = 1, sd = 5 },\n  { r = 50, t = inf, sd = 10, nd = 1.5 },\n  { r = -50, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("surface 2: t:"), std::string::npos) << e;

    e = error_for("  { stop = true, t = 1, sd = 5 },\n  { r = 50, t = 5, nd = 1.5 },\n  { r = -50, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("bad.toml:4: surface 2: sd: missing"), std::string::npos) << e;

    e = error_for("  { stop = true, t = 1, sd = 5 },\n  { r = 50, t = 5, sd = 10, nd = 1.5, thick = 3 },\n  { r = -50, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("surface 2: thick: unknown field"), std::string::npos) << e;

    e = error_for("  { stop = true, t = 1, sd = 5 },\n  { stop = true, t = 1, sd = 5 },\n  { r = 50, t = 5, sd = 10, nd = 1.5 },\n  { r = -50, t = 40, sd = 10 },\n");
    EXPECT_NE(e.find("a second aperture stop"), std::string::npos) << e;

    e = error_for("  { stop = true, t = 1, sd = 5 },\n  { r = 50, t = 5, sd = 10, nd = 1.5 },\n");
    EXPECT_NE(e.find("must leave the light in air"), std::string::npos) << e;

    e = parse_error("name = \"bad\"\nsurfaces = [\n  { stop = true t = 1 },\n]\n");  // TOML syntax
    EXPECT_NE(e.find("bad.toml:3:"), std::string::npos) << e;

    e = parse_error("surfaces = []\n");
    EXPECT_NE(e.find("name: missing"), std::string::npos) << e;
}

TEST(LensFile, NegativeAirGapNextToTheStopIsAllowed) {
    EXPECT_EQ(parse_error("name = \"ok\"\nsurfaces = [\n  { r = 50, t = 5, sd = 10, nd = 1.5 },\n"
                          "  { r = -50, t = -1, sd = 10 },\n  { stop = true, t = 40, sd = 5 },\n]\n"),
              "");
}

// Damaged files (characters deleted, replaced or duplicated) either still parse into a valid lens or fail
// with a LensFileError that names the file; never another exception, a crash or a hang.
TEST(LensFile, DamagedFilesFailCleanly) {
    const std::string original(*preset_text("canon-70-200"));
    const std::string fx = "# t\n#!scale 0.5\n60 8 LAK9 1.691 54.7 20\n-200 2/12 air 20\n10000 5 iris 10\n"
                           "-50 3 abbe 1.6 40 12 #!aspheric=0,1e-6,2e-9\n80 40 air 12\n";
    const std::string dat = "# x\n50 5 1.5 20\n-50 10 1 20\n0 5 0 8\n30 4 1.6 16\n200 0 1 16\n";
    std::uint64_t state = 12345;
    const auto next = [&state] {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return static_cast<std::size_t>(state >> 33);
    };
    const std::string alphabet = "0123456789.-+e,[]{}=\"#/ \nabcinfnax";
    int parsed = 0, rejected = 0;
    for (int trial = 0; trial < 600; ++trial) {
        const std::string& base = trial % 3 == 0 ? original : (trial % 3 == 1 ? fx : dat);
        std::string text = base;
        for (int edits = 1 + static_cast<int>(next() % 3); edits > 0; --edits) {
            const std::size_t at = next() % text.size();
            switch (next() % 3) {
                case 0: text.erase(at, 1 + next() % 4); break;
                case 1: text[at] = alphabet[next() % alphabet.size()]; break;
                default: text.insert(at, text.substr(at, 1 + next() % 6)); break;
            }
        }
        try {
            Lens lens;
            if (trial % 3 == 0) lens = parse_lens_toml(text, "damaged.toml");
            else if (trial % 3 == 1) lens = parse_lentil_fx(text, "damaged.fx");
            else lens = parse_pbrt_dat(text, "damaged.dat");
            validate_lens(lens, "again");
            ++parsed;
        } catch (const LensFileError& e) {
            EXPECT_NE(std::string(e.what()).find("damaged."), std::string::npos) << e.what();
            ++rejected;
        } catch (const std::exception& e) {
            ADD_FAILURE() << "not a LensFileError: " << e.what() << "\n" << text;
        }
    }
    EXPECT_GT(rejected, 100);
    EXPECT_GT(parsed, 10);
}

// A path that is there but not a file (a device that never ends, a folder) is named as such, never read
// and never taken for a missing preset.
TEST(LensFile, DevicesAndFoldersAreRefusedUnread) {
    for (const char* path : {"/dev/zero", "/tmp"}) {
        try {
            (void)load_lens(path);
            ADD_FAILURE() << path << " was read as a lens";
        } catch (const LensFileError& e) {
            EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
        }
    }
}

// ---------------------------------------------------------------- importers

TEST(Importers, PbrtDatWithCrlfDiameterAndStop) {
    const std::string dat =
        "# test lens\r\n#  radius\taxpos\tN\taperture\r\n50\t5\t1.5\t20\r\n-50\t10\t1\t20\r\n0\t5\t0\t8\r\n"
        "30\t4\t1.6\t16\r\n200\t0\t1\t16\r\n";
    const Lens lens = parse_pbrt_dat(dat, "test.dat");
    ASSERT_EQ(lens.surfaces.size(), 5u);
    EXPECT_EQ(lens.stop_index(), 2);
    EXPECT_DOUBLE_EQ(lens.surfaces[0].semi_diameter_mm, 10.0);  // diameter 20
    EXPECT_DOUBLE_EQ(lens.surfaces[2].semi_diameter_mm, 4.0);
    EXPECT_TRUE(lens.surfaces[1].medium.is_air());
    EXPECT_DOUBLE_EQ(lens.surfaces[3].medium.index(450.0), 1.6);  // no dispersion in the format
    EXPECT_EQ(lens.surfaces[0].source_line, 3);
    // Last thickness = paraxial BFL.
    const System sys = realize(lens);
    EXPECT_NEAR(lens.surfaces.back().thickness_mm[0], paraxial(sys).bfl_mm, 1e-9);
    EXPECT_GT(lens.surfaces.back().thickness_mm[0], 0.0);
}

TEST(Importers, PbrtDatErrorsNameTheLine) {
    try {
        parse_pbrt_dat("# x\r\n50\t5\t1.5\t20\r\n-50\t10\r\n", "short.dat");
        FAIL() << "no error";
    } catch (const LensFileError& e) {
        EXPECT_NE(std::string(e.what()).find("short.dat:3: expected 4 columns"), std::string::npos) << e.what();
    }
}

TEST(Importers, LentilFxScaleZoomIrisAsphereAndEfl) {
    const std::string fx =
        "# TEST; zoom\r\n#EFL\t100\t150\r\n#!scale 0.5\r\n// radius thickness matl index vno sa\r\n"
        "60\t8\tLAK9\t1.691\t54.7\t20\r\n-200\t2/12\tair\t\t20\r\n10000\t5\tiris\t\t10\r\n"
        "-50\t3\tabbe\t1.6\t40\t12 #!aspheric=0,1e-6,2e-9\r\n80\t40\tair\t12\r\n0\t0\tair\t0\r\n99\t9\tair\t9\r\n";
    const Lens lens = parse_lentil_fx(fx, "test.fx");
    ASSERT_EQ(lens.surfaces.size(), 5u);  // the radius-0 row ends the table
    EXPECT_EQ(lens.zoom_positions(), 2);
    EXPECT_DOUBLE_EQ(lens.surfaces[0].radius_mm, 30.0);
    EXPECT_DOUBLE_EQ(lens.surfaces[0].semi_diameter_mm, 10.0);
    EXPECT_EQ(lens.surfaces[1].thickness_mm, (std::vector<double>{1.0, 6.0}));
    EXPECT_TRUE(lens.surfaces[2].is_stop);
    EXPECT_EQ(lens.surfaces[0].medium.formula, Glass::Formula::Abbe);
    EXPECT_NEAR(lens.surfaces[0].medium.index(kLineD_nm), 1.691, 1e-9);
    ASSERT_EQ(lens.surfaces[3].aspheric.size(), 2u);
    EXPECT_NEAR(lens.surfaces[3].aspheric[0], 1e-6 * 8.0, 1e-18);   // a4 s^-3
    EXPECT_NEAR(lens.surfaces[3].aspheric[1], 2e-9 * 32.0, 1e-18);  // a6 s^-5
    EXPECT_EQ(lens.stated_focal_mm, (std::vector<double>{50.0, 75.0}));
}

TEST(Importers, LentilFxRejectsCylindricalSurfacesNamingTheLine) {
    try {
        parse_lentil_fx("50 5 abbe 1.5 60 10\n100000 2 iris 5\n40 3 cx_abbe 1.6 40 10\n-40 30 cx_air 10\n", "ana.fx");
        FAIL() << "no error";
    } catch (const LensFileError& e) {
        EXPECT_NE(std::string(e.what()).find("ana.fx:3: material: 'cx_abbe' is a cylindrical"), std::string::npos) << e.what();
    }
}

TEST(Importers, ReferenceFilesGiveTheDocumentedFocalLengths) {
    if (!fs::exists(kReference)) GTEST_SKIP() << "../shared/reference/lenses not found at " << kReference;
    // Paraxial values listed in ../shared/reference/lenses/README.md (computed there independently).
    const Lens dgauss = load_lens((kReference / "pbrt" / "dgauss.50mm.dat").string());
    EXPECT_NEAR(paraxial(realize(dgauss)).efl_mm, 50.358, 1e-3);
    EXPECT_NEAR(dgauss.surfaces.back().thickness_mm[0], 36.106, 1e-3);
    EXPECT_NEAR(paraxial(realize(load_lens((kReference / "pbrt" / "telephoto.250mm.dat").string()))).efl_mm, 249.567, 1e-3);
    const Lens canon = load_lens((kReference / "lentil-fx" / "canon-zoom.fx").string());
    EXPECT_NEAR(paraxial(realize(canon, 0.0)).efl_mm, 72.118, 1e-3);
    EXPECT_NEAR(paraxial(realize(canon, 0.5)).efl_mm, 134.948, 1e-3);
    EXPECT_NEAR(paraxial(realize(canon, 1.0)).efl_mm, 193.910, 1e-3);
    EXPECT_NEAR(paraxial(realize(load_lens((kReference / "lentil-fx" / "double-gauss-angenieux.fx").string()))).efl_mm, 49.992, 1e-3);
    const Lens nikon = load_lens((kReference / "lentil-fx" / "nikon-zoom.fx").string());
    EXPECT_NEAR(paraxial(realize(nikon, 0.0)).efl_mm, 57.206, 1e-3);  // the 1/1.4-scaled table
    const Lens fisheye = load_lens((kReference / "lentil-fx" / "fisheye-aspherical.fx").string());
    int aspheres = 0;
    for (const auto& s : fisheye.surfaces) aspheres += s.aspheric.empty() ? 0 : 1;
    EXPECT_EQ(aspheres, 4);
    EXPECT_NEAR(paraxial(realize(fisheye)).efl_mm, 9.709, 1e-3);
}

TEST(Importers, FormatIsDetectedByExtensionThenContent) {
    EXPECT_EQ(detect_lens_format("a.dat", ""), LensFormat::PbrtDat);
    EXPECT_EQ(detect_lens_format("a.fx", ""), LensFormat::LentilFx);
    EXPECT_EQ(detect_lens_format("a.lens", ""), LensFormat::Toml);
    EXPECT_EQ(detect_lens_format("a.txt", "# x\n1 2 1.5 4\n"), LensFormat::PbrtDat);
    EXPECT_EQ(detect_lens_format("a.txt", "# x\n50 5 abbe 1.5 60 10\n"), LensFormat::LentilFx);
    EXPECT_EQ(detect_lens_format("a.txt", "name = \"x\"\nsurfaces = []\n"), LensFormat::Toml);
    EXPECT_THROW(load_lens("no-such-lens"), LensFileError);
}
