// The memory budget of a run (--memory-limit): the most bytes lensfx may hold in its big buffers (frames,
// flare images, GL targets, lens tables, output conversions). Every such buffer is sized against it before
// it is made, so a hostile header or option is refused in one line naming what was too big, instead of
// ending in std::bad_alloc or the kernel's OOM killer. A plain value: each stage keeps a copy.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace lensfx {

// Thrown when a buffer would not fit the budget; the message names the buffer and both sizes.
class MemoryLimitError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct MemoryBudget {
    std::size_t limit = 0;  // bytes; 0: no limit

    bool limited() const { return limit > 0; }
    // Throws MemoryLimitError "WHAT needs 10.8 GB, over the memory limit of 4 GB (--memory-limit)" when
    // `bytes` exceed the limit. A double, so that products of hostile sizes are compared without overflow.
    void check(double bytes, std::string_view what) const;
};

// The byte count of width x height items of `item_bytes` each, as a double (never overflows).
inline double bytes_of(double width, double height, double item_bytes) { return width * height * item_bytes; }

// "10.8 GB", "512 MB", "64 KB", "12 bytes" (decimal units, as /usr/bin/time and df report them).
std::string format_bytes(double bytes);

// --memory-limit's text: "4G", "512M", "1.5G", "800K", "1000000" (bytes); K/M/G/T are powers of 1024, an
// optional trailing "B" or "iB" is accepted; "0" or "none": no limit. Throws std::invalid_argument.
MemoryBudget parse_memory_limit(std::string_view text);

// The cgroup memory limit of this process in bytes, 0 when none is set: the lowest memory.max (v2) or
// memory.limit_in_bytes (v1) over the cgroups /proc/self/cgroup names and their ancestors, so that a limit on a
// child cgroup (a Slurm job's, a systemd slice's) counts as well as one seen at the hierarchy's root; on v1 the
// deepest readable memory.stat's hierarchical_memory_limit, which is what binds there. The hierarchies are where
// /proc/self/mountinfo says (/sys/fs/cgroup and /sys/fs/cgroup/memory where it shows none).
double cgroup_memory_limit();

// The same, from /proc/self/cgroup's text and a reader of files (/proc/self/mountinfo and cgroupfs files;
// nullopt where a file cannot be read), to be tested without the machine's cgroups.
double cgroup_memory_limit(std::string_view proc_self_cgroup,
                           const std::function<std::optional<std::string>(const std::string& path)>& read_file);

// A procfs or cgroupfs file whole, up to max_bytes (they report no size); nullopt where it cannot be opened.
// /proc/self/mountinfo runs to hundreds of KiB on a host with thousands of mounts (containers, Kubernetes),
// and the cgroup mounts may be listed last.
inline constexpr std::size_t kProcFileCap = std::size_t{4} << 20;
std::optional<std::string> read_proc_file(const std::string& path, std::size_t max_bytes = kProcFileCap);

// The default budget: half of the machine's memory (the physical memory, or the cgroup's limit or the process's
// address-space or data limit when lower), so one run never takes the machine down with it.
MemoryBudget default_memory_budget();

// --memory-limit's help text, shared by the commands that take it.
inline constexpr const char* kMemoryLimitHelp =
    "Most memory for frames, flare images and lens tables: 4G, 512M... (default: half the machine's memory; 0 or none: no limit)";

}  // namespace lensfx
