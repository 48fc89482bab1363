// The memory budget (see optics/memory_budget.h).
#include <optics/memory_budget.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

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

namespace {

// A limit file's value in bytes; 0 for "max", v1's "no limit" (a number near 2^63) and anything unreadable.
double limit_value(const std::optional<std::string>& text) {
    if (!text) return 0.0;
    std::string value = *text;
    value.erase(std::remove_if(value.begin(), value.end(), [](unsigned char c) { return std::isspace(c); }), value.end());
    if (value.empty() || value == "max" || value.find_first_not_of("0123456789") != std::string::npos) return 0.0;
    try {
        const double bytes = std::stod(value);
        return bytes > 0.0 && bytes < 1e18 ? bytes : 0.0;
    } catch (const std::exception&) {
        return 0.0;
    }
}

// Whether `list`, split at `delimiter`, has an item that is exactly `item` (a path's "..", v1's "memory").
bool has_item(std::string_view list, char delimiter, std::string_view item) {
    while (!list.empty()) {
        const auto cut = list.find(delimiter);
        if (list.substr(0, cut) == item) return true;
        if (cut == std::string_view::npos) break;
        list.remove_prefix(cut + 1);
    }
    return false;
}

// The first line of `text` (without its newline), which it then drops.
std::string_view take_line(std::string_view& text) {
    const auto end = text.find('\n');
    const std::string_view line = text.substr(0, end);
    text.remove_prefix(end == std::string_view::npos ? text.size() : end + 1);
    return line;
}

// v1's memory.stat "hierarchical_memory_limit N": the limit that binds the cgroup, its ancestors' included where
// they count (use_hierarchy) and parents above the mount (a container's) too; 0 when unlimited, nullopt when the
// file or the line is missing.
std::optional<double> hierarchical_limit(const std::optional<std::string>& memory_stat) {
    if (!memory_stat) return std::nullopt;
    constexpr std::string_view kKey = "hierarchical_memory_limit ";
    std::string_view text = *memory_stat;
    while (!text.empty()) {
        const std::string_view line = take_line(text);
        if (line.substr(0, kKey.size()) == kKey) return limit_value(std::string(line.substr(kKey.size())));
    }
    return std::nullopt;
}

// The cgroup directories from `cgroup_dir` (a path inside `mount`, "/" at the root) up to the root, deepest first.
std::vector<std::string> cgroup_and_ancestors(const std::string& mount, std::string_view cgroup_dir) {
    // Paths never hold a ".." component from the kernel; refuse one rather than read outside the mount.
    if (cgroup_dir.empty() || cgroup_dir.front() != '/' || has_item(cgroup_dir, '/', "..")) cgroup_dir = {};
    std::vector<std::string> dirs;
    for (;;) {
        while (!cgroup_dir.empty() && cgroup_dir.back() == '/') cgroup_dir.remove_suffix(1);
        dirs.push_back(mount + std::string(cgroup_dir));
        if (cgroup_dir.empty()) break;
        cgroup_dir = cgroup_dir.substr(0, cgroup_dir.find_last_of('/'));
    }
    return dirs;
}

}  // namespace

double cgroup_memory_limit(std::string_view proc_self_cgroup,
                           const std::function<std::optional<std::string>(const std::string& path)>& read_file) {
    double lowest = 0.0;  // 0: none yet
    const auto lower_to = [&](double bytes) {
        if (bytes > 0.0 && (lowest == 0.0 || bytes < lowest)) lowest = bytes;
    };
    const auto consider = [&](const std::string& file) { lower_to(limit_value(read_file(file))); };
    // The hierarchy roots, read even when /proc/self/cgroup is missing or names paths this mount does not show.
    consider("/sys/fs/cgroup/memory.max");
    consider("/sys/fs/cgroup/memory/memory.limit_in_bytes");
    // Each line: "hierarchy-id:controllers:/path" (v2: "0::/path").
    while (!proc_self_cgroup.empty()) {
        const std::string_view line = take_line(proc_self_cgroup);
        const auto first = line.find(':');
        const auto second = first == std::string_view::npos ? first : line.find(':', first + 1);
        if (second == std::string_view::npos) continue;
        const std::string_view controllers = line.substr(first + 1, second - first - 1);
        const std::string_view path = line.substr(second + 1);
        if (line.substr(0, first) == "0" && controllers.empty()) {
            for (const auto& dir : cgroup_and_ancestors("/sys/fs/cgroup", path)) consider(dir + "/memory.max");
        } else if (has_item(controllers, ',', "memory")) {
            // v1: the deepest cgroup's hierarchical limit where its memory.stat can be read, else each limit up
            // to the root (an ancestor's binds only with use_hierarchy, so that may be lower than what binds).
            const std::vector<std::string> dirs = cgroup_and_ancestors("/sys/fs/cgroup/memory", path);
            std::optional<double> hierarchical;
            for (auto dir = dirs.begin(); dir != dirs.end() && !hierarchical; ++dir) hierarchical = hierarchical_limit(read_file(*dir + "/memory.stat"));
            if (hierarchical) {
                lower_to(*hierarchical);
            } else {
                for (const auto& dir : dirs) consider(dir + "/memory.limit_in_bytes");
            }
        }
    }
    return lowest;
}

double cgroup_memory_limit() {
    // A whole small file (cgroupfs and procfs files are a few lines); nullopt where it cannot be opened.
    const auto read_file = [](const std::string& path) -> std::optional<std::string> {
        std::ifstream in(path);
        if (!in) return std::nullopt;
        std::string text(64 * 1024, '\0');
        in.read(text.data(), static_cast<std::streamsize>(text.size()));
        text.resize(static_cast<std::size_t>(in.gcount()));
        return text;
    };
    return cgroup_memory_limit(read_file("/proc/self/cgroup").value_or(""), read_file);
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
