// The memory budget (--memory-limit): parsing, the checks and their messages, the lens tables' estimate,
// and end-to-end runs of the lensfx program on small hostile inputs made here: each is refused in one
// `lensfx:` line naming what was too big (never a bare std::bad_alloc), or runs within the budget.
#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <fmt/core.h>
#include <gtest/gtest.h>
#include <unistd.h>
#include <sys/wait.h>
#include <sys/resource.h>

#include <filter/colour.h>
#include <filter/image_io.h>
#include <filter/pipeline.h>
#include <gpu/flare_renderer.h>
#include <optics/image_window.h>
#include <optics/lens_file.h>
#include <optics/memory_budget.h>
#include <optics/system.h>

#include "../filter/filter_test_util.h"
#include "plate_lens.h"

namespace fs = std::filesystem;
using namespace lensfx;
using namespace lensfx::test;

namespace {

constexpr std::size_t kGiB = std::size_t{1} << 30;

// The message of the MemoryLimitError `f` throws ("" when it throws none).
template <typename F>
std::string refusal(F&& f) {
    try {
        f();
    } catch (const MemoryLimitError& e) {
        return e.what();
    }
    return "";
}

// One line on stderr, starting "lensfx: ", that holds `needle` and no bare bad_alloc.
void expect_one_line(const RunResult& r, const std::string& needle) {
    EXPECT_NE(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(std::count(r.stderr_text.begin(), r.stderr_text.end(), '\n'), 1) << r.stderr_text;
    EXPECT_EQ(r.stderr_text.rfind("lensfx: ", 0), 0u) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find(needle), std::string::npos) << r.stderr_text;
    EXPECT_EQ(r.stderr_text.find("bad_alloc"), std::string::npos) << r.stderr_text;
}

// A half RGB EXR whose data window is `data` x `data` pixels at (4, 4) inside a display window of
// `display` x `display`: a file of a few KB that declares a frame of display^2 pixels. The data holds one
// bright light (1000) on a dim ground (0.1), so the flare stage finds it.
void make_windowed_exr(const fs::path& path, int data, int display) {
    OIIO::ImageSpec spec(data, data, 3, OIIO::TypeHalf);
    spec.x = 4;
    spec.y = 4;
    spec.full_width = display;
    spec.full_height = display;
    std::vector<float> px(static_cast<std::size_t>(data) * static_cast<std::size_t>(data) * 3, 0.1f);
    for (int c = 0; c < 3; ++c) px[static_cast<std::size_t>((data / 2 * data + data / 2) * 3 + c)] = 1000.0f;
    auto out = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(out && out->open(path.string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeFloat, px.data()));
    ASSERT_TRUE(out->close());
}

// A lens of about `surfaces` surfaces (plate_lens.h) written to `dir`.
fs::path make_many_surface_lens(const fs::path& dir, int surfaces) {
    const fs::path path = dir / fmt::format("many-{}.toml", surfaces);
    std::ofstream(path) << plate_lens_toml(surfaces);
    return path;
}

std::string quoted(const fs::path& p) { return fmt::format("\"{}\"", p.string()); }

}  // namespace

TEST(MemoryBudget, ParsesSizesAndNone) {
    EXPECT_EQ(parse_memory_limit("4G").limit, 4 * kGiB);
    EXPECT_EQ(parse_memory_limit("512M").limit, std::size_t{512} << 20);
    EXPECT_EQ(parse_memory_limit("1.5g").limit, kGiB + kGiB / 2);
    EXPECT_EQ(parse_memory_limit("800K").limit, std::size_t{800} << 10);
    EXPECT_EQ(parse_memory_limit("4GB").limit, 4 * kGiB);
    EXPECT_EQ(parse_memory_limit("4GiB").limit, 4 * kGiB);
    EXPECT_EQ(parse_memory_limit("1000000").limit, 1000000u);
    EXPECT_FALSE(parse_memory_limit("none").limited());
    EXPECT_FALSE(parse_memory_limit("0").limited());
    for (const char* bad : {"", "G", "abc", "-1G", "4X", "nan", "1e3", "0.1", "1G2"})
        EXPECT_THROW(parse_memory_limit(bad), std::invalid_argument) << bad;
}

TEST(MemoryBudget, RefusalNamesWhatAndBothSizes) {
    const MemoryBudget budget{kGiB};
    EXPECT_EQ(refusal([&] { budget.check(static_cast<double>(kGiB), "a buffer"); }), "");
    EXPECT_EQ(refusal([&] { budget.check(2e9, "the thing"); }),
              "the thing needs 2.0 GB, over the memory limit of 1.1 GB (--memory-limit)");
    // Products of hostile sizes stay finite and are still refused.
    EXPECT_NE(refusal([&] { budget.check(bytes_of(1e6, 1e6, 12), "a window"); }).find("12 TB"), std::string::npos);
    EXPECT_EQ(refusal([&] { MemoryBudget{}.check(1e30, "anything"); }), "");  // no limit
    EXPECT_EQ(format_bytes(512), "512 bytes");
    EXPECT_EQ(format_bytes(10.8e9), "11 GB");
}

TEST(MemoryBudget, DefaultIsHalfOfTheMachine) {
    const MemoryBudget budget = default_memory_budget();
    ASSERT_TRUE(budget.limited());
    const double physical = static_cast<double>(::sysconf(_SC_PHYS_PAGES)) * static_cast<double>(::sysconf(_SC_PAGE_SIZE));
    EXPECT_LE(static_cast<double>(budget.limit), physical / 2.0 + 1.0);
    EXPECT_GT(budget.limit, std::size_t{64} << 20);
}

// Under a process limit (ulimit -v) lower than the machine's memory, half of that: a 20000 x 20000 frame under
// `ulimit -v 2000000` then is refused by the budget in words, where it ended in std::bad_alloc. In a child process,
// which takes the limit.
TEST(MemoryBudget, DefaultIsHalfOfTheProcessLimit) {
#if defined(__SANITIZE_ADDRESS__)
    // Its shadow is terabytes of address space: under a 1 GiB limit its allocator's next mapping fails (reading
    // the cgroup files allocates), so the limit's arithmetic is checked in the uninstrumented build.
    GTEST_SKIP() << "AddressSanitizer reserves terabytes of address space at start";
#endif
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        const rlimit one_gib{std::size_t{1} << 30, std::size_t{1} << 30};
        if (::setrlimit(RLIMIT_AS, &one_gib) != 0) ::_exit(3);
        const MemoryBudget budget = default_memory_budget();
        ::_exit(budget.limited() && budget.limit == (std::size_t{1} << 29) ? 0 : 1);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);
}

// The cgroup limit is read where the process's cgroup is, not only at the hierarchy's root: a Slurm job's or a
// systemd slice's limit sits on a child cgroup. The lowest over the cgroup and its ancestors counts; "max" and
// v1's "no limit" (2^63 rounded to pages) do not; a path with ".." is not followed out of the mount.
TEST(MemoryBudget, CgroupLimitOfAChildCgroupAndItsAncestors) {
    std::map<std::string, std::string> files;
    // Paths normalised as the file system would resolve them, so a ".." that escaped the mount would be found.
    const auto reader = [&](const std::string& path) -> std::optional<std::string> {
        const auto found = files.find(std::filesystem::path(path).lexically_normal().string());
        return found == files.end() ? std::nullopt : std::optional<std::string>(found->second);
    };
    // v2: the job's own limit, under an unlimited root.
    files = {{"/sys/fs/cgroup/memory.max", "max\n"},
             {"/sys/fs/cgroup/slurm/uid_0/job_7/memory.max", "2000000000\n"},
             {"/sys/fs/cgroup/slurm/uid_0/memory.max", "max\n"}};
    EXPECT_EQ(cgroup_memory_limit("0::/slurm/uid_0/job_7\n", reader), 2e9);
    // An ancestor's lower limit wins over the child's.
    files["/sys/fs/cgroup/slurm/memory.max"] = "1000000000\n";
    EXPECT_EQ(cgroup_memory_limit("0::/slurm/uid_0/job_7\n", reader), 1e9);
    // v1 (hybrid): the memory controller's line among others, its path under the memory mount.
    files = {{"/sys/fs/cgroup/memory/memory.limit_in_bytes", "9223372036854771712\n"},
             {"/sys/fs/cgroup/memory/process_api/a1/memory.limit_in_bytes", "3000000000\n"}};
    EXPECT_EQ(cgroup_memory_limit("12:cpu,cpuacct:/x\n4:memory:/process_api/a1\n0::/\n", reader), 3e9);
    EXPECT_EQ(cgroup_memory_limit("4:memsomething:/process_api/a1\n", reader), 0.0);
    // No /proc/self/cgroup (or a namespace showing "/"): the roots alone.
    files = {{"/sys/fs/cgroup/memory.max", "4294967296"}};
    EXPECT_EQ(cgroup_memory_limit("", reader), 4294967296.0);
    EXPECT_EQ(cgroup_memory_limit("0::/\n", reader), 4294967296.0);
    // v1 with memory.stat: its hierarchical limit is what binds (an ancestor's limit without use_hierarchy does
    // not, a container's parent above the mount does); the deepest readable memory.stat decides, unlimited too.
    files = {{"/sys/fs/cgroup/memory/job/memory.limit_in_bytes", "3000000000"},
             {"/sys/fs/cgroup/memory/job/memory.stat", "cache 0\nhierarchical_memory_limit 1500000000\nrss 12\n"}};
    EXPECT_EQ(cgroup_memory_limit("4:memory:/job\n", reader), 1.5e9);
    files = {{"/sys/fs/cgroup/memory/memory.limit_in_bytes", "2000000000"},
             {"/sys/fs/cgroup/memory/job/memory.stat", "hierarchical_memory_limit 9223372036854771712\n"}};
    EXPECT_EQ(cgroup_memory_limit("4:memory:/job\n", reader), 2e9);  // the root file still counts
    files = {{"/sys/fs/cgroup/memory/outer/memory.limit_in_bytes", "2000000000"},
             {"/sys/fs/cgroup/memory/outer/job/memory.stat", "hierarchical_memory_limit 9223372036854771712\n"}};
    EXPECT_EQ(cgroup_memory_limit("4:memory:/outer/job\n", reader), 0.0);  // use_hierarchy 0: outer's does not bind
    // Hostile text: no ".." out of the mount (the escape's target holds a limit), garbage values ignored; a name
    // with dots in it is a name.
    files = {{"/sys/fs/memory.max", "1000"}, {"/sys/fs/cgroup/a/memory.max", "12abc"}, {"/sys/fs/cgroup/x..y/memory.max", "5000"}};
    EXPECT_EQ(cgroup_memory_limit("0::/../..\n0::/a/../../..\n0::/a\nnonsense\n::::\n", reader), 0.0);
    EXPECT_EQ(cgroup_memory_limit("0::/x..y\n", reader), 5000.0);
}

// The hierarchies are found where /proc/self/mountinfo says: a cgroup v2 mount elsewhere than /sys/fs/cgroup, a
// v1 memory controller mounted with another ("cpu,memory"), a mount whose root is a deeper cgroup (a container's
// bind mount), and octal escapes in mount points. Files at the usual places then do not count.
// A host with thousands of mounts has a mountinfo of hundreds of KiB, its cgroup mounts perhaps last: the file is
// read whole (in chunks: procfs reports no size), and the cgroup2 mount on its last line is found.
TEST(MemoryBudget, LongMountinfoIsReadToItsEnd) {
    const auto dir = std::filesystem::temp_directory_path() / fmt::format("lensfx-mountinfo-{}", ::getpid());
    std::filesystem::create_directories(dir);
    std::string mountinfo;
    for (int i = 0; mountinfo.size() < 300 * 1024; ++i)
        mountinfo += fmt::format("{} 1 0:{} / /var/lib/containers/overlay/{:06} rw - overlay overlay rw\n", 100 + i, 50 + i, i);
    mountinfo += "9999 1 0:26 / /run/cg rw - cgroup2 cgroup2 rw\n";
    std::ofstream(dir / "mountinfo") << mountinfo;
    EXPECT_EQ(lensfx::read_proc_file((dir / "mountinfo").string()), mountinfo);
    EXPECT_EQ(lensfx::read_proc_file((dir / "mountinfo").string(), 1000), mountinfo.substr(0, 1000));  // the cap holds
    EXPECT_EQ(lensfx::read_proc_file((dir / "none").string()), std::nullopt);
    const std::map<std::string, std::string> files = {{"/run/cg/job/memory.max", "7000000\n"}};
    const auto reader = [&](const std::string& path) -> std::optional<std::string> {
        if (path == "/proc/self/mountinfo") return lensfx::read_proc_file((dir / "mountinfo").string());
        const auto found = files.find(path);
        return found == files.end() ? std::nullopt : std::optional<std::string>(found->second);
    };
    EXPECT_EQ(lensfx::cgroup_memory_limit("0::/job\n", reader), 7e6);
    std::filesystem::remove_all(dir);
}

TEST(MemoryBudget, CgroupHierarchiesAreWhereMountinfoSays) {
    std::map<std::string, std::string> files;
    const auto reader = [&](const std::string& path) -> std::optional<std::string> {
        const auto found = files.find(std::filesystem::path(path).lexically_normal().string());
        return found == files.end() ? std::nullopt : std::optional<std::string>(found->second);
    };
    const std::string decoy = "1000";  // a limit at the usual place, which these mounts make the wrong one
    files = {{"/proc/self/mountinfo", "22 1 0:21 / /proc rw - proc proc rw\n"
                                      "30 22 0:26 / /run/cg rw,nosuid shared:9 - cgroup2 cgroup2 rw,nsdelegate\n"},
             {"/sys/fs/cgroup/job/memory.max", decoy},
             {"/run/cg/job/memory.max", "2000000000\n"}};
    EXPECT_EQ(cgroup_memory_limit("0::/job\n", reader), 2e9);
    // v1: the memory controller mounted with cpu, after a mount of another controller.
    files = {{"/proc/self/mountinfo", "31 25 0:27 / /cgroup/cpuset rw - cgroup cgroup rw,cpuset\n"
                                      "32 25 0:28 / /cgroup/cpu,memory rw - cgroup cgroup rw,cpu,memory\n"},
             {"/sys/fs/cgroup/memory/job/memory.limit_in_bytes", decoy},
             {"/cgroup/cpu,memory/job/memory.limit_in_bytes", "3000000000"}};
    EXPECT_EQ(cgroup_memory_limit("5:cpu,memory:/job\n", reader), 3e9);
    // A container's bind mount whose root is the process's own cgroup: its path shows through the mount's root.
    files = {{"/proc/self/mountinfo", "40 35 0:30 /kubepods/pod1/c2 /sys/fs/cgroup ro - cgroup2 cgroup rw\n"},
             {"/sys/fs/cgroup/kubepods/pod1/c2/memory.max", decoy},
             {"/sys/fs/cgroup/memory.max", "500000000\n"},
             {"/sys/fs/cgroup/sub/memory.max", "400000000\n"}};
    EXPECT_EQ(cgroup_memory_limit("0::/kubepods/pod1/c2\n", reader), 5e8);
    EXPECT_EQ(cgroup_memory_limit("0::/kubepods/pod1/c2/sub\n", reader), 4e8);
    EXPECT_EQ(cgroup_memory_limit("0::/kubepods/pod1/c22\n", reader), 5e8);  // not under the root: the mount's own
    // A mount point with a space (\040 in mountinfo).
    files = {{"/proc/self/mountinfo", "30 1 0:26 / /mnt/c\\040g rw - cgroup2 none rw\n"}, {"/mnt/c g/j/memory.max", "6000"}};
    EXPECT_EQ(cgroup_memory_limit("0::/j\n", reader), 6000.0);
    // Mountinfo without cgroup mounts, or garbage: the usual places.
    for (const char* text : {"22 1 0:21 / /proc rw - proc proc rw\n", " - \n - cgroup2\n1 2 3 x y - cgroup2 a b\n\\\n"}) {
        files = {{"/proc/self/mountinfo", text}, {"/sys/fs/cgroup/job/memory.max", "7000"}};
        EXPECT_EQ(cgroup_memory_limit("0::/job\n", reader), 7000.0) << text;
    }
}

// The tables of a lens grow with the cube of its surfaces (ghosts by the square, their sequences by the
// surfaces); the estimate follows. The coating tables are shared by the steps (one per surface and way),
// so 100 surfaces need some 0.2 GB, not the 5.5 GB they once did. What cannot be drawn with fewer ghosts,
// the ghost list, is checked; the refusal names the lens, surfaces and ghosts.
// A window's side from its inclusive bounds (the EXR readers of filter/ and dof/ share it): exact up to an
// int's largest side, and bounds near the int limits refused in words instead of overflowing.
TEST(MemoryBudget, WindowSideFromBoundsWithoutOverflow) {
    EXPECT_EQ(window_side(0, 0, "data window"), 1);
    EXPECT_EQ(window_side(-4, 3, "data window"), 8);
    EXPECT_EQ(window_side(0, std::numeric_limits<int>::max() - 1, "display window"), std::numeric_limits<int>::max());
    const auto message = [](int min, int max) {
        try {
            window_side(min, max, "display window");
        } catch (const std::runtime_error& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_EQ(message(std::numeric_limits<int>::min(), std::numeric_limits<int>::max()),
              "display window -2147483648..2147483647 is empty or too large");
    EXPECT_EQ(message(-1, std::numeric_limits<int>::max() - 1), "display window -1..2147483646 is empty or too large");
    EXPECT_EQ(message(5, 4), "display window 5..4 is empty or too large");
    EXPECT_EQ(message(std::numeric_limits<int>::max(), std::numeric_limits<int>::min()),
              "display window 2147483647..-2147483648 is empty or too large");
}

TEST(MemoryBudget, GhostTablesOfManySurfaces) {
    const fs::path dir = scratch_dir("memory-lens");
    auto system_of = [&](int surfaces) { return optics::realize(optics::load_lens(make_many_surface_lens(dir, surfaces).string())); };
    const optics::System small = system_of(21), large = system_of(101), huge = system_of(301);
    const double a = gpu::ghost_table_bytes(small, 3), b = gpu::ghost_table_bytes(large, 3), c = gpu::ghost_table_bytes(huge, 3);
    EXPECT_LT(a, 64e6);
    EXPECT_LT(b, 0.5e9);  // 5.5 GB measured for 100 surfaces before the tables were shared
    EXPECT_GT(c / b, 20.0);
    EXPECT_EQ(refusal([&] { gpu::check_ghost_tables(small, 3, MemoryBudget{kGiB}); }), "");
    EXPECT_EQ(refusal([&] { gpu::check_ghost_tables(huge, 3, MemoryBudget{4 * kGiB}); }), "");  // drawn in part
    const std::string message = refusal([&] { gpu::check_ghost_tables(huge, 3, MemoryBudget{kGiB / 8}); });
    EXPECT_NE(message.find("ghosts of its 301 surfaces"), std::string::npos) << message;
    EXPECT_NE(message.find("over half the memory limit of 134 MB"), std::string::npos) << message;
    fs::remove_all(dir);
}

// Display formats are converted a strip of rows at a time: the strips give exactly what the whole
// image quantised at once gives, dither included.
TEST(MemoryBudget, PngWrittenInStripsEqualsWholeImage) {
    const fs::path dir = scratch_dir("memory-png");
    const int w = 37, h = 700;  // more than two strips, the last one short
    std::vector<float> px(static_cast<std::size_t>(w) * h * 3);
    for (std::size_t i = 0; i < px.size(); ++i) px[i] = static_cast<float>((i * 7919) % 1000) / 999.0f;
    filter::Frame frame = filter::image_frame(w, h, 3, filter::PixelType::float32, px.data());
    frame.index = 5;
    filter::WriteOptions options;
    options.memory = MemoryBudget{std::size_t{1} << 20};
    filter::write_image(frame, (dir / "out.png").string(), options);
    const std::vector<std::uint8_t> expected = colour::quantise8({px.data(), static_cast<std::size_t>(w), static_cast<std::size_t>(h), 3, 0},
                                                                 options.dither, frame.index);
    auto in = OIIO::ImageInput::open((dir / "out.png").string());
    ASSERT_TRUE(in);
    std::vector<std::uint8_t> got(expected.size());
    ASSERT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeUInt8, got.data()));
    EXPECT_EQ(got, expected);
    // The 8-bit image (78 KB) is never held whole: it is streamed to the writer a strip at a time, so a
    // 64 KB budget writes the same file.
    options.memory = MemoryBudget{std::size_t{64} << 10};
    EXPECT_EQ(refusal([&] { filter::write_image(frame, (dir / "small.png").string(), options); }), "");
    auto small = OIIO::ImageInput::open((dir / "small.png").string());
    ASSERT_TRUE(small);
    std::vector<std::uint8_t> again(expected.size());
    ASSERT_TRUE(small->read_image(0, 0, 0, 3, OIIO::TypeUInt8, again.data()));
    EXPECT_EQ(again, expected);
    fs::remove_all(dir);
}

// A 2 KB EXR declaring a 30000 x 30000 display window: a pass-through stays small (the display window is
// never materialised), a flare over it is refused by the budget before anything is allocated, and so is a
// PFM output (PFM has no windows: the display window would be written whole).
TEST(MemoryBudgetEndToEnd, HugeDisplayWindowOfATinyFile) {
    const fs::path dir = scratch_dir("memory-window");
    make_windowed_exr(dir / "in.exr", 8, 30000);
    ASSERT_LT(fs::file_size(dir / "in.exr"), 4096u);
    const std::string in = quoted(dir / "in.exr");
    const auto pass = run(lensfx_cmd() + fmt::format(" -i {} -o {} --memory-limit 16M", in, quoted(dir / "pass.exr")));
    ASSERT_EQ(pass.exit_code, 0) << pass.stderr_text;
    const filter::Frame out = filter::read_image((dir / "pass.exr").string());
    EXPECT_EQ(out.spec.full_width, 30000);
    EXPECT_EQ(out.spec.width, 8);
    expect_one_line(run(lensfx_cmd() + fmt::format(" -i {} -o {} --lens cooke-triplet --memory-limit 4G", in, quoted(dir / "flare.exr"))),
                    "frame 1: the flare over the 30000x30000 display window needs");
    expect_one_line(run(lensfx_cmd() + fmt::format(" -i {} -o {} --memory-limit 1G", in, quoted(dir / "out.pfm"))),
                    "PFM output of the 30000x30000 display window needs 11 GB, over the memory limit of 1.1 GB");
    EXPECT_EQ(file_count(dir), 2u);  // nothing written by the refused runs
    fs::remove_all(dir);
}

// A frame whose float R, G, B copy would take it over the limit is refused before the copy is made, in one line
// naming the frame and the limit (before, an 8K half frame under 300M reached 710 MB: copied, its lights found,
// and only then refused by the flare's own check).
TEST(MemoryBudgetEndToEnd, AFrameIsRefusedBeforeItsFloatCopyOutgrowsTheLimit) {
    const fs::path dir = scratch_dir("memory-float-copy");
    make_windowed_exr(dir / "in.exr", 2048, 2048);  // 25 MB as half, 50 MB more as float
    const std::string in = quoted(dir / "in.exr");
    expect_one_line(run(lensfx_cmd() + fmt::format(" -i {} -o {} --lens cooke-triplet --memory-limit 40M", in, quoted(dir / "out.exr"))),
                    "frame 1: the 2048x2048 frame as float R, G, B needs 75 MB, over the memory limit of 42 MB");
    EXPECT_EQ(file_count(dir), 1u);  // nothing written
    fs::remove_all(dir);
}

// 1e6 x 1e6 windows: the default budget (half of any machine) refuses a flare over the display window; a
// header whose data window is that large is refused before its pixels are allocated.
TEST(MemoryBudgetEndToEnd, MillionPixelWindows) {
    const fs::path dir = scratch_dir("memory-million");
    make_windowed_exr(dir / "display.exr", 8, 1000000);
    expect_one_line(run(lensfx_cmd() + fmt::format(" -i {} -o {} --lens cooke-triplet", quoted(dir / "display.exr"), quoted(dir / "o.exr"))),
                    "the flare over the 1000000x1000000 display window needs");
    const auto pass = run(lensfx_cmd() + fmt::format(" -i {} -o {}", quoted(dir / "display.exr"), quoted(dir / "pass.exr")));
    EXPECT_EQ(pass.exit_code, 0) << pass.stderr_text;

    // The data window's bounds patched in the header of a 4 x 4 file: 1000000 x 1000000 declared.
    make_windowed_exr(dir / "data.exr", 4, 16);
    std::stringstream read;
    read << std::ifstream(dir / "data.exr", std::ios::binary).rdbuf();
    std::string bytes = read.str();
    const std::string attribute("dataWindow\0box2i\0", 17);
    const auto at = bytes.find(attribute);
    ASSERT_NE(at, std::string::npos);
    const std::int32_t window[4] = {0, 0, 999999, 999999};
    std::memcpy(bytes.data() + at + attribute.size() + 4, window, sizeof window);
    std::ofstream(dir / "data.exr", std::ios::binary) << bytes;
    const auto r = run(lensfx_cmd() + fmt::format(" -i {} -o {} --memory-limit 1G", quoted(dir / "data.exr"), quoted(dir / "d.exr")));
    expect_one_line(r, "data.exr: frame 1: ");
    fs::remove_all(dir);
}

// Stream headers and --size are sized before a byte is allocated.
TEST(MemoryBudgetEndToEnd, StreamSizes) {
    expect_one_line(run(": | " + lensfx_cmd() + " -i - -o - --pix-fmt gbrpf32le --size 99999x99999 --memory-limit 4G > /dev/null"),
                    "stdin: frame 1: a 99999x99999 gbrpf32le frame (--size) needs 120 GB, over the memory limit of 4.3 GB");
    expect_one_line(run("printf 'PF\\n65536 65536\\n-1.0\\n' | " + lensfx_cmd() + " -i - -o - --memory-limit 1G > /dev/null"),
                    "stdin: frame 1: a 65536x65536 PFM image needs 52 GB");
}

// A lens of 300 surfaces whose ghost list alone (some 0.3 GB) exceeds the limit: refused at the start, in
// one line naming the lens and the limit, by the filter and by `lensfx flare`; the bad value of the
// option itself is one line too.
TEST(MemoryBudgetEndToEnd, LensOfManySurfaces) {
    const fs::path dir = scratch_dir("memory-lens-e2e");
    const fs::path lens = make_many_surface_lens(dir, 301);
    make_windowed_exr(dir / "in.exr", 8, 16);
    expect_one_line(run(lensfx_cmd() + fmt::format(" -i {} -o {} --lens {} --memory-limit 128M", quoted(dir / "in.exr"),
                                                   quoted(dir / "out.exr"), quoted(lens))),
                    "ghosts of its 301 surfaces");
    expect_one_line(run(lensfx_cmd() + fmt::format(" flare --lens {} --angle 5,0 -o {} --memory-limit 128M", quoted(lens), quoted(dir / "f.exr"))),
                    "lens plates and a triplet: even the list of the");
    expect_one_line(run(lensfx_cmd() + fmt::format(" flare --lens cooke-triplet --angle 5,0 --size 16384x16384 -o {} --memory-limit 1G",
                                                   quoted(dir / "f.exr"))),
                    "a 16384x16384 flare image needs");
    expect_one_line(run(lensfx_cmd() + fmt::format(" -i {} -o {} --memory-limit 4X", quoted(dir / "in.exr"), quoted(dir / "o.exr"))),
                    "--memory-limit: must be a size such as 4G, 512M or none, not \"4X\"");  // a usage error (exit 2)
    fs::remove_all(dir);
}

// A lens whose ghost data does not fit half the limit but whose list does is drawn with its brightest
// ghosts, with one warning saying how many and what share of the power was left out.
TEST(MemoryBudgetEndToEnd, LensOfManySurfacesFitsWithItsBrightestGhosts) {
    const fs::path dir = scratch_dir("memory-lens-fit");
    const fs::path lens = make_many_surface_lens(dir, 41);
    const auto r = run(fmt::format("LENSFX_CACHE_DIR={} ", quoted(dir / "cache")) + lensfx_cmd() +
                       fmt::format(" flare --lens {} --angle 5,3 --size 64x48 --grid 8 -o {} --memory-limit 6M", quoted(lens), quoted(dir / "f.exr")));
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find("brightest ghosts"), std::string::npos) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find("% of that power"), std::string::npos) << r.stderr_text;
    EXPECT_TRUE(fs::exists(dir / "f.exr"));
    fs::remove_all(dir);
}

// A stage that keeps `bytes` of its own buffers (as the flare stage keeps its GL targets) and takes a
// while on each frame, so that a reader not held back by those bytes would read ahead meanwhile.
class KeepsBuffers : public filter::Stage {
public:
    explicit KeepsBuffers(std::size_t bytes) : bytes_(bytes) {}
    std::string_view name() const override { return "keeps"; }
    void process(filter::Frame&) override { std::this_thread::sleep_for(std::chrono::milliseconds(40)); }
    std::size_t held_bytes(const filter::ImageSpec&) const override { return bytes_; }

private:
    std::size_t bytes_;
};

// The pipeline counts a stage's own buffers with the frames in flight: under a limit that holds one 64 x 64
// frame (24 KB of half pixels and 48 KB as float) with the stage's 100 KB, but not two frames with them,
// the most ever held counts the stage's bytes and stays within the limit (the reader waits); so does a
// run bounded by the in-flight limit alone (the filter's default when no --memory-limit is given).
TEST(MemoryBudgetEndToEnd, SequenceCountsTheStagesBuffers) {
    const fs::path dir = scratch_dir("memory-stage-buffers");
    for (int i = 1; i <= 4; ++i) make_windowed_exr(dir / fmt::format("in.{:04d}.exr", i), 64, 64);
    constexpr std::size_t kFrame = 64 * 64 * (6 + 12), kStage = 100000;
    KeepsBuffers stage(kStage);
    filter::PipelineOptions o;
    o.input = (dir / "in.####.exr").string();
    o.output = (dir / "out.####.exr").string();
    o.quiet = true;
    o.queue_depth = 3;
    o.memory.limit = 200000;
    const filter::RunReport limited = filter::run_pipeline(o, {&stage});
    EXPECT_EQ(limited.written(), 4u);
    EXPECT_GE(limited.peak_held_bytes, kFrame + kStage);
    EXPECT_LE(limited.peak_held_bytes, o.memory.limit);

    o.memory.limit = 0;  // none: the in-flight limit alone bounds what is held
    o.in_flight_limit = 200000;
    const filter::RunReport in_flight = filter::run_pipeline(o, {&stage});
    EXPECT_EQ(in_flight.written(), 4u);
    EXPECT_GE(in_flight.peak_held_bytes, kFrame + kStage);
    EXPECT_LE(in_flight.peak_held_bytes, o.in_flight_limit);
    fs::remove_all(dir);
}

// A sequence under a limit that holds one frame but not two runs with the reader waiting for the writer
// (no deadlock), and writes what an unlimited run writes.
TEST(MemoryBudgetEndToEnd, SequenceFitsALimitOfOneFrame) {
    const fs::path dir = scratch_dir("memory-sequence");
    for (int i = 1; i <= 4; ++i) make_windowed_exr(dir / fmt::format("in.{:04d}.exr", i), 64, 64);
    // A frame: 64 x 64 half RGB (24 KB) and its float R, G, B (48 KB).
    const std::string in = quoted(dir / "in.####.exr");
    const auto r = run(lensfx_cmd() + fmt::format(" -i {} -o {} --exposure 1 --memory-limit 100K --queue-depth 3", in, quoted(dir / "a.####.exr")));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    ASSERT_EQ(run(lensfx_cmd() + fmt::format(" -i {} -o {} --exposure 1 --memory-limit none", in, quoted(dir / "b.####.exr"))).exit_code, 0);
    for (int i = 1; i <= 4; ++i)
        EXPECT_EQ(compare_images((dir / fmt::format("b.{:04d}.exr", i)).string(), (dir / fmt::format("a.{:04d}.exr", i)).string()), "");
    // A limit below one frame: refused by the reader, naming the frame.
    expect_one_line(run(lensfx_cmd() + fmt::format(" -i {} -o {} --memory-limit 16K", in, quoted(dir / "c.####.exr"))),
                    "in.0001.exr: frame 1: its 64x64 data window with 3 channels needs");
    fs::remove_all(dir);
}
