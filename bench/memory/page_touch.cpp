// bench_page_touch: what a fresh page costs on this machine, the figure behind the heap's page size
// (filter/src/process_heap.cpp). Each trial maps a fresh anonymous region, advises it to use 4 KiB pages or
// transparent huge pages, and makes it resident by touching it (a fault a page) or with MADV_POPULATE_WRITE,
// then prints milliseconds per MiB; a second write of the same memory (no faults) is printed beside it. On a
// virtual machine the first touch may trap to the host, which may have taken back memory the guest freed: the
// trials are --gap seconds apart (default 3, as a run started by hand would follow the last), and the modes run
// in turn, in reverse order every other round, so that no mode always follows the same one (a huge page freed
// moments before is cheap). Each row says how much of the region was in huge pages after the first touch.
//   bench_page_touch [--mib N (128)] [--trials N (3)] [--gap S (3)]
#include <sys/mman.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <fstream>
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

struct Options {
    std::size_t mib = 128;
    int trials = 3;
    double gap_s = 3.0;
};

struct Mode {
    const char* name;
    int advice;     // MADV_NOHUGEPAGE or MADV_HUGEPAGE
    bool populate;  // MADV_POPULATE_WRITE instead of touching
};

struct Trial {
    double first_ms_per_mib = 0.0;
    double again_ms_per_mib = 0.0;
    double huge_share = 0.0;  // of the region in huge pages after the first touch
    bool populated = true;    // false: MADV_POPULATE_WRITE refused, the region was touched instead
};

// MemAvailable from /proc/meminfo, in MiB; 0 where it is not known.
std::size_t available_mib() {
    std::ifstream meminfo("/proc/meminfo");
    for (std::string line; std::getline(meminfo, line);)
        if (line.starts_with("MemAvailable:")) return std::stoull(line.substr(13)) >> 10;  // kB
    return 0;
}

Options parse(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
            return argv[++i];
        };
        if (a == "--mib") o.mib = std::stoul(next());
        else if (a == "--trials") o.trials = std::stoi(next());
        else if (a == "--gap") o.gap_s = std::stod(next());
        else throw std::invalid_argument("unknown argument " + a);
    }
    if (o.mib == 0 || o.mib > 65536) throw std::invalid_argument("--mib must be 1..65536");
    // Each trial makes the whole region resident: more than half of what the machine has free would invite the OOM killer.
    if (const std::size_t available = available_mib(); available > 0 && o.mib > available / 2)
        throw std::invalid_argument(fmt::format("--mib {} is over half the {} MiB this machine has available", o.mib, available));
    if (o.trials < 1) throw std::invalid_argument("--trials must be at least 1");
    if (!(o.gap_s >= 0.0 && o.gap_s <= 3600.0)) throw std::invalid_argument("--gap must be 0..3600 seconds");
    return o;
}

// The kernel's transparent huge page mode ("always", "madvise" or "never"), "none" where it has none.
std::string transparent_huge_pages() {
    std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string line;
    std::getline(in, line);
    const auto open = line.find('['), close = line.find(']');
    return open != std::string::npos && close > open ? line.substr(open + 1, close - open - 1) : "none";
}

// Bytes in huge pages of the mapping that starts at `start` (/proc/self/smaps' AnonHugePages).
std::size_t huge_bytes_at(const void* start) {
    const std::string prefix = fmt::format("{:x}-", reinterpret_cast<std::uintptr_t>(start));
    std::ifstream smaps("/proc/self/smaps");
    bool here = false;
    for (std::string line; std::getline(smaps, line);) {
        if (line.starts_with(prefix)) here = true;
        else if (here && line.starts_with("AnonHugePages:")) return std::stoull(line.substr(14)) << 10;
    }
    return 0;
}

double ms_since(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

// One trial: a fresh region of `bytes` (2 MiB aligned, so that huge pages can back all of it) made resident
// in `mode`, then written once more.
Trial run_trial(const Mode& mode, std::size_t bytes) {
    void* mapped = mmap(nullptr, bytes + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapped == MAP_FAILED) throw std::runtime_error(fmt::format("cannot map {} MiB", bytes >> 20));
    const auto aligned = (reinterpret_cast<std::uintptr_t>(mapped) + kHugePage - 1) & ~(kHugePage - 1);
    auto* p = reinterpret_cast<char*>(aligned);
    madvise(p, bytes, mode.advice);  // splits the mapping: the region is a mapping of its own
    const double mib = static_cast<double>(bytes) / (1 << 20);
    Trial out;
    auto t = std::chrono::steady_clock::now();
    out.populated = mode.populate && madvise(p, bytes, MADV_POPULATE_WRITE) == 0;
    if (!out.populated) std::memset(p, 1, bytes);
    out.first_ms_per_mib = ms_since(t) / mib;
    out.huge_share = static_cast<double>(huge_bytes_at(p)) / static_cast<double>(bytes);
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

void print_row(const char* name, double first, double again, double huge_share) {
    fmt::print("  {:<24} {:7.3f}  {:7.3f}  {:5.0f}%\n", name, first, again, 100.0 * huge_share);
}

void run(const Options& o) {
    const std::vector<Mode> modes = {{"4 KiB pages, touched", MADV_NOHUGEPAGE, false},
                                     {"4 KiB pages, populated", MADV_NOHUGEPAGE, true},
                                     {"huge pages, touched", MADV_HUGEPAGE, false},
                                     {"huge pages, populated", MADV_HUGEPAGE, true}};
    std::vector<std::vector<double>> first(modes.size()), again(modes.size()), huge(modes.size());
    fmt::print("transparent huge pages: {}; {} MiB a trial, {} s apart\n", transparent_huge_pages(), o.mib, o.gap_s);
    fmt::print("  {:<24} {:>7}  {:>7}  {:>6}\n", "ms per MiB", "first", "again", "huge");
    bool refused = false;
    for (int t = 0; t < o.trials; ++t)
        for (std::size_t k = 0; k < modes.size(); ++k) {
            const std::size_t m = t % 2 ? modes.size() - 1 - k : k;  // every other round in reverse
            std::this_thread::sleep_for(std::chrono::duration<double>(o.gap_s));
            const Trial r = run_trial(modes[m], o.mib << 20);
            refused = refused || (modes[m].populate && !r.populated);
            first[m].push_back(r.first_ms_per_mib);
            again[m].push_back(r.again_ms_per_mib);
            huge[m].push_back(r.huge_share);
            print_row(modes[m].name, r.first_ms_per_mib, r.again_ms_per_mib, r.huge_share);
        }
    fmt::print("median over {} trials:\n", o.trials);
    for (std::size_t m = 0; m < modes.size(); ++m) print_row(modes[m].name, median(first[m]), median(again[m]), median(huge[m]));
    if (refused) fmt::print("MADV_POPULATE_WRITE was refused (Linux before 5.14?): the populated rows were touched\n");
}

}  // namespace

int main(int argc, char** argv) {
    try {
        run(parse(argc, argv));
    } catch (const std::exception& e) {
        fmt::print(stderr, "bench_page_touch: {}\n", e.what());
        return 1;
    }
    return 0;
}
