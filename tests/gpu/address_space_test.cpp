// The address space a render needs (gpu/address_space.h): the check refuses a limit under it in words naming the
// limit, and lets any limit at or above it, or none, pass. Each case runs in a child: RLIMIT_AS is the process's.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <thread>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/core.h>

#include <gpu/address_space.h>
#include <gpu/context.h>

namespace lensfx::gpu {
namespace {

// The exit status of a child that caps its address space at `bytes` and then runs the check: 0 when it passed,
// 1 when it refused naming ulimit -v, 2 when it refused otherwise.
int check_under(std::size_t bytes) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        const rlimit limit{bytes, bytes};
        if (::setrlimit(RLIMIT_AS, &limit) != 0) ::_exit(3);
        try {
            require_address_space();
        } catch (const std::runtime_error& e) {
            ::_exit(std::string(e.what()).find("ulimit -v") != std::string::npos ? 1 : 2);
        }
        ::_exit(0);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 100;
}

TEST(AddressSpace, TheNeedGrowsWithTheThreads) {
    EXPECT_LT(address_space_needed(2), address_space_needed(16));
    EXPECT_GE(address_space_needed(2), std::size_t{512} << 20) << "CandleGlass.exr's flare ran at 512 MiB, not at 480, on 2 threads";
    EXPECT_GE(address_space_needed(16), std::size_t{832} << 20) << "with 16 llvmpipe and 16 decoding threads: ran at 832, not at 768";
}

TEST(AddressSpace, ALimitUnderTheNeedIsRefusedInWords) {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "AddressSanitizer's shadow memory needs terabytes of address space";
#endif
    const std::size_t need = address_space_needed(llvmpipe_threads());
    EXPECT_EQ(check_under(need - (std::size_t{1} << 20)), 1);
    EXPECT_EQ(check_under(need), 0);
    rlimit own{};
    if (::getrlimit(RLIMIT_AS, &own) == 0 && own.rlim_cur == RLIM_INFINITY) {
        EXPECT_NO_THROW(require_address_space()) << "no limit: nothing to check";
    }
}

// A cgroup memory limit under the floor a GL context needs is refused in words naming both; none, or one at the
// floor or above, passes.
TEST(AddressSpace, ACgroupLimitUnderTheContextFloorIsRefusedInWords) {
    const double mib = 1 << 20;
    try {
        require_cgroup_memory(64 * mib);
        ADD_FAILURE() << "a 64 MiB cgroup limit passed";
    } catch (const std::runtime_error& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("64 MiB"), std::string::npos) << what;
        EXPECT_NE(what.find(fmt::format("{} MiB", kContextMemoryFloor >> 20)), std::string::npos) << what;
        EXPECT_NE(what.find("cgroup"), std::string::npos) << what;
    }
    EXPECT_THROW(require_cgroup_memory(static_cast<double>(kContextMemoryFloor) - 4096), std::runtime_error);
    EXPECT_NO_THROW(require_cgroup_memory(0.0)) << "no limit";
    EXPECT_NO_THROW(require_cgroup_memory(static_cast<double>(kContextMemoryFloor)));
    EXPECT_NO_THROW(require_cgroup_memory(8.0 * 1024 * mib));
}

// A child cgroup limited to `bytes` (a v1 memory hierarchy, else v2 with the memory controller on for the root's
// children), or "" where this process may not make one (not root, cgroupfs read-only, no memory controller).
std::string limited_cgroup(std::size_t bytes) {
    namespace fs = std::filesystem;
    const std::string name = fmt::format("lensfx-test-{}", ::getpid());
    for (const auto& [root, limit_file] : {std::pair{"/sys/fs/cgroup/memory", "memory.limit_in_bytes"}, std::pair{"/sys/fs/cgroup", "memory.max"}}) {
        const fs::path dir = fs::path(root) / name;
        std::error_code ec;
        if (!fs::create_directory(dir, ec) || ec) continue;
        std::ofstream(dir / limit_file) << bytes;
        std::ifstream in(dir / limit_file);
        std::size_t set = 0;
        if (in >> set && set <= bytes && set > bytes / 2) return dir.string();
        fs::remove(dir, ec);
    }
    return "";
}

// The same in a real cgroup: a child moved into one limited to 64 MiB is refused a GL context in words before the
// driver loads; the kernel would otherwise end it (exit 137, no message) while llvmpipe starts.
TEST(AddressSpace, AContextInACgroupUnderTheFloorIsRefusedBeforeTheDriverLoads) {
    const std::string cgroup = limited_cgroup(std::size_t{64} << 20);
    if (cgroup.empty()) GTEST_SKIP() << "no child cgroup with a memory limit can be made here (needs root and a writable cgroupfs)";
    const pid_t pid = ::fork();
    if (pid == 0) {
        if (!(std::ofstream(cgroup + "/cgroup.procs") << 0)) ::_exit(3);
        try {
            Context context(Platform::Auto);
        } catch (const std::runtime_error& e) {
            ::_exit(std::string(e.what()).find("cgroup is 64 MiB") != std::string::npos ? 1 : 2);
        }
        ::_exit(0);
    }
    int status = 0;
    ::waitpid(pid, &status, 0);
    std::error_code ec;
    std::filesystem::remove(cgroup, ec);
    ASSERT_TRUE(WIFEXITED(status)) << "the child was killed (signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0) << ")";
    // A cgroup that cannot be joined (v2's rule that a cgroup with controllers on holds no processes, in a container)
    // tests nothing.
    if (WEXITSTATUS(status) == 3) GTEST_SKIP() << "the child could not join " << cgroup;
    EXPECT_EQ(WEXITSTATUS(status), 1) << "0: a context was made; 2: refused for another reason";
}

// lensfx's default llvmpipe threads (the cores and two more) are set where the user set none, a user's value
// kept, and the address-space check counts what is set.
TEST(AddressSpace, DefaultLlvmpipeThreadsAreSetUnlessTheUserSetThem) {
    const char* before = std::getenv("LP_NUM_THREADS");
    const std::string saved = before ? before : "";
    const char* mark_before = std::getenv("LENSFX_DEFAULT_LP_NUM_THREADS");
    const std::string mark_saved = mark_before ? mark_before : "";
    const int cores = static_cast<int>(std::thread::hardware_concurrency());
    EXPECT_EQ(default_llvmpipe_threads(), std::clamp(cores + 2, 1, 32));
    ::unsetenv("LP_NUM_THREADS");
    set_default_llvmpipe_threads();
    EXPECT_EQ(llvmpipe_threads(), default_llvmpipe_threads());
    ::setenv("LP_NUM_THREADS", "3", 1);
    set_default_llvmpipe_threads();
    EXPECT_STREQ(std::getenv("LP_NUM_THREADS"), "3");
    EXPECT_EQ(llvmpipe_threads(), 3);
    // What a parent lensfx on a machine of 33 cores set, inherited by a farm job here: this machine's default.
    ::setenv("LP_NUM_THREADS", "35", 1);
    ::setenv("LENSFX_DEFAULT_LP_NUM_THREADS", "35", 1);
    set_default_llvmpipe_threads();
    EXPECT_EQ(llvmpipe_threads(), default_llvmpipe_threads());
    if (before) ::setenv("LP_NUM_THREADS", saved.c_str(), 1);
    else ::unsetenv("LP_NUM_THREADS");
    if (mark_before) ::setenv("LENSFX_DEFAULT_LP_NUM_THREADS", mark_saved.c_str(), 1);
    else ::unsetenv("LENSFX_DEFAULT_LP_NUM_THREADS");
}

}  // namespace
}  // namespace lensfx::gpu
