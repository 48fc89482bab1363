// The program's heap set up for frame-sized buffers: glibc's malloc tuned once at start-up so that images and
// render targets come from the one heap and are kept for the next frame.
#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <string>
#include <thread>

namespace lensfx::filter {

// What tune_process_heap did, for --report and tests.
struct HeapTuning {
    bool tuned = false;
    std::string reason;      // why not, when not ("" when tuned)
    bool one_arena = false;  // every thread allocates from the one heap (tuned, or under ulimit -v / -d)
    bool small_pages = false; // the heap's first 256 MiB advised to use 4 KiB pages (a kernel built with transparent huge pages)
};

// On glibc, with an unlimited address space and data segment and no strict overcommit: frame-sized blocks
// (1080p images and targets) served from the heap instead of fresh mappings; its first 192 MiB and their pad
// in 4 KiB pages (not transparent huge pages, which a virtual machine may make slowly: process_heap.cpp); up
// to 288 MiB of freed memory kept for the next frame; every thread's blocks from that one heap; bigger blocks
// (8K) stay mappings given back at free.
// Elsewhere, under AddressSanitizer, or with LENSFX_SYSTEM_HEAP set, the allocator is left as it is, but for
// one thing under ulimit -v or -d: the threads share one arena, which halves the address space a run needs.
// Call once, first thing in main.
HeapTuning tune_process_heap();

// Makes the memory the heap grows by resident ahead of its first use, on a thread of its own. On a virtual
// machine each page's first touch may trap to the host: 4 KiB pages faulted in one at a time cost 3 ms a MB on
// the twenty-first stop's, and a 1080p run touches about 150 MB for the first time (its frame, the flare's
// images, the GL driver's render targets). What tune_process_heap reserved is left to fault in: made resident
// ahead of the heap's top (16 or 64 MiB ahead, a scratch build of the thirty-first stop) it bought no time on a
// 1080p run and cost 50 MB of resident memory. Beyond it, the heap grows by the block asked for and 64 MiB more
// (the pad), and the thread makes both resident with MADV_POPULATE_WRITE, 256 KiB a call, a tenth of the
// faults' cost there. All of it becomes resident, touched or not: the rest of the pad and room reserved but
// never used (at most the pad and the largest reservation more than a run would touch).
// Inert (warms nothing) where the heap is not tuned, under a cgroup's memory limit (what it makes resident
// unused could take the run over it) or where the kernel lacks MADV_POPULATE_WRITE (before Linux 5.14).
// Told to stop when destroyed, and not waited for (it may be asleep for 64 ms): it touches nothing but the
// kernel's page tables and its own counter.
class HeapWarmer {
public:
    HeapWarmer() = default;  // warms nothing
    explicit HeapWarmer(const HeapTuning& tuning);
    ~HeapWarmer();
    HeapWarmer(const HeapWarmer&) = delete;
    HeapWarmer& operator=(const HeapWarmer&) = delete;
    bool running() const { return thread_.joinable(); }
    // Bytes made resident so far.
    std::size_t warmed() const { return warmed_ ? warmed_->load(std::memory_order_relaxed) : 0; }

private:
    std::shared_ptr<std::atomic<std::size_t>> warmed_;  // shared with the thread, which may outlive this
    std::jthread thread_;
};

}  // namespace lensfx::filter
