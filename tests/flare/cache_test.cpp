// The disk cache (flare/cache.h): the folder rule, the key hash and the atomic writer, and the two caches
// the flare model keeps through it (direct-power tables, starburst textures): stored, read, and a damaged,
// foreign or other-shaped file recomputed.
#include <cstdlib>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <flare/cache.h>
#include <flare/direct_power.h>
#include <flare/starburst_cache.h>
#include <optics/aperture.h>
#include <optics/lens_file.h>
#include <optics/starburst.h>
#include <optics/system.h>

namespace fs = std::filesystem;
using namespace lensfx;

namespace {

fs::path temp_dir(const std::string& name) {
    // Named by the process too: runs of other checkouts at the same time must not share it.
    const fs::path dir = fs::temp_directory_path() / ("lensfx_cache_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

}  // namespace

TEST(Cache, FolderFollowsTheEnvironmentAndTheOption) {
    const char* saved = std::getenv("LENSFX_CACHE_DIR");
    const std::string keep = saved ? saved : "";
    ::setenv("LENSFX_CACHE_DIR", "/some/where", 1);
    EXPECT_EQ(flare::default_cache_dir(), "/some/where");
    ::setenv("LENSFX_CACHE_DIR", "none", 1);
    EXPECT_EQ(flare::default_cache_dir(), "");
    ::unsetenv("LENSFX_CACHE_DIR");
    if (const char* home = std::getenv("HOME"); home && *home) {
        EXPECT_EQ(flare::default_cache_dir(), (fs::path(home) / ".cache" / "lensfx").string());
    }
    EXPECT_EQ(flare::cache_dir_of("/given"), "/given");
    EXPECT_EQ(flare::cache_dir_of("none"), "");
    EXPECT_EQ(flare::cache_dir_of(""), flare::default_cache_dir());
    if (saved) ::setenv("LENSFX_CACHE_DIR", keep.c_str(), 1);
}

TEST(Cache, FilesAreNamedByKindAndKeyHash) {
    EXPECT_EQ(flare::key_hash(""), 0xcbf29ce484222325ull) << "FNV-1a's offset basis";
    EXPECT_NE(flare::key_hash("a"), flare::key_hash("b"));
    EXPECT_EQ(flare::cache_file("/c", "direct", 0xabcull), "/c/direct-0000000000000abc.bin");
}

TEST(Cache, WriterReplacesAtomicallyAndLeavesNoTemporary) {
    const fs::path dir = temp_dir("writer");
    const std::string path = (dir / "deeper" / "x.bin").string();
    flare::write_cache_file(path, [](std::ostream& out) { out << "first"; });
    flare::write_cache_file(path, [](std::ostream& out) { out << "second"; });
    std::ifstream in(path);
    std::string text;
    std::getline(in, text);
    EXPECT_EQ(text, "second");
    EXPECT_EQ(std::distance(fs::directory_iterator(dir / "deeper"), fs::directory_iterator{}), 1) << "no temporary left";
    EXPECT_THROW(flare::write_cache_file("/proc/lensfx-no/x.bin", [](std::ostream&) {}), std::runtime_error);
    EXPECT_FALSE(flare::try_write_cache_file("/proc/lensfx-no/x.bin", [](std::ostream&) {}));
}

namespace {

// The whole of what a cache file opened as `path` gives, or nullopt for a miss.
std::optional<std::string> cache_text(const fs::path& path, std::uintmax_t max_bytes = flare::kMaxCacheFileBytes) {
    flare::CacheFile in = flare::open_cache_file(path, max_bytes);
    if (!in) return std::nullopt;
    std::string text(static_cast<std::size_t>(in.size()) + 1, '\0');  // one byte more than the file holds
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<std::size_t>(in.gcount()));
    return text;
}

}  // namespace

// open_cache_file opens, then checks the open descriptor: only a regular file of at most max_bytes, named
// directly, is read; a symbolic link (to a file, a FIFO or a device), a FIFO or a folder is a miss at once.
TEST(Cache, OnlyARegularFileWithinTheCapIsOpened) {
    const fs::path dir = temp_dir("open");
    std::ofstream(dir / "file.bin", std::ios::binary) << "cached";
    EXPECT_EQ(cache_text(dir / "file.bin"), "cached");
    EXPECT_EQ(flare::open_cache_file(dir / "file.bin").size(), 6u);
    EXPECT_EQ(cache_text(dir / "file.bin", 6), "cached");
    EXPECT_EQ(cache_text(dir / "file.bin", 5), std::nullopt) << "over the cap";
    ASSERT_EQ(::mkfifo((dir / "fifo.bin").c_str(), 0600), 0);
    fs::create_symlink(dir / "file.bin", dir / "to-file.bin");
    fs::create_symlink(dir / "fifo.bin", dir / "to-fifo.bin");
    fs::create_symlink("/dev/zero", dir / "to-zero.bin");
    fs::create_directory(dir / "folder.bin");
    for (const char* name : {"fifo.bin", "to-file.bin", "to-fifo.bin", "to-zero.bin", "folder.bin", "missing.bin"}) {
        const flare::CacheFile in = flare::open_cache_file(dir / name);  // returns: a FIFO with no writer does not block
        EXPECT_FALSE(in.is_open()) << name;
        EXPECT_TRUE(in.fail()) << name;
    }
    fs::remove_all(dir);
}

// What is read is the file that was opened and checked, to the size it had then, whatever the name is
// turned into afterwards (here a FIFO, which read through the name would block).
TEST(Cache, AnOpenedFileIsReadFromItsDescriptor) {
    const fs::path dir = temp_dir("swap");
    const fs::path path = dir / "file.bin";
    std::ofstream(path, std::ios::binary) << std::string(200000, 'a');  // more than the reader's buffer
    flare::CacheFile in = flare::open_cache_file(path);
    ASSERT_TRUE(in.is_open());
    fs::remove(path);
    ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0);
    std::string first(10, '\0'), rest(200000, '\0');
    ASSERT_TRUE(in.read(first.data(), static_cast<std::streamsize>(first.size())));
    in.read(rest.data(), static_cast<std::streamsize>(rest.size()));
    EXPECT_EQ(in.gcount(), 200000 - 10) << "the file's bytes, and no more";
    EXPECT_TRUE(in.eof());
    EXPECT_EQ(first + rest.substr(0, 200000 - 10), std::string(200000, 'a'));
    fs::remove_all(dir);
}

// A temporary a killed run left beside a cache file (SIGTERM while it wrote) is removed by the next write of
// that file; one of a process still running (this one) is not.
TEST(Cache, TemporariesOfDeadProcessesAreRemovedByTheNextWrite) {
    const fs::path dir = temp_dir("cache-stale");
    fs::create_directories(dir);
    const std::string file = (dir / "direct-0123456789abcdef.bin").string();
    const std::string dead = file + ".2147483646.1f2e3d.tmp";  // above any pid_max: no such process
    const std::string alive = file + "." + std::to_string(::getpid()) + ".abc.tmp";
    const std::string other = (dir / "bounds-0123456789abcdef.bin.2147483646.1.tmp").string();
    for (const std::string& f : {dead, alive, other}) std::ofstream(f) << "partial";
    flare::write_cache_file(file, [](std::ostream& out) { out << "whole"; });
    EXPECT_FALSE(fs::exists(dead));
    EXPECT_TRUE(fs::exists(alive));
    EXPECT_TRUE(fs::exists(other)) << "another file's temporaries wait for that file's next write";
    fs::remove_all(dir);
}

TEST(Cache, KeyIsReadBackOnlyWhenWhole) {
    std::stringstream s;
    flare::write_key(s, "lens 1");
    EXPECT_TRUE(flare::read_key(s, "lens 1"));
    std::stringstream other;
    flare::write_key(other, "lens 2");
    EXPECT_FALSE(flare::read_key(other, "lens 1"));
    std::stringstream cut(s.str().substr(0, 10));
    EXPECT_FALSE(flare::read_key(cut, "lens 1"));
}

TEST(Cache, StarburstStoresReadsAndRepairs) {
    const fs::path dir = temp_dir("cache");
    optics::Aperture hexagon;
    hexagon.blades = 6;
    hexagon.rotation_deg = 10.0;
    const optics::Starburst computed = flare::cached_starburst(hexagon, {}, (dir / "sub").string());
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir / "sub")) files.push_back(e.path());
    ASSERT_EQ(files.size(), 1u) << "one file per iris, no temporary left";
    const optics::Starburst read = flare::cached_starburst(hexagon, {}, (dir / "sub").string());
    EXPECT_EQ(read.size, computed.size);
    EXPECT_EQ(read.texel_per_fnumber_mm, computed.texel_per_fnumber_mm);
    EXPECT_EQ(read.rgb, computed.rgb);

    // A damaged (truncated) file is recomputed and rewritten.
    const auto whole = fs::file_size(files[0]);
    fs::resize_file(files[0], whole / 2);
    const optics::Starburst repaired = flare::cached_starburst(hexagon, {}, (dir / "sub").string());
    EXPECT_EQ(repaired.rgb, computed.rgb);
    EXPECT_EQ(fs::file_size(files[0]), whole);
    EXPECT_GT(whole, computed.rgb.size() * sizeof(float)) << "the texture and its key";

    // A whole file whose texels no texture has (NaN, huge, or a channel not summing to 1) is recomputed too.
    for (const float poison : {std::nanf(""), 3.4e38f, 0.5f}) {
        {
            std::fstream f(files[0], std::ios::in | std::ios::out | std::ios::binary);
            f.seekp(static_cast<std::streamoff>(whole - 4 * sizeof(float)));  // a texel near the texture's end
            f.write(reinterpret_cast<const char*>(&poison), sizeof poison);
        }
        EXPECT_EQ(flare::cached_starburst(hexagon, {}, (dir / "sub").string()).rgb, computed.rgb) << poison;
    }

    // Other options (dirt on the pupil, other primaries) are other textures, in other files.
    optics::StarburstOptions dirty;
    dirty.dirt.scratches = 20;
    const optics::Starburst scratched = flare::cached_starburst(hexagon, dirty, (dir / "sub").string());
    EXPECT_NE(scratched.rgb, computed.rgb);
    optics::StarburstOptions acescg;
    acescg.xyz_to_rgb[0] = 1.6410234;
    EXPECT_NE(flare::cached_starburst(hexagon, acescg, (dir / "sub").string()).rgb, computed.rgb);
    EXPECT_EQ(std::distance(fs::directory_iterator(dir / "sub"), fs::directory_iterator{}), 3);
}

TEST(Cache, DirectPowerTableTracesOnDemandAndKeepsItsSamplesOnDisk) {
    const fs::path dir = temp_dir("direct");
    const optics::System system = optics::realize(optics::load_lens("brendel-tessar"), 0.0, std::nullopt);
    flare::DirectPowerTable table(system, 20.0, 12, 8);
    EXPECT_EQ(table.traced(), 0);
    const auto near_axis = table.at(0.5, 0.2);
    EXPECT_EQ(table.traced(), 3) << "samples 0, 1 and 2 (the first is repeated below 0)";
    EXPECT_GT(near_axis[1], 0.0);
    table.save(dir / "t.bin", "key");

    flare::DirectPowerTable again(system, 20.0, 12, 8);
    EXPECT_FALSE(again.load(dir / "t.bin", "another key"));
    EXPECT_EQ(again.traced(), 0);
    EXPECT_TRUE(again.load(dir / "t.bin", "key"));
    EXPECT_EQ(again.traced(), 3);
    EXPECT_EQ(again.at(0.5, 0.2), near_axis);
    EXPECT_EQ(again.traced(), 3) << "nothing traced for a lookup the file covers";
    flare::DirectPowerTable other_size(system, 20.0, 10, 8);
    EXPECT_FALSE(other_size.load(dir / "t.bin", "key"));
    // A sample no trace could give (1e-300 saturated every pixel; negative or huge left the flare out) is
    // traced again, not used.
    for (const double poison : {1e-300, -1.0, 1e300}) {
        const auto size = fs::file_size(dir / "t.bin");
        {
            std::fstream f(dir / "t.bin", std::ios::in | std::ios::out | std::ios::binary);
            f.seekp(static_cast<std::streamoff>(size - 12 * 3 * sizeof(double)));  // sample 0's red
            f.write(reinterpret_cast<const char*>(&poison), sizeof poison);
        }
        flare::DirectPowerTable doctored(system, 20.0, 12, 8);
        EXPECT_TRUE(doctored.load(dir / "t.bin", "key"));
        EXPECT_EQ(doctored.traced(), 2) << "sample 0 not taken: " << poison;
        EXPECT_EQ(doctored.at(0.5, 0.2), near_axis) << poison;
        EXPECT_EQ(doctored.traced(), 3) << "sample 0 traced again: " << poison;
        table.save(dir / "t.bin", "key");
    }
    fs::resize_file(dir / "t.bin", fs::file_size(dir / "t.bin") - 1);
    flare::DirectPowerTable damaged(system, 20.0, 12, 8);
    EXPECT_FALSE(damaged.load(dir / "t.bin", "key"));
}

// Beyond its field (a light outside the frame) the table looks the light up where it is: nothing through the lens
// at 80 degrees, where the table's last sample (20 degrees) lent it its power; 25 degrees as traced there.
TEST(Cache, DirectPowerTableLooksUpLightsBeyondItsField) {
    const optics::System system = optics::realize(optics::load_lens("brendel-tessar"), 0.0, std::nullopt);
    const flare::DirectPowerTable table(system, 20.0, 12, 8);
    EXPECT_GT(table.at(19.0, 0.0)[1], 0.0);
    EXPECT_EQ(table.at(80.0, 10.0)[1], 0.0);
    EXPECT_EQ(flare::direct_power(system, 80.0, 10.0, 8)[1], 0.0);
    const auto beyond = table.at(26.0, 0.0), traced = flare::direct_power(system, 26.0, 0.0, 8);  // sample 13 of the 2-degree table
    for (std::size_t c = 0; c < 3; ++c) EXPECT_NEAR(beyond[c], traced[c], 1e-9 * traced[c]) << c;
    EXPECT_EQ(table.traced(), 3) << "samples 9-11 for 19 degrees; the lights beyond go to a table of their own";
    EXPECT_EQ(table.at(std::nan(""), 0.0), (std::array<double, 3>{})) << "no angle, no power";
}

