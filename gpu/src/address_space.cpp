// The address space a render needs (see gpu/address_space.h).
#include <gpu/address_space.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>

#include <fmt/core.h>
#include <optics/memory_budget.h>
#include <sys/resource.h>

namespace lensfx::gpu {

namespace {

constexpr std::size_t kMiB = std::size_t{1} << 20;
// CandleGlass.exr's flare with its threads sharing one arena (filter/process_heap.h), `ulimit -v` swept in
// 32 MiB steps on 2 cores: it ran at 512 MiB and failed at 480; with 16 llvmpipe threads (LP_NUM_THREADS) at
// 704 and not at 672; with 16 of them and 16 decoding threads (--threads 16, as 16 cores would have) at 832 and
// not at 768: about 485 MiB and 23 MiB per core. This rounds both up.
constexpr std::size_t kBaseBytes = 512 * kMiB;
constexpr std::size_t kPerThreadBytes = 24 * kMiB;  // an llvmpipe thread and a decoding thread
constexpr int kMesaMaxThreads = 32;                  // LP_MAX_THREADS
// Names the LP_NUM_THREADS value lensfx set itself (set_default_llvmpipe_threads), so that a child does not take
// it for the user's.
constexpr const char* kDefaultThreadsMark = "LENSFX_DEFAULT_LP_NUM_THREADS";

}  // namespace

std::size_t address_space_needed(int threads) {
    return kBaseBytes + kPerThreadBytes * static_cast<std::size_t>(std::max(threads, 0));
}

int llvmpipe_threads() {
    if (const char* env = std::getenv("LP_NUM_THREADS"); env && *env) {
        int n = 0;
        const auto [end, ec] = std::from_chars(env, env + std::strlen(env), n);
        if (ec == std::errc{} && *end == '\0' && n >= 0) return std::min(n, kMesaMaxThreads);
    }
    return std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, kMesaMaxThreads);
}

int default_llvmpipe_threads() {
    return std::clamp(static_cast<int>(std::thread::hardware_concurrency()) + 2, 1, kMesaMaxThreads);
}

void set_default_llvmpipe_threads() {
    const char* set = std::getenv("LP_NUM_THREADS");
    const char* ours = std::getenv(kDefaultThreadsMark);
    // A value the user gave stays; one a parent lensfx set for its own machine and its children inherited (a
    // farm job through sbatch, which exports the environment) is replaced by this machine's.
    if (set && !(ours && std::strcmp(set, ours) == 0)) return;
    const std::string threads = std::to_string(default_llvmpipe_threads());
    ::setenv("LP_NUM_THREADS", threads.c_str(), 1);
    ::setenv(kDefaultThreadsMark, threads.c_str(), 1);
}

void require_address_space() {
    rlimit limit{};
    if (getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return;
    const int threads = llvmpipe_threads();
    const std::size_t needed = address_space_needed(threads);
    if (limit.rlim_cur >= needed) return;
    throw std::runtime_error(fmt::format(
        "the address space is limited to {} MiB (ulimit -v {}), under the {} MiB a render needs here ({} GL threads): "
        "below it the GL driver and FFTW abort instead of failing; raise ulimit -v",
        limit.rlim_cur / kMiB, limit.rlim_cur / 1024, needed / kMiB, threads));
}

void require_cgroup_memory(double cgroup_limit) {
    if (!(cgroup_limit > 0.0) || cgroup_limit >= static_cast<double>(kContextMemoryFloor)) return;
    throw std::runtime_error(fmt::format(
        "the memory limit of this process's cgroup is {} MiB, under the {} MiB a GL context needs to start: below it the "
        "kernel ends the process while the driver loads; give the job more memory (sbatch --mem, systemd MemoryMax)",
        static_cast<std::size_t>(cgroup_limit) / kMiB, kContextMemoryFloor / kMiB));
}

void require_cgroup_memory() { require_cgroup_memory(cgroup_memory_limit()); }

}  // namespace lensfx::gpu
