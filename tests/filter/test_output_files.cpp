// The files the program writes (filter/output_files.h): written unnamed where the file system allows, named only
// when committed, gone when dropped, and their errors naming the file the user asked for.
#include <filter/output_files.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <fcntl.h>
#include <fmt/core.h>
#include <gtest/gtest.h>
#include <unistd.h>

namespace fs = std::filesystem;
using lensfx::filter::TempFile;

namespace {

// A folder of its own under the system's temporary folder, removed at the end.
struct ScratchDir {
    fs::path path = fs::temp_directory_path() / fmt::format("lensfx-test-output-files-{}", ::getpid());
    ScratchDir() {
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~ScratchDir() { fs::remove_all(path); }
};

std::vector<std::string> names_in(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
    return names;
}

std::string slurp(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

void put(const std::string& path, const std::string& text) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << text;
}

// Whether `dir`'s file system makes unnamed files (O_TMPFILE); the tests of that path are skipped where not.
bool writes_unnamed(const fs::path& dir) {
    const int fd = ::open(dir.c_str(), O_TMPFILE | O_WRONLY, 0600);
    if (fd < 0) return false;
    ::close(fd);
    return true;
}

}  // namespace

TEST(TempFile, HasNoNameUntilCommitted) {
    const ScratchDir dir;
    if (!writes_unnamed(dir.path)) GTEST_SKIP() << "no O_TMPFILE here";
    const std::string target = (dir.path / "a.exr").string();
    TempFile file(target);
    EXPECT_EQ(file.name(), target);
    put(file.path(), "frame");  // opened again with truncation, as OpenEXR and OpenImageIO do
    EXPECT_TRUE(names_in(dir.path).empty()) << names_in(dir.path).front();
    file.commit();
    EXPECT_EQ(names_in(dir.path), std::vector<std::string>{"a.exr"});
    EXPECT_EQ(slurp(target), "frame");
}

TEST(TempFile, DroppedLeavesTheTargetAsItWas) {
    const ScratchDir dir;
    const std::string target = (dir.path / "a.exr").string();
    put(target, "old");
    {
        TempFile file(target);
        put(file.path(), "half a frame");
    }
    EXPECT_EQ(names_in(dir.path), std::vector<std::string>{"a.exr"});
    EXPECT_EQ(slurp(target), "old");
}

TEST(TempFile, ReplacesTheTargetWhenCommitted) {
    const ScratchDir dir;
    const std::string target = (dir.path / "a.exr").string();
    put(target, "old");
    TempFile file(target);
    put(file.path(), "new");
    file.commit();
    EXPECT_EQ(names_in(dir.path), std::vector<std::string>{"a.exr"});
    EXPECT_EQ(slurp(target), "new");
}

// A writer's message names the file the user asked for, never /proc/self/fd/N.
TEST(TempFile, ErrorsNameTheTarget) {
    const ScratchDir dir;
    const std::string target = (dir.path / "a.exr").string();
    TempFile file(target);
    try {
        file.write([](const std::string& path) { throw std::runtime_error(fmt::format("cannot write {}: disk full ({})", path, path)); });
        FAIL() << "no exception";
    } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()), fmt::format("cannot write {}: disk full ({})", target, target));
    }
}

// A temporary of this PID's name left by an earlier process (PIDs are reused) is replaced at commit.
TEST(TempFile, CommitsOverAStaleTemporaryOfTheSamePid) {
    const ScratchDir dir;
    const std::string stale = (dir.path / fmt::format(".a.lensfx-{}.exr", ::getpid())).string();
    put(stale, "stale");
    TempFile file((dir.path / "a.exr").string());
    put(file.path(), "new");
    file.commit();
    EXPECT_EQ(slurp(dir.path / "a.exr"), "new");
    EXPECT_FALSE(fs::exists(stale));
}

// A target name of 255 bytes (the most a file system takes) is written: its temporary's name is cut to fit.
TEST(TempFile, TheLongestLegalNameIsWritten) {
    const ScratchDir dir;
    const std::string name = std::string(251, 'a') + ".exr";
    TempFile file((dir.path / name).string());
    put(file.path(), "frame");
    file.commit();
    EXPECT_EQ(names_in(dir.path), std::vector<std::string>{name});
    EXPECT_EQ(slurp(dir.path / name), "frame");
}
