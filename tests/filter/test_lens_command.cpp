// The `lensfx lens` commands end to end: info, list, convert and trace through the program.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/presets.h>
#include <optics/system.h>

#include "run_lensfx.h"

namespace fs = std::filesystem;
using namespace lensfx::optics;
using lensfx::test::ProgramRun;
using lensfx::test::run_lensfx;

namespace {

const fs::path kReference = fs::path(LENSFX_SHARED_DIR) / "reference" / "lenses";

fs::path temp_file(const std::string& name, const std::string& text) {
    const fs::path dir = fs::temp_directory_path() / "lensfx_lens_tests";
    fs::create_directories(dir);
    const fs::path p = dir / name;
    std::ofstream(p, std::ios::binary) << text;
    return p;
}

}  // namespace

TEST(LensCommand, InfoJsonHasTheDocumentedKeys) {
    const ProgramRun r = run_lensfx("lens info mld-double-gauss --json");
    ASSERT_EQ(r.status, 0) << r.output;
    const auto j = nlohmann::json::parse(r.output);
    for (const char* key : {"efl_mm", "bfl_mm", "ffl_mm", "f_number", "entrance_pupil_mm", "entrance_pupil_diameter_mm",
                            "exit_pupil_mm", "exit_pupil_diameter_mm", "surfaces", "ghosts"})
        EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_NEAR(j["efl_mm"].get<double>(), 100.0038, 2e-4);
    EXPECT_NEAR(j["bfl_mm"].get<double>(), 61.4875, 2e-4);
    EXPECT_EQ(j["surfaces"].get<int>(), 11);
    EXPECT_EQ(j["ghosts"].get<int>(), 45);  // 10 reflecting interfaces: 10 * 9 / 2
}

TEST(LensCommand, InfoTakesZoomLabelsWavelengthAndFiles) {
    ProgramRun r = run_lensfx("lens info canon-70-200 --zoom 200mm --json");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NEAR(nlohmann::json::parse(r.output)["efl_mm"].get<double>(), 194.0, 0.2);
    r = run_lensfx("lens info mld-double-gauss --wavelength 486.13 --json");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_LT(nlohmann::json::parse(r.output)["efl_mm"].get<double>(), 100.0);
    const fs::path p = fs::path(LENSFX_SOURCE_DIR) / "presets" / "lenses" / "brendel-tessar.toml";
    r = run_lensfx("lens info \"" + p.string() + "\"");
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("focal length:"), std::string::npos) << r.output;
}

TEST(LensCommand, BadFileFailsNamingTheLineAndField) {
    const fs::path p = temp_file("bad_glass.toml",
                                 "name = \"bad\"\nsurfaces = [\n  { stop = true, t = 1, sd = 5 },\n"
                                 "  { r = 50, t = 5, sd = 10, glass = \"NOPE-1\" },\n  { r = -50, t = 40, sd = 10 },\n]\n");
    const ProgramRun r = run_lensfx("lens info \"" + p.string() + "\" --json");
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.output.find("bad_glass.toml:4: surface 2: glass: unknown glass 'NOPE-1'"), std::string::npos) << r.output;

    const fs::path q = temp_file("bad_zoom.toml",
                                 "name = \"bad\"\nsurfaces = [\n  { stop = true, t = [1, 2], sd = 5 },\n"
                                 "  { r = 50, t = 5, sd = 10, nd = 1.5 },\n  { r = -50, t = [40, 41, 42], sd = 10 },\n]\n");
    const ProgramRun s = run_lensfx("lens info \"" + q.string() + "\"");
    EXPECT_NE(s.status, 0);
    EXPECT_NE(s.output.find("bad_zoom.toml:5: surface 3: t:"), std::string::npos) << s.output;
}

TEST(LensCommand, ListShowsEveryPreset) {
    const ProgramRun r = run_lensfx("lens list");
    ASSERT_EQ(r.status, 0) << r.output;
    for (const auto& name : preset_names()) EXPECT_NE(r.output.find(name), std::string::npos) << name;
}

TEST(LensCommand, ConvertWritesTheProjectFormat) {
    if (!fs::exists(kReference)) GTEST_SKIP() << "../shared/reference/lenses not found at " << kReference;
    const fs::path out = fs::temp_directory_path() / "lensfx_lens_tests" / "kreitzer.toml";
    fs::create_directories(out.parent_path());
    const ProgramRun r = run_lensfx("lens convert \"" + (kReference / "lentil-fx" / "kreitzer-tele.fx").string() + "\" -o \"" + out.string() + "\"");
    ASSERT_EQ(r.status, 0) << r.output;
    const Lens a = load_lens((kReference / "lentil-fx" / "kreitzer-tele.fx").string());
    const Lens b = load_lens(out.string());
    EXPECT_EQ(paraxial(realize(a)).efl_mm, paraxial(realize(b)).efl_mm);
}

TEST(LensCommand, TraceJsonListsEverySurface) {
    const ProgramRun r = run_lensfx("lens trace mld-double-gauss --height 10 --angle 5 --wavelength 587.56 --json");
    ASSERT_EQ(r.status, 0) << r.output;
    const auto j = nlohmann::json::parse(r.output);
    ASSERT_EQ(j["surfaces"].size(), 11u);
    EXPECT_EQ(j["surfaces"][0]["surface"].get<int>(), 1);
    EXPECT_NEAR(j["surfaces"][0]["y"].get<double>(), 10.0, 0.5);  // the ray meets the first surface near its height
    for (const auto& s : j["surfaces"]) {
        const double dx = s["dx"], dy = s["dy"], dz = s["dz"];
        EXPECT_NEAR(dx * dx + dy * dy + dz * dz, 1.0, 1e-12);
        EXPECT_GE(s["path_mm"].get<double>(), 0.0);
    }
}
