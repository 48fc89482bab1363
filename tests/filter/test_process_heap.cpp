// The program's heap tuning (filter/process_heap.h): each case runs in a child process of its own, because
// malloc's settings are the whole process's.
#include <filter/process_heap.h>
#include <optics/memory_budget.h>

#include <cstdio>
#include <cstdlib>
#include <cctype>
#include <cstring>
#include <fstream>
#include <functional>
#include <string>
#include <thread>
#include <vector>
#include <chrono>

#include <gtest/gtest.h>
#include <malloc.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace lensfx::filter;

#if defined(__SANITIZE_ADDRESS__)
TEST(ProcessHeap, NeedsGlibcsMalloc) { GTEST_SKIP() << "AddressSanitizer replaces malloc: the heap is left alone"; }
#else
namespace {

// Runs `body` in a forked child; its return value is the child's exit status (0 = passed).
int in_child(const std::function<int()>& body) {
    const pid_t pid = fork();
    if (pid == 0) _exit(body());
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 100;
}

// Bytes of the blocks malloc serves from mappings of their own.
std::size_t mapped_block_bytes() { return mallinfo2().hblkhd; }

// A block the compiler may not elide (it drops a malloc and free with nothing between them that it can see).
void* opaque(void* p) {
    asm volatile("" : : "r"(p) : "memory");
    return p;
}

constexpr std::size_t kFrameBytes = std::size_t{30} << 20;  // a 1080p RGB float image and then some
constexpr std::size_t k8KBytes = std::size_t{400} << 20;    // an 8K half RGB frame and more

}  // namespace

// glibc's default maps a 30 MB block of its own (so this test can fail); tuned, it comes from the heap.
TEST(ProcessHeap, FrameSizedBlocksComeFromTheHeap) {
    EXPECT_EQ(in_child([] {
        void* p = opaque(std::malloc(kFrameBytes));
        const bool mapped = mapped_block_bytes() >= kFrameBytes;
        std::free(p);
        return mapped ? 0 : 1;
    }), 0) << "untuned, a frame-sized block should be a mapping of its own";
    EXPECT_EQ(in_child([] {
        if (!tune_process_heap().tuned) return 2;
        void* p = opaque(std::malloc(kFrameBytes));
        const bool mapped = mapped_block_bytes() > 0;
        std::free(p);
        return mapped ? 1 : 0;
    }), 0);
}

// Minor page faults of this process so far.
long minor_faults() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return usage.ru_minflt;
}

// An 8K frame's buffers are mappings of their own, given back at free: the heap keeps only what a 1080p job
// reuses (kept for good in the heap, an 8K sequence's peak rose from 1.89 to 2.20 GB; bench_memory).
TEST(ProcessHeap, An8KBufferIsGivenBackAtFree) {
    EXPECT_EQ(in_child([] {
        if (!tune_process_heap().tuned) return 2;
        void* p = opaque(std::malloc(k8KBytes));
        const bool mapped = mapped_block_bytes() >= k8KBytes;
        std::free(p);
        return mapped && mapped_block_bytes() == 0 ? 0 : 1;
    }), 0);
}

// A block freed after one frame is handed to the next without being given back to the kernel: touching it
// again takes no page faults (glibc's default unmaps it, and 30 MB fault back in at 4 KiB or 2 MiB a time).
TEST(ProcessHeap, AFreedFrameIsTheNextFramesMemory) {
    EXPECT_EQ(in_child([] {
        if (!tune_process_heap().tuned) return 2;
        auto* a = static_cast<char*>(opaque(std::malloc(kFrameBytes)));
        std::memset(a, 1, kFrameBytes);
        std::free(opaque(a));
        const long before = minor_faults();
        auto* b = static_cast<char*>(opaque(std::malloc(kFrameBytes)));
        std::memset(b, 2, kFrameBytes);
        const long faults = minor_faults() - before;
        std::free(opaque(b));
        return faults < 8 ? 0 : 1;
    }), 0);
}

// A frame-sized block another thread frees (the reader's frame, an OpenEXR worker's buffers) is the next
// frame's memory on any thread: glibc's default gives each thread an arena of its own, so the main thread's
// block would fault in afresh (7,680 faults for these 30 MB).
TEST(ProcessHeap, AWorkerThreadsFreedBlockIsReusedByTheNext) {
    EXPECT_EQ(in_child([] {
        if (!tune_process_heap().tuned) return 2;
        std::thread worker([] {
            auto* p = static_cast<char*>(opaque(std::malloc(kFrameBytes)));
            std::memset(p, 1, kFrameBytes);
            std::free(opaque(p));
        });
        worker.join();
        const long before = minor_faults();
        auto* q = static_cast<char*>(opaque(std::malloc(kFrameBytes)));
        std::memset(q, 2, kFrameBytes);
        const long faults = minor_faults() - before;
        std::free(opaque(q));
        return faults < static_cast<long>(kFrameBytes / 4096 / 4) ? 0 : 1;  // well under one fault per 4 KiB page
    }), 0);
}

// Pages of [p, p + bytes) resident in memory (mincore).
std::size_t resident_pages(const void* p, std::size_t bytes) {
    const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
    const std::uintptr_t from = reinterpret_cast<std::uintptr_t>(p) & ~(page - 1);
    const std::size_t span = reinterpret_cast<std::uintptr_t>(p) + bytes - from;
    std::vector<unsigned char> in((span + page - 1) / page);
    if (mincore(reinterpret_cast<void*>(from), span, in.data()) != 0) return 0;
    std::size_t n = 0;
    for (unsigned char c : in) n += c & 1;
    return n;
}

// Whether this kernel makes a range resident on request (MADV_POPULATE_WRITE, Linux 5.14).
bool kernel_populates() {
    const std::size_t bytes = 1 << 16;
    void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) return false;
    const bool ok = madvise(p, bytes, 23 /* MADV_POPULATE_WRITE */) == 0;
    munmap(p, bytes);
    return ok;
}

// Frame-sized blocks beyond the heap's reservation and pad (it grows) are made resident by the warmer before
// anything touches them; without the warmer, an untouched block's pages are not resident (but for those
// glibc's chunk headers fault in).
TEST(ProcessHeap, TheWarmerMakesWhatTheHeapGrowsByResident) {
    if (!kernel_populates()) GTEST_SKIP() << "the kernel lacks MADV_POPULATE_WRITE (Linux 5.14): the warmer does nothing";
    if (lensfx::cgroup_memory_limit() > 0.0) GTEST_SKIP() << "under a cgroup memory limit the warmer stays off";
    EXPECT_EQ(in_child([] {
        const HeapTuning tuning = tune_process_heap();
        if (!tuning.tuned) return 2;
        const std::size_t pages = kFrameBytes / static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
        void* cold = opaque(std::malloc(kFrameBytes));
        if (resident_pages(cold, kFrameBytes) > pages / 4) return 3;
        const HeapWarmer warmer(tuning);
        if (!warmer.running()) return 4;
        std::vector<void*> blocks;  // ten frames: beyond the 192 MiB reserved and the 64 MiB pad
        for (int i = 0; i < 10; ++i) blocks.push_back(opaque(std::malloc(kFrameBytes)));
        bool resident = false;
        for (int waited_ms = 0; waited_ms < 10000 && !resident; waited_ms += 10) {
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
            resident = resident_pages(blocks.back(), kFrameBytes) >= pages;
        }
        const bool warmed = warmer.warmed() >= kFrameBytes;
        for (void* b : blocks) std::free(b);
        std::free(cold);
        return resident && warmed ? 0 : 1;
    }), 0);
}

// The kernel's transparent huge page mode ("always", "madvise" or "never"), "" where it has none.
std::string transparent_huge_pages() {
    std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string line;
    std::getline(in, line);
    const auto open = line.find('['), close = line.find(']');
    return open != std::string::npos && close > open ? line.substr(open + 1, close - open - 1) : "";
}

// The mapping holding an address, as /proc/self/smaps tells it: its bytes in transparent huge pages and its
// flags ("nh": advised not to use them, "hg": advised to).
struct MappingPages {
    bool found = false;
    std::size_t huge_bytes = 0;
    std::string flags;
};
MappingPages mapping_of(const void* p) {
    const auto at = reinterpret_cast<std::uintptr_t>(p);
    std::ifstream smaps("/proc/self/smaps");
    MappingPages out;
    bool here = false;
    for (std::string line; std::getline(smaps, line);) {
        if (!line.empty() && std::isxdigit(static_cast<unsigned char>(line[0])) && line.find('-') != std::string::npos) {
            const std::uintptr_t lo = std::stoull(line, nullptr, 16), hi = std::stoull(line.substr(line.find('-') + 1), nullptr, 16);
            here = lo <= at && at < hi;  // a mapping's first line: its address range
            out.found = out.found || here;
        } else if (here && line.starts_with("AnonHugePages:")) {
            out.huge_bytes = std::stoull(line.substr(14)) << 10;
        } else if (here && line.starts_with("VmFlags:")) {
            out.flags = line.substr(8);
        }
    }
    return out;
}

bool has_flag(const std::string& flags, const std::string& flag) { return (flags + " ").find(" " + flag + " ") != std::string::npos; }

// A 1080p frame's buffer comes from heap advised to use 4 KiB pages, whatever the kernel's default ("always",
// "madvise" or "never"): on the thirty-first stop's machine a cold huge page took 2.7-4.1 ms a MiB on first touch,
// a 4 KiB page 0.43-0.55 (bench_page_touch). Touched whole, none of it is in huge pages: neither the first frame
// nor the eighth, which lies beyond the 192 MiB reserved, in the pad glibc grew the heap by with them.
TEST(ProcessHeap, AFrameSizedBlockIsInSmallPages) {
    if (transparent_huge_pages().empty()) GTEST_SKIP() << "this kernel has no transparent huge pages: nothing to advise against";
    const int status = in_child([] {
        const HeapTuning tuning = tune_process_heap();
        if (!tuning.tuned) return 2;
        if (!tuning.small_pages) return 3;
        std::vector<char*> frames;
        for (int i = 0; i < 8; ++i) {
            frames.push_back(static_cast<char*>(opaque(std::malloc(kFrameBytes))));
            std::memset(frames.back(), 1, kFrameBytes);
        }
        const MappingPages first = mapping_of(frames.front() + kFrameBytes / 2), last = mapping_of(frames.back() + kFrameBytes / 2);
        for (char* p : frames) std::free(opaque(p));
        if (!first.found || !last.found) return 4;
        if (first.flags.empty()) return 5;  // a kernel before 3.8 says no VmFlags
        bool small = true;
        for (const MappingPages& m : {first, last}) {
            const bool ok = has_flag(m.flags, "nh") && !has_flag(m.flags, "hg") && m.huge_bytes == 0;
            if (!ok) std::fprintf(stderr, "a frame's mapping: flags '%s', %zu bytes in huge pages\n", m.flags.c_str(), m.huge_bytes);
            small = small && ok;
        }
        return small ? 0 : 1;
    });
    if (status == 5) GTEST_SKIP() << "this kernel's smaps has no VmFlags";
    EXPECT_EQ(status, 0);
}

// An untuned heap (here LENSFX_SYSTEM_HEAP) is not warmed.
TEST(ProcessHeap, AnUntunedHeapIsNotWarmed) {
    EXPECT_EQ(in_child([] {
        setenv("LENSFX_SYSTEM_HEAP", "1", 1);
        const HeapWarmer warmer(tune_process_heap());
        return !warmer.running() && warmer.warmed() == 0 ? 0 : 1;
    }), 0);
}

// 0 when, in a child with `resource` capped at 8 GiB, tune_process_heap leaves the heap alone saying `why`.
int capped_leaves_heap_alone(decltype(RLIMIT_AS) resource, const char* why) {
    return in_child([resource, why] {
        const rlimit limit{std::size_t{8} << 30, std::size_t{8} << 30};
        if (setrlimit(resource, &limit) != 0) return 3;
        const HeapTuning t = tune_process_heap();
        return !t.tuned && t.reason.find(why) != std::string::npos ? 0 : 1;
    });
}

TEST(ProcessHeap, ALimitedAddressSpaceLeavesTheHeapAlone) { EXPECT_EQ(capped_leaves_heap_alone(RLIMIT_AS, "ulimit -v"), 0); }

// The arenas malloc has (one <heap nr=...> each in malloc_info) after a worker thread allocated a small block.
int arenas_after_a_worker_allocates() {
    std::thread([] { std::free(opaque(std::malloc(4096))); }).join();
    char* text = nullptr;
    std::size_t size = 0;
    FILE* out = open_memstream(&text, &size);
    malloc_info(0, out);
    std::fclose(out);
    int arenas = 0;
    for (const char* at = text; (at = std::strstr(at, "<heap nr=")) != nullptr; ++at) ++arenas;
    std::free(text);
    return arenas;
}

// Under ulimit -v the heap is left alone but for the arenas: a worker thread allocates from the main heap instead
// of an arena of its own (64 MiB of address space each: CandleGlass.exr's flare needed 1.06 GiB, 0.5 with one).
TEST(ProcessHeap, ALimitedAddressSpaceKeepsOneArena) {
    EXPECT_EQ(in_child([] { return arenas_after_a_worker_allocates() == 2 ? 0 : 1; }), 0) << "untuned, a worker thread gets an arena of its own";
    EXPECT_EQ(in_child([] {
        const rlimit limit{std::size_t{8} << 30, std::size_t{8} << 30};
        if (setrlimit(RLIMIT_AS, &limit) != 0) return 3;
        const HeapTuning t = tune_process_heap();
        return !t.tuned && t.one_arena && arenas_after_a_worker_allocates() == 1 ? 0 : 1;
    }), 0);
}

// A capped data segment is charged the reservation and the top pad: tuned there, a run under `ulimit -d 450000`
// hung or aborted where the untuned heap ran in 197 MB.
TEST(ProcessHeap, ALimitedDataSegmentLeavesTheHeapAlone) { EXPECT_EQ(capped_leaves_heap_alone(RLIMIT_DATA, "ulimit -d"), 0); }

TEST(ProcessHeap, SystemHeapVariableLeavesTheHeapAlone) {
    EXPECT_EQ(in_child([] {
        setenv("LENSFX_SYSTEM_HEAP", "1", 1);
        const HeapTuning t = tune_process_heap();
        return !t.tuned && t.reason.find("LENSFX_SYSTEM_HEAP") != std::string::npos ? 0 : 1;
    }), 0);
}
#endif
