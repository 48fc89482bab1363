// glibc's malloc tuned for a program whose big allocations are frames and render targets of a few tens of MB.
//
// By default glibc serves every block over 32 MiB (and, until its threshold adapts, over 128 KiB) from a mapping
// of its own, given back at free(). Each new frame-sized buffer then takes a page fault per 4 KiB on first
// touch, in our code and in Mesa's llvmpipe, which zero-fills every texture it makes: about a quarter of the
// main thread's time on a 1080p frame, and far more on virtual machines, where a fault costs more. Served from
// one heap advised to use 2 MiB pages, a 33 MB target takes 16 faults instead of 8,100, and a block freed after
// one frame is reused by the next without faulting again (canon-70-200 on a 1080p frame: 47,700 page faults
// before, 11,100 after). Every thread allocates from that one heap: glibc would give each new thread (the
// reader, OpenEXR's and llvmpipe's workers) an arena of its own, mapped in 4 KiB pages that no one advised, and
// CandleGlass.exr took 4,800 of its 9,900 faults there (about 11 us each on a virtual machine: 50 ms of CPU,
// most of it on the read's critical path). What the heap keeps is bounded: blocks of 32 MiB and more that its
// top cannot hold (8K frames and bands) stay mappings of their own, given back at free, and the heap gives back
// what is free at its top above 288 MiB. bench_memory's 8K sequence peaks at 1.96 GB against 1.89 untuned; with
// 512 MiB kept for good it was 2.20 GB, with 256 MiB reserved 2.11 GB.
#include <filter/process_heap.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>

#if defined(__GLIBC__)
#include <malloc.h>
#include <sys/mman.h>
#include <sys/resource.h>
#endif

namespace lensfx::filter {

namespace {

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)  // under ASan tune_process_heap uses none of these
constexpr std::size_t kReserve = std::size_t{192} << 20;    // heap advised for huge pages up front: a 1080p job's peak heap
constexpr std::size_t kHugePage = std::size_t{2} << 20;     // x86-64's and arm64's (4 KiB granule) THP size
constexpr int kTopPad = 64 << 20;                            // each heap growth at least this much
constexpr int kHeapBlockLimit = 32 << 20;  // glibc's largest mmap threshold: a 1080p RGBA float target fits under it
constexpr int kDefaultMmapMax = 65536;     // glibc's default M_MMAP_MAX
// The heap gives memory back only when more than this is free at its top: more than the reservation and its
// pad, so that a 1080p job never shrinks it; an 8K frame's freed buffers do.
constexpr int kTrimThreshold = 288 << 20;

// A capped address space or data segment: every thread's arena (64 MiB of address space each, one per thread
// up to 8 a core) counts against it.
bool memory_is_capped() {
    rlimit as{}, data{};
    return (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY) || (getrlimit(RLIMIT_DATA, &data) == 0 && data.rlim_cur != RLIM_INFINITY);
}

// Why the heap is better left alone here, or "".
std::string reason_to_leave_heap() {
    if (std::getenv("LENSFX_SYSTEM_HEAP") != nullptr) return "LENSFX_SYSTEM_HEAP is set";
    rlimit as{};
    // A capped address space (ulimit -v) would be charged the reservation and never get it back.
    if (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY) return "the address space is limited (ulimit -v)";
    rlimit data{};
    // So is a capped data segment (ulimit -d): the heap and its pad count against it even while unused.
    if (getrlimit(RLIMIT_DATA, &data) == 0 && data.rlim_cur != RLIM_INFINITY) return "the data segment is limited (ulimit -d)";
    int overcommit = 0;
    // Strict overcommit (mode 2) commits the reserved heap as if it were used.
    if (std::ifstream("/proc/sys/vm/overcommit_memory") >> overcommit; overcommit == 2) return "strict overcommit (vm.overcommit_memory = 2)";
    return "";
}

// Grows the heap by kReserve, advises its whole 2 MiB pages to be huge, and frees it back into the heap's top:
// later blocks are carved from there. Untouched, it costs address space, not memory.
void reserve_huge_page_heap() {
    void* block = std::malloc(kReserve);
    if (block == nullptr) return;
    const auto start = reinterpret_cast<std::uintptr_t>(block);
    const std::uintptr_t first = (start + kHugePage - 1) & ~(kHugePage - 1);
    const std::uintptr_t last = (start + kReserve) & ~(kHugePage - 1);
    if (last > first) madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);  // no THP: harmless EINVAL
    std::free(block);
}
#endif

}  // namespace

HeapTuning tune_process_heap() {
#if defined(__SANITIZE_ADDRESS__)
    return {false, "AddressSanitizer's allocator"};  // it replaces malloc: nothing here would apply
#elif defined(__GLIBC__)
    if (std::string why = reason_to_leave_heap(); !why.empty()) {
        // Under a cap, the threads still share one arena: CandleGlass.exr's flare then runs in 0.5 GiB of address
        // space instead of 1.06 (llvmpipe's 16 threads: 0.69 instead of 1.56; docs/DESIGN.md, Memory).
        const bool one_arena = memory_is_capped() && mallopt(M_ARENA_MAX, 1) == 1;
        return {false, why, one_arena};
    }
    mallopt(M_TRIM_THRESHOLD, kTrimThreshold);  // a freed frame is the next frame's memory, unless it is huge
    mallopt(M_ARENA_MAX, 1);               // worker threads' blocks from this heap too (small ones stay in tcache)
    mallopt(M_TOP_PAD, kTopPad);
    mallopt(M_MMAP_MAX, 0);                // the reservation itself from the heap
    reserve_huge_page_heap();
    mallopt(M_MMAP_MAX, kDefaultMmapMax);
    mallopt(M_MMAP_THRESHOLD, kHeapBlockLimit);  // bigger blocks (4K, 8K) stay mappings given back at free
    return {true, "", true};
#else
    return {false, "not glibc"};
#endif
}

}  // namespace lensfx::filter
