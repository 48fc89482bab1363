// The program's heap set up for frame-sized buffers: glibc's malloc tuned once at start-up so that images and
// render targets come from the one heap and are kept for the next frame.
#pragma once

#include <string>

namespace lensfx::filter {

// What tune_process_heap did, for --report and tests.
struct HeapTuning {
    bool tuned = false;
    std::string reason;      // why not, when not ("" when tuned)
    bool one_arena = false;  // every thread allocates from the one heap (tuned, or under ulimit -v / -d)
};

// On glibc, with an unlimited address space and data segment and no strict overcommit: frame-sized blocks
// (1080p images and targets) served from the heap instead of fresh mappings, and up
// to 288 MiB of freed memory kept for the next frame; every thread's blocks from that one heap; bigger blocks (8K) stay mappings given back at free.
// Elsewhere, under AddressSanitizer, or with LENSFX_SYSTEM_HEAP set, the allocator is left as it is, but for
// one thing under ulimit -v or -d: the threads share one arena, which halves the address space a run needs.
// Call once, first thing in main.
HeapTuning tune_process_heap();

}  // namespace lensfx::filter
