// glibc's malloc tuned for a program whose big allocations are frames and render targets of a few tens of MB.
//
// By default glibc serves every block over 32 MiB (and, until its threshold adapts, over 128 KiB) from a mapping
// of its own, given back at free(). Each new frame-sized buffer then faults in again on first touch, in our code
// and in Mesa's llvmpipe, which zero-fills every texture it makes. Here every frame-sized block comes from the
// one heap, and a block freed after one frame is reused by the next without faulting again. Every thread
// allocates from that heap: glibc would give each new thread (the reader, OpenEXR's and llvmpipe's workers) an
// arena of its own, and CandleGlass.exr took 4,800 of its 9,900 faults there, most of them on the read's
// critical path. What the heap keeps is bounded: blocks of 32 MiB and more that its top cannot hold (8K frames
// and bands) stay mappings of their own, given back at free, and the heap gives back what is free at its top
// above 288 MiB.
//
// The heap's first 192 MiB (what a 1080p job's heap holds at its peak) are reserved up front and advised to use
// 4 KiB pages (MADV_NOHUGEPAGE), whatever the kernel's default for transparent huge pages. Which page size is
// faster depends on the virtual machine, and the choice has turned three times (huge pages until the twentieth
// stop, 4 KiB pages until the twenty-fourth, huge pages until the thirty-first, 4 KiB pages since):
// - the twentieth stop's machine, whose balloon reported free memory to its host: a cold 2 MiB page made again
//   by the host on first touch at about 0.5 GB/s against 2.6 GB/s for 4 KiB pages (canon-70-200 on a 1080p
//   frame run 3 s after the last: 1.22 s with huge pages, 1.09 s without);
// - the twenty-first to twenty-fourth stops' machines: a 4 KiB page's first touch cost 12 us (0.28 GB/s) and
//   a huge page 59 ms per 32 MiB cold, 2.6 ms when the host had made it a few seconds before: canon-70-200
//   culled on a 1080p frame 1.570 -> 1.415 s with huge pages;
// - the thirty-first stop's machine (bench_page_touch, 3 s between trials): 4 KiB pages 0.43-0.55 ms a MiB
//   touched and 0.26-0.34 populated, huge pages 2.7-4.1 ms a MiB cold (6-8 times slower) and 0.15-0.21 only
//   when freed moments before (by this process or another). canon-70-200 culled on a 1080p frame: 1.70 -> 1.34 s
//   run 3 s after the last, 1.64 -> 1.36 s back to back (docs/benchmarks.md, thirty-first stop).
// bench_page_touch says which holds on a machine in a minute.

#include <filter/process_heap.h>

#include <optics/memory_budget.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <system_error>

#if defined(__GLIBC__)
#include <malloc.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace lensfx::filter {

namespace {

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)  // under ASan tune_process_heap uses none of these
constexpr std::size_t kReserve = std::size_t{192} << 20;    // heap advised for 4 KiB pages up front: a 1080p job's peak heap
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
    // A capped address space (ulimit -v) would be charged the heap's pad and the freed memory it keeps.
    if (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY) return "the address space is limited (ulimit -v)";
    rlimit data{};
    // So is a capped data segment (ulimit -d): the heap and its pad count against it even while unused.
    if (getrlimit(RLIMIT_DATA, &data) == 0 && data.rlim_cur != RLIM_INFINITY) return "the data segment is limited (ulimit -d)";
    int overcommit = 0;
    // Strict overcommit (mode 2) commits the heap's pad as if it were used.
    if (std::ifstream("/proc/sys/vm/overcommit_memory") >> overcommit; overcommit == 2) return "strict overcommit (vm.overcommit_memory = 2)";
    return "";
}

// The kernel's page size (4 KiB on x86-64), asked once.
std::uintptr_t page_size() {
    static const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
    return page;
}

// The end of the heap (the program break, down to a page), asked of the kernel: glibc's copy is not for other threads.
std::uintptr_t program_break() {
    return static_cast<std::uintptr_t>(syscall(SYS_brk, 0)) & ~(page_size() - 1);
}

// Hands [from, to) (whole pages) back to the kernel: the next touch faults in a zeroed page.
void drop_pages(std::uintptr_t from, std::uintptr_t to) {
    if (to > from) madvise(reinterpret_cast<void*>(from), to - from, MADV_DONTNEED);
}

// Grows the heap by kReserve (and the pad), advises it, pad included, to use 4 KiB pages and frees it back into
// the heap's top, where later blocks are carved from. Untouched, it costs address space, not memory. True when the
// kernel took the advice (false where it has no transparent huge pages to advise against). What the heap grows by
// later (beyond 256 MiB: frames over 32 MiB are mappings of their own) is not advised.
bool reserve_small_page_heap() {
    mallopt(M_MMAP_MAX, 0);  // the reservation itself from the heap
    void* block = std::malloc(kReserve);
    mallopt(M_MMAP_MAX, kDefaultMmapMax);
    if (block == nullptr) return false;
    const std::uintptr_t page = page_size();
    const auto start = reinterpret_cast<std::uintptr_t>(block);
    const std::uintptr_t first = (start + page - 1) & ~(page - 1);
    const std::uintptr_t end = start + kReserve, brk = program_break();
    // up to the break when the block ends the heap there (its pad after it), else the block alone
    const bool ends_heap = end <= brk && brk - end <= static_cast<std::uintptr_t>(kTopPad) + page;
    const std::uintptr_t last = ends_heap ? brk : end & ~(page - 1);
    const bool advised = last > first && madvise(reinterpret_cast<void*>(first), last - first, MADV_NOHUGEPAGE) == 0;
    // Where the kernel gives huge pages to all memory ("always"), malloc's writes of the chunk headers at the
    // block's two ends were first touches of whole huge pages, made before the advice: handed back, they fault in
    // again as 4 KiB pages. The block is ours and unwritten; the pad is dropped past the top chunk's header at `end`.
    if (advised) {
        drop_pages(first, end & ~(page - 1));
        if (ends_heap) drop_pages((end + 2 * sizeof(std::size_t) + page - 1) & ~(page - 1), brk);
    }
    std::free(block);
    return advised;
}

#endif

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LENSFX_UNDER_ASAN 1  // clang before 22 does not define __SANITIZE_ADDRESS__
#endif
#endif

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__) && !defined(LENSFX_UNDER_ASAN)
#define LENSFX_HEAP_WARMER 1
#if !defined(MADV_POPULATE_WRITE)
#define MADV_POPULATE_WRITE 23  // Linux 5.14; older glibc headers lack it, older kernels answer EINVAL
#endif
// Made resident per call: short, so that the mmap lock the call holds is let go often, and the thread can stop between.
constexpr std::size_t kWarmStep = std::size_t{256} << 10;
// How often the heap's end is looked at: soon after it grew (a frame's buffers come one after another), less
// and less often while it does not (a sequence's later frames reuse the first's memory).
constexpr auto kWarmPollFirst = std::chrono::milliseconds(2);
constexpr auto kWarmPollLast = std::chrono::milliseconds(64);

// Makes [from, to) resident, kWarmStep at a time, until stopped; `from` ends where it got to. False when the
// kernel refuses for good (no MADV_POPULATE_WRITE: EINVAL); a range unmapped meanwhile (the heap trimmed) is left.
bool make_resident(std::uintptr_t& from, std::uintptr_t to, const std::stop_token& stop, std::atomic<std::size_t>& warmed) {
    while (from < to && !stop.stop_requested()) {
        const std::size_t n = std::min<std::size_t>(kWarmStep, to - from);
        if (madvise(reinterpret_cast<void*>(from), n, MADV_POPULATE_WRITE) != 0) {
            if (errno != ENOMEM && errno != EAGAIN && errno != EINTR) return false;
            from = to;
            return true;
        }
        from += n;
        warmed.fetch_add(n, std::memory_order_relaxed);
    }
    return true;
}

// The warmer's thread: whatever the heap grows by beyond `from` (the break at the start) made resident. At
// the normal priority: what it does the program would otherwise do in page faults, at several times the cost,
// and a thread at idle priority could be pre-empted holding the mmap lock that the program's brk and mmap wait for.
void warm_heap(const std::stop_token& stop, std::uintptr_t from, std::atomic<std::size_t>& warmed) {
    auto poll = kWarmPollFirst;
    while (!stop.stop_requested()) {
        const std::uintptr_t end = program_break();
        from = std::min(from, end);  // trimmed: what it grows by again is warmed again
        poll = from < end ? kWarmPollFirst : std::min(poll * 2, kWarmPollLast);
        if (!make_resident(from, end, stop, warmed)) return;
        std::this_thread::sleep_for(poll);
    }
}
#endif

}  // namespace

HeapWarmer::HeapWarmer([[maybe_unused]] const HeapTuning& tuning) {
#if defined(LENSFX_HEAP_WARMER)
    // Under a cgroup's memory limit, memory made resident but never used could take the run over it.
    if (!tuning.tuned || cgroup_memory_limit() > 0.0) return;
    const std::uintptr_t from = program_break();
    warmed_ = std::make_shared<std::atomic<std::size_t>>(0);
    try {
        thread_ = std::jthread([from, warmed = warmed_](std::stop_token stop) { warm_heap(stop, from, *warmed); });
    } catch (const std::system_error&) {  // no thread to be had (a limit on threads): nothing is warmed
    }
#endif
}

HeapWarmer::~HeapWarmer() {
    if (!thread_.joinable()) return;
    thread_.request_stop();
    thread_.detach();
}

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
    const bool small_pages = reserve_small_page_heap();
    mallopt(M_MMAP_THRESHOLD, kHeapBlockLimit);  // bigger blocks (4K, 8K) stay mappings given back at free
    return {true, "", true, small_pages};
#else
    return {false, "not glibc"};
#endif
}

}  // namespace lensfx::filter
