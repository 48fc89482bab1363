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

// Where a cgroup hierarchy is mounted, and which cgroup the mount's root shows ("/" unless it was bind-mounted
// from deeper down, as some container runtimes do).
struct CgroupMount {
    std::string point;
    std::string root = "/";
};

// The cgroup v2 hierarchy's mount and the v1 memory controller's; where /proc/self/mountinfo shows none, the
// usual places.
struct CgroupMounts {
    CgroupMount v2{"/sys/fs/cgroup"};
    CgroupMount v1_memory{"/sys/fs/cgroup/memory"};
};

// Whether field[i] starts an octal escape: a backslash and three octal digits.
bool octal_escape_at(std::string_view field, std::size_t i) {
    const auto digit = [](char c) { return c >= '0' && c <= '7'; };
    return field[i] == '\\' && i + 3 < field.size() && digit(field[i + 1]) && digit(field[i + 2]) && digit(field[i + 3]);
}

// A mountinfo path field with its octal escapes (a space is \040, a backslash \134) decoded.
std::string unescaped(std::string_view field) {
    std::string out;
    for (std::size_t i = 0; i < field.size(); ++i) {
        if (!octal_escape_at(field, i)) {
            out += field[i];
            continue;
        }
        out += static_cast<char>(((field[i + 1] - '0') << 6) | ((field[i + 2] - '0') << 3) | (field[i + 3] - '0'));
        i += 3;
    }
    return out;
}

// The space-separated fields of a line.
std::vector<std::string_view> fields_of(std::string_view line) {
    std::vector<std::string_view> fields;
    while (!line.empty()) {
        const auto end = line.find(' ');
        if (end != 0) fields.push_back(line.substr(0, end));
        line.remove_prefix(end == std::string_view::npos ? line.size() : end + 1);
    }
    return fields;
}

// The cgroup mounts /proc/self/mountinfo's text shows ("id parent dev root point options [tags] - type source
// superoptions" a line): the first cgroup2 mount, and the first v1 mount with the memory controller among its
// super options (alone, or with others: "cpu,memory").
CgroupMounts cgroup_mounts(std::string_view mountinfo) {
    CgroupMounts mounts;
    bool v2 = false, v1 = false;
    while (!mountinfo.empty()) {
        const std::string_view line = take_line(mountinfo);
        const auto dash = line.find(" - ");
        if (dash == std::string_view::npos) continue;
        const std::vector<std::string_view> before = fields_of(line.substr(0, dash));
        const std::vector<std::string_view> after = fields_of(line.substr(dash + 3));
        if (before.size() < 5 || after.size() < 3 || before[3].front() != '/' || before[4].front() != '/') continue;
        const CgroupMount mount{unescaped(before[4]), unescaped(before[3])};
        if (after[0] == "cgroup2" && !v2) {
            mounts.v2 = mount;
            v2 = true;
        } else if (after[0] == "cgroup" && has_item(after[2], ',', "memory") && !v1) {
            mounts.v1_memory = mount;
            v1 = true;
        }
    }
    return mounts;
}

// Cgroup `path` (as /proc/self/cgroup names it) below what `mount` shows: the mount's root taken off its front.
// A path outside the mount's root (the mount shows a cgroup deeper than the process's) is the mount's root itself.
std::string_view below_mount_root(const CgroupMount& mount, std::string_view path) {
    std::string_view root = mount.root;
    while (!root.empty() && root.back() == '/') root.remove_suffix(1);
    if (root.empty()) return path;
    const bool inside = path.substr(0, root.size()) == root && (path.size() == root.size() || path[root.size()] == '/');
    return inside ? path.substr(root.size()) : std::string_view("/");
}

}  // namespace

double cgroup_memory_limit(std::string_view proc_self_cgroup,
                           const std::function<std::optional<std::string>(const std::string& path)>& read_file) {
    double lowest = 0.0;  // 0: none yet
    const auto lower_to = [&](double bytes) {
        if (bytes > 0.0 && (lowest == 0.0 || bytes < lowest)) lowest = bytes;
    };
    const auto consider = [&](const std::string& file) { lower_to(limit_value(read_file(file))); };
    // Where the hierarchies are (/sys/fs/cgroup and /sys/fs/cgroup/memory unless mountinfo says otherwise).
    const CgroupMounts mounts = cgroup_mounts(read_file("/proc/self/mountinfo").value_or(""));
    // The hierarchy roots, read even when /proc/self/cgroup is missing or names paths this mount does not show.
    consider(mounts.v2.point + "/memory.max");
    consider(mounts.v1_memory.point + "/memory.limit_in_bytes");
    // Each line: "hierarchy-id:controllers:/path" (v2: "0::/path").
    while (!proc_self_cgroup.empty()) {
        const std::string_view line = take_line(proc_self_cgroup);
        const auto first = line.find(':');
        const auto second = first == std::string_view::npos ? first : line.find(':', first + 1);
        if (second == std::string_view::npos) continue;
        const std::string_view controllers = line.substr(first + 1, second - first - 1);
        const std::string_view path = line.substr(second + 1);
        if (line.substr(0, first) == "0" && controllers.empty()) {
            for (const auto& dir : cgroup_and_ancestors(mounts.v2.point, below_mount_root(mounts.v2, path))) consider(dir + "/memory.max");
        } else if (has_item(controllers, ',', "memory")) {
            // v1: the deepest cgroup's hierarchical limit where its memory.stat can be read, else each limit up
            // to the root (an ancestor's binds only with use_hierarchy, so that may be lower than what binds).
            const std::vector<std::string> dirs = cgroup_and_ancestors(mounts.v1_memory.point, below_mount_root(mounts.v1_memory, path));
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

std::optional<std::string> read_proc_file(const std::string& path, std::size_t max_bytes) {
    std::ifstream in(path);
    if (!in) return std::nullopt;
    // procfs files have no size to ask for: read in chunks until the end (or the cap).
    constexpr std::size_t kChunk = 64 * 1024;
    std::string text;
    while (in && text.size() < max_bytes) {
        const std::size_t had = text.size();
        text.resize(std::min(max_bytes, had + kChunk));
        in.read(text.data() + had, static_cast<std::streamsize>(text.size() - had));
        text.resize(had + static_cast<std::size_t>(in.gcount()));
    }
    return text;
}

double cgroup_memory_limit() {
    const auto read_file = [](const std::string& path) { return read_proc_file(path, kProcFileCap); };
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
