// The ray table's disk cache: a second run reads exactly the table the first computed; another focus,
// lens or raster is another file; a truncated, altered or foreign file is rejected and rebuilt; a cache
// that cannot be written is skipped.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <dof/ray_cache.h>
#include <fmt/core.h>

#include "dof_scenes.h"

namespace lensfx::dof {
namespace {

namespace fs = std::filesystem;

constexpr int kSamples = 16, kGrid = 3;

// A folder of its own under the build's temporary folder, removed at the end.
struct TempDir {
    fs::path path;
    explicit TempDir(const char* name) : path(fs::temp_directory_path() / fmt::format("lensfx-dof-cache-{}-{}", name, ::getpid())) {
        fs::remove_all(path);
    }
    ~TempDir() { fs::remove_all(path); }
};

Camera small_camera(double focus_m = 1.0) { return test::camera_for("mld-double-gauss", 4.0, focus_m, 2.0, 40, 10.0); }

void expect_same(const RayTable& a, const RayTable& b) {
    ASSERT_EQ(a.line.size(), b.line.size());
    EXPECT_EQ(a.grid_x, b.grid_x);
    EXPECT_EQ(a.grid_y, b.grid_y);
    EXPECT_EQ(a.samples, b.samples);
    EXPECT_EQ(a.cell_w, b.cell_w);
    EXPECT_EQ(a.cell_h, b.cell_h);
    EXPECT_EQ(a.focus_w, b.focus_w);
    EXPECT_EQ(a.max_slope, b.max_slope);
    EXPECT_EQ(a.line, b.line);
    EXPECT_EQ(a.weight, b.weight);
}

// Every .bin file in dir (the cache's tables; no temporaries left).
std::vector<fs::path> files_in(const fs::path& dir) {
    std::vector<fs::path> out;
    for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path());
    return out;
}

TEST(DofRayCache, SecondRunReadsTheTableTheFirstComputed) {
    TempDir dir("same");
    const Camera cam = small_camera();
    RayTableSource first, second;
    const RayTable a = cached_ray_table(cam, kSamples, kGrid, dir.path.string(), &first);
    const RayTable b = cached_ray_table(cam, kSamples, kGrid, dir.path.string(), &second);
    EXPECT_FALSE(first.loaded);
    EXPECT_TRUE(first.saved);
    EXPECT_TRUE(second.loaded);
    EXPECT_FALSE(second.rejected);
    expect_same(a, b);
    expect_same(a, make_ray_table(cam, kSamples, kGrid));
    ASSERT_EQ(files_in(dir.path).size(), 1u) << "one table, no temporary left";
    EXPECT_EQ(files_in(dir.path)[0].extension(), ".bin");
}

TEST(DofRayCache, AnotherFocusLensOrRasterIsAnotherFile) {
    const Camera cam = small_camera();
    const std::string key = ray_table_key(cam, kSamples, kGrid);
    Camera focus = small_camera(1.5), lens = cam, raster = cam, stop = small_camera();
    lens.system = optics::realize(optics::load_lens("cooke-triplet"), 0.0, 5.6);
    raster.width = 41;
    stop.system = optics::realize(optics::load_lens("mld-double-gauss"), 0.0, 5.6);
    for (const Camera* other : {&focus, &lens, &raster, &stop}) {
        EXPECT_NE(ray_table_key(*other, kSamples, kGrid), key);
        EXPECT_NE(ray_table_path("d", ray_table_key(*other, kSamples, kGrid)), ray_table_path("d", key));
    }
    EXPECT_NE(ray_table_key(cam, kSamples + 1, kGrid), key);
    EXPECT_NE(ray_table_key(cam, kSamples, kGrid + 1), key);
}

// Damages the one cached file with `damage`, then expects the next run to reject it, rebuild the same
// table and leave a good file (read by the run after).
template <typename Damage>
void expect_rejected_and_rebuilt(const char* name, Damage damage) {
    TempDir dir(name);
    const Camera cam = small_camera();
    const RayTable a = cached_ray_table(cam, kSamples, kGrid, dir.path.string());
    const std::string path = ray_table_path(dir.path.string(), ray_table_key(cam, kSamples, kGrid));
    ASSERT_TRUE(fs::exists(path));
    damage(path);
    EXPECT_FALSE(read_ray_table(path, ray_table_key(cam, kSamples, kGrid)).has_value());
    RayTableSource again, after;
    expect_same(a, cached_ray_table(cam, kSamples, kGrid, dir.path.string(), &again));
    EXPECT_FALSE(again.loaded);
    EXPECT_TRUE(again.rejected);
    EXPECT_TRUE(again.saved);
    expect_same(a, cached_ray_table(cam, kSamples, kGrid, dir.path.string(), &after));
    EXPECT_TRUE(after.loaded);
}

TEST(DofRayCache, AlteredByteIsRejectedAndRebuilt) {
    expect_rejected_and_rebuilt("altered", [](const std::string& path) {
        std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(static_cast<std::streamoff>(fs::file_size(path) / 2));
        f.put('\x5a');
    });
}

TEST(DofRayCache, TruncatedFileIsRejectedAndRebuilt) {
    expect_rejected_and_rebuilt("truncated", [](const std::string& path) { fs::resize_file(path, fs::file_size(path) - 7); });
}

TEST(DofRayCache, ForeignFileUnderTheNameIsRejectedAndRebuilt) {
    expect_rejected_and_rebuilt("foreign", [](const std::string& path) {
        TempDir other("foreign-source");
        const Camera focus = small_camera(1.5);
        (void)cached_ray_table(focus, kSamples, kGrid, other.path.string());
        fs::copy_file(ray_table_path(other.path.string(), ray_table_key(focus, kSamples, kGrid)), path, fs::copy_options::overwrite_existing);
    });
}

TEST(DofRayCache, HeaderClaimingAHugeTableIsRejectedBeforeAllocating) {
    expect_rejected_and_rebuilt("huge", [](const std::string& path) {
        const Camera cam = small_camera();
        const std::string key = ray_table_key(cam, kSamples, kGrid);
        std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(static_cast<std::streamoff>(8 + 8 + key.size() + 8));  // the header's samples
        const std::int32_t samples = 1 << 16;
        f.write(reinterpret_cast<const char*>(&samples), sizeof samples);
    });
}

TEST(DofRayCache, UnwritableCacheIsSkipped) {
    TempDir dir("unwritable");
    std::ofstream(dir.path.string()) << "a file where the folder should be";
    RayTableSource source;
    const Camera cam = small_camera();
    expect_same(make_ray_table(cam, kSamples, kGrid), cached_ray_table(cam, kSamples, kGrid, (dir.path / "sub").string(), &source));
    EXPECT_FALSE(source.saved);
    EXPECT_FALSE(source.loaded);
}

}  // namespace
}  // namespace lensfx::dof
