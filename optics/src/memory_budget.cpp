// The memory budget (see optics/memory_budget.h).
#include <optics/memory_budget.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <string>

#include <fmt/core.h>
#include <sys/resource.h>
#include <unistd.h>

namespace lensfx {

void MemoryBudget::check(double bytes, std::string_view what) const {
    if (!limited() || bytes <= static_cast<double>(limit)) return;
    throw MemoryLimitError(fmt::format("{} needs {}, over the memory limit of {} (--memory-limit)", what,
                                       format_bytes(bytes), format_bytes(static_cast<double>(limit))));
}

std::string format_bytes(double bytes) {
    if (!(bytes < 1e30)) return "more than 1e30 bytes";
    static constexpr const char* kUnits[] = {"KB", "MB", "GB", "TB", "PB", "EB"};
    if (bytes < 1e3) return fmt::format("{:.0f} bytes", bytes);
    double value = bytes / 1e3;
    std::size_t unit = 0;
    while (value >= 1e3 && unit + 1 < std::size(kUnits)) {
        value /= 1e3;
        ++unit;
    }
    return value < 10.0 ? fmt::format("{:.1f} {}", value, kUnits[unit]) : fmt::format("{:.0f} {}", value, kUnits[unit]);
}

MemoryBudget parse_memory_limit(std::string_view text) {
    std::string t(text);
    std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (t == "none" || t == "0") return {};
    auto bad = [&] {
        return std::invalid_argument(fmt::format("--memory-limit must be a size such as 4G, 512M or none, not \"{}\"", text));
    };
    for (const char* suffix : {"ib", "b"}) {
        const std::string s(suffix);
        if (t.size() > s.size() && t.compare(t.size() - s.size(), s.size(), s) == 0) {
            t.resize(t.size() - s.size());
            break;
        }
    }
    double scale = 1.0;
    if (!t.empty()) {
        const std::string units = "kmgt";
        if (const auto u = units.find(t.back()); u != std::string::npos) {
            scale = std::pow(1024.0, static_cast<double>(u + 1));
            t.pop_back();
        }
    }
    if (t.empty() || t.find_first_not_of("0123456789.") != std::string::npos) throw bad();
    std::size_t used = 0;
    double value = 0.0;
    try {
        value = std::stod(t, &used);
    } catch (const std::exception&) {
        throw bad();
    }
    const double bytes = value * scale;
    if (used != t.size() || !(bytes >= 1.0) || bytes > 1e18) throw bad();
    return MemoryBudget{static_cast<std::size_t>(bytes)};
}

double cgroup_memory_limit() {
    for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
        std::ifstream in(path);
        std::string value;
        if (!(in >> value) || value == "max") continue;
        try {
            const double bytes = std::stod(value);
            if (bytes > 0.0 && bytes < 1e18) return bytes;  // v1 reports "no limit" as a huge number
        } catch (const std::exception&) {
        }
    }
    return 0.0;
}

MemoryBudget default_memory_budget() {
    double memory = static_cast<double>(::sysconf(_SC_PHYS_PAGES)) * static_cast<double>(::sysconf(_SC_PAGE_SIZE));
    if (const double cgroup = cgroup_memory_limit(); cgroup > 0.0 && (cgroup < memory || !(memory > 0.0))) memory = cgroup;
    // A process limit (ulimit -v, ulimit -d) lower than that: half of it too, so that a frame too large for it is
    // refused by the budget in a line that says so rather than failing an allocation (std::bad_alloc).
    for (const int resource : {RLIMIT_AS, RLIMIT_DATA}) {
        rlimit limit{};
        if (::getrlimit(resource, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY && static_cast<double>(limit.rlim_cur) < memory)
            memory = static_cast<double>(limit.rlim_cur);
    }
    if (!(memory > 0.0)) return {};
    return MemoryBudget{static_cast<std::size_t>(memory / 2.0)};
}

}  // namespace lensfx
