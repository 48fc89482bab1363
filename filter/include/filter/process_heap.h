// The program's heap set up for frame-sized buffers: glibc's malloc tuned once at start-up so that images and
// render targets come from memory backed by transparent huge pages and kept for the next frame.
#pragma once

#include <string>

namespace lensfx::filter {

// What tune_process_heap did, for --report and tests.
struct HeapTuning {
    bool tuned = false;
    std::string reason;  // why not, when not ("" when tuned)
};

// On glibc, with an unlimited address space and data segment and no strict overcommit: the heap's first 192 MiB advised to use
// huge pages, frame-sized blocks (1080p images and targets) served from it instead of fresh mappings, and up
// to 288 MiB of freed memory kept for the next frame; every thread's blocks from that one heap; bigger blocks (8K) stay mappings given back at free.
// Elsewhere, under AddressSanitizer, or with LENSFX_SYSTEM_HEAP set, the allocator is left as it is. Call
// once, first thing in main.
HeapTuning tune_process_heap();

}  // namespace lensfx::filter
