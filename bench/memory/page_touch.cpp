// bench_page_touch: what a fresh page costs on this machine, the figure behind the heap's page size
// (filter/src/process_heap.cpp). Each trial maps a fresh anonymous region, advises it to use 4 KiB pages or
// transparent huge pages, and makes it resident by touching it (a fault a page) or with MADV_POPULATE_WRITE,
// then prints milliseconds per MiB; a second touch of the same memory (no faults) is printed beside it. On a
// virtual machine the first touch may trap to the host, which may have taken back memory the guest freed: the
// trials are apart by --gap seconds (default 3, as a run started by hand would be) and the modes alternate.
//   bench_page_touch [--mib N (128)] [--trials N (3)] [--gap S (3)]
#include <sys/mman.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <fmt/core.h>

namespace {

#if !defined(MADV_POPULATE_WRITE)
#define MADV_POPULATE_WRITE 23  // Linux 5.14
#endif

constexpr std::size_t kHugePage = std::size_t{2} << 20;

struct Mode {
    const char* name;
    int advice;     // MADV_NOHUGEPAGE or MADV_HUGEPAGE
    bool populate;  // MADV_POPULATE_WRITE instead of touching
};

struct Trial {
    double first_ms_per_mib = 0.0;
    double again_ms_per_mib = 0.0;
};

double ms_since(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

// One trial: a fresh region of `bytes` (2 MiB aligned, so that huge pages can back all of it) made resident
// in `mode`, then written once more.
Trial run_trial(const Mode& mode, std::size_t bytes) {
    void* mapped = mmap(nullptr, bytes + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapped == MAP_FAILED) throw std::runtime_error("mmap failed");
    const auto aligned = (reinterpret_cast<std::uintptr_t>(mapped) + kHugePage - 1) & ~(kHugePage - 1);
    auto* p = reinterpret_cast<char*>(aligned);
    madvise(p, bytes, mode.advice);  // refused without transparent huge pages: then both modes are 4 KiB pages
    const double mib = static_cast<double>(bytes) / (1 << 20);
    Trial out;
    auto t = std::chrono::steady_clock::now();
    if (!mode.populate || madvise(p, bytes, MADV_POPULATE_WRITE) != 0) std::memset(p, 1, bytes);
    out.first_ms_per_mib = ms_since(t) / mib;
    t = std::chrono::steady_clock::now();
    std::memset(p, 2, bytes);
    out.again_ms_per_mib = ms_since(t) / mib;
    munmap(mapped, bytes + kHugePage);
    return out;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2.0;
}

}  // namespace

int main(int argc, char** argv) {
    std::size_t mib = 128;
    int trials = 3;
    double gap_s = 3.0;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string a = argv[i];
        if (a == "--mib") mib = std::stoul(argv[i + 1]);
        else if (a == "--trials") trials = std::stoi(argv[i + 1]);
        else if (a == "--gap") gap_s = std::stod(argv[i + 1]);
        else {
            fmt::print(stderr, "bench_page_touch: unknown option {}\n", a);
            return 2;
        }
    }
    if (mib == 0 || mib > 65536 || trials < 1 || !(gap_s >= 0.0)) {
        fmt::print(stderr, "bench_page_touch: --mib 1..65536, --trials >= 1, --gap >= 0\n");
        return 2;
    }
    const std::vector<Mode> modes = {{"4 KiB pages, touched", MADV_NOHUGEPAGE, false},
                                     {"4 KiB pages, populated", MADV_NOHUGEPAGE, true},
                                     {"huge pages, touched", MADV_HUGEPAGE, false},
                                     {"huge pages, populated", MADV_HUGEPAGE, true}};
    std::vector<std::vector<double>> first(modes.size()), again(modes.size());
    fmt::print("{} MiB a trial, {} s apart (ms per MiB: first touch, then a second write)\n", mib, gap_s);
    for (int t = 0; t < trials; ++t)
        for (std::size_t m = 0; m < modes.size(); ++m) {
            std::this_thread::sleep_for(std::chrono::duration<double>(gap_s));
            const Trial r = run_trial(modes[m], mib << 20);
            first[m].push_back(r.first_ms_per_mib);
            again[m].push_back(r.again_ms_per_mib);
            fmt::print("  {:<24} {:7.3f}  {:7.3f}\n", modes[m].name, r.first_ms_per_mib, r.again_ms_per_mib);
        }
    fmt::print("median over {} trials:\n", trials);
    for (std::size_t m = 0; m < modes.size(); ++m)
        fmt::print("  {:<24} {:7.3f}  {:7.3f}\n", modes[m].name, median(first[m]), median(again[m]));
    return 0;
}
