// The address space and the memory a render needs at the least. Under a lower `ulimit -v` (RLIMIT_AS), Mesa's llvmpipe
// aborts the process from its JIT ("LLVM ERROR: Unable to allocate section memory"), crashes in the code it
// generated, or fails to open libGL, and FFTW aborts when its malloc fails: none of them reports an error
// that could become one `lensfx:` line. So a render checks the limit before it starts.
#pragma once

#include <cstddef>

namespace lensfx::gpu {

// The least address space, in bytes, of a process that renders with `threads` llvmpipe threads (LP_NUM_THREADS,
// else one per core) and as many decoding threads. Measured on CandleGlass.exr (1000x810, dgauss 50 mm, 85
// ghosts; docs/DESIGN.md's Memory section): a base and a part per thread, with a margin; bigger frames need more,
// which --memory-limit bounds.
std::size_t address_space_needed(int threads);

// llvmpipe's thread count: LP_NUM_THREADS when set, else the cores (at most Mesa's 32).
int llvmpipe_threads();

// The rasteriser and compute threads lensfx gives llvmpipe where the user did not (LP_NUM_THREADS): the cores and
// two more, at most Mesa's 32. With one a core, a core idles whenever the main thread bins the next scene or
// waits for a dispatch, and a thread whose tiles are done waits for the slowest (2 cores, hyperfine, 10 runs:
// canon-70-200 on the 1080p stage frame 1.16 -> 1.10 s, CandleGlass 0.53 -> 0.51 s; --no-scene-cull the same).
int default_llvmpipe_threads();
// Sets LP_NUM_THREADS to default_llvmpipe_threads() unless the user set it (a value a parent lensfx set, marked
// in LENSFX_DEFAULT_LP_NUM_THREADS and inherited, e.g. by a farm job through sbatch, is this machine's default
// again). Call first thing in main, before any other thread runs (setenv) and before the GL driver is loaded (it
// reads the variable once).
void set_default_llvmpipe_threads();

// Throws std::runtime_error naming the limit, the need and `ulimit -v` when the process's address space is
// limited below address_space_needed(llvmpipe_threads()); returns at once when it is not limited.
void require_address_space();

// The least cgroup memory limit under which a GL context starts: below it the kernel's OOM killer ends the process
// (exit 137, no message) while the driver loads. Mesa's llvmpipe on a 64x36 frame, a v1 child cgroup's
// memory.limit_in_bytes swept (docs/DESIGN.md's Memory section): with the page cache cold it ran at 72 MiB and was
// killed at 64; warm at 60 and not at 56 (its libraries were charged elsewhere). This adds a third.
inline constexpr std::size_t kContextMemoryFloor = std::size_t{96} << 20;

// Throws std::runtime_error naming the limit and the floor when `cgroup_limit` (bytes; 0: none) is under
// kContextMemoryFloor. The other form checks this process's (cgroup_memory_limit).
void require_cgroup_memory(double cgroup_limit);
void require_cgroup_memory();

}  // namespace lensfx::gpu
