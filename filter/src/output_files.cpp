// Files the program writes (see filter/output_files.h).
#include <filter/output_files.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <utility>
#include <stdexcept>
#include <thread>

#include <fcntl.h>
#include <fmt/core.h>
#include <pthread.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <filter/sequence.h>
#include <optics/process_liveness.h>

namespace lensfx::filter {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kTempTag = ".lensfx-";  // ".NAME.lensfx-PID.EXT"

// The temporaries being written, for the signal handler: fixed slots, each free, being filled, or ready
// (its path may be unlinked). Only lock-free atomics and unlink() are touched from the handler.
constexpr int kSlots = 64;
constexpr std::size_t kPathMax = 4096;
enum SlotState : int { kFree = 0, kFilling = 1, kReady = 2 };
struct Slot {
    std::atomic<int> state{kFree};
    char path[kPathMax] = {};
};
Slot g_slots[kSlots];
static_assert(std::atomic<int>::is_always_lock_free);

constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
std::atomic<bool> g_stop_said{false};  // the stopping line is written once, whichever thread the signal lands on
static_assert(std::atomic<bool>::is_always_lock_free);

// A file written unnamed (O_TMPFILE) is named only in commit(), for the two calls that link it under its temporary
// name and rename that onto the target. The handler marks the program stopping, then waits for the commits under way
// (g_naming) before it removes the temporaries; a commit that starts after the mark waits for the end (seq_cst: either
// the commit sees the mark or the handler sees the commit).
std::atomic<bool> g_stopping{false};
std::atomic<int> g_naming{0};

// The handler's wait for the commits under way: bounded (two system calls each), never forever.
void wait_for_commits_under_way() {
    const struct timespec ms{0, 1'000'000};
    for (int waited = 0; g_naming.load() > 0 && waited < 2000; ++waited) ::nanosleep(&ms, nullptr);
}

// The stopping signals as a set (the handler's mask, and what a commit blocks on its thread).
sigset_t stop_signal_set() {
    sigset_t set;
    sigemptyset(&set);
    for (int sig : kStopSignals) sigaddset(&set, sig);
    return set;
}

// The program's one line on a stopping signal, written with write(2) alone (async-signal-safe).
template <std::size_t N>
void write_line(const char (&line)[N]) {
    if (::write(STDERR_FILENO, line, N - 1) < 0) return;  // a stderr that cannot take it changes nothing
}

void say_stopped_by(int sig) {
    if (g_stop_said.exchange(true)) return;
    switch (sig) {
        case SIGINT: return write_line("lensfx: stopped by SIGINT (no output file is left half-written)\n");
        case SIGTERM: return write_line("lensfx: stopped by SIGTERM (no output file is left half-written)\n");
        case SIGHUP: return write_line("lensfx: stopped by SIGHUP (no output file is left half-written)\n");
        default: return write_line("lensfx: stopped by SIGQUIT (no output file is left half-written)\n");
    }
}

// The temporaries removed and the line written, then the signal's default action: the caller (a shell running
// a loop of lensfx commands) sees the program killed by that signal and stops too.
extern "C" void remove_temporaries_and_die(int sig) {
    g_stopping.store(true);
    wait_for_commits_under_way();
    for (Slot& s : g_slots) {
        if (s.state.load() == kReady) ::unlink(s.path);
    }
    say_stopped_by(sig);
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

void install_handlers_once() {
    static std::once_flag once;
    std::call_once(once, [] {
        struct sigaction sa {};
        sa.sa_handler = remove_temporaries_and_die;
        sa.sa_mask = stop_signal_set();  // one stopping signal handled at a time
        for (int sig : kStopSignals) {
            struct sigaction old {};
            ::sigaction(sig, nullptr, &old);
            if (old.sa_handler == SIG_IGN) continue;  // nohup: an ignored signal stays ignored
            ::sigaction(sig, &sa, nullptr);
        }
    });
}

// A slot holding `path`, or -1 when all are taken (the file is then only removed by a later run).
int register_temporary(const std::string& path) {
    if (path.size() >= kPathMax) return -1;
    for (int i = 0; i < kSlots; ++i) {
        int expected = kFree;
        if (g_slots[i].state.compare_exchange_strong(expected, kFilling)) {
            std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
            g_slots[i].state.store(kReady);
            return i;
        }
    }
    return -1;
}

void unregister_temporary(int slot) {
    if (slot < 0) return;
    g_slots[slot].state.store(kFilling);
    g_slots[slot].state.store(kFree);
}

// The PID in a temporary's name, or 0 when the name is not one of ours.
long temporary_pid(const std::string& name) {
    if (name.empty() || name[0] != '.') return 0;
    const auto tag = name.rfind(kTempTag);
    if (tag == std::string::npos) return 0;
    long pid = 0;
    std::size_t i = tag + kTempTag.size();
    for (; i < name.size() && name[i] >= '0' && name[i] <= '9' && pid < 1'000'000'000; ++i) pid = pid * 10 + (name[i] - '0');
    const bool ends = i == name.size() || name[i] == '.';
    return ends && i > tag + kTempTag.size() ? pid : 0;
}

// What a file that is not a regular one is, for a message.
const char* kind_of(mode_t mode) {
    return S_ISDIR(mode) ? "a directory" : S_ISFIFO(mode) ? "a named pipe" : S_ISCHR(mode) || S_ISBLK(mode) ? "a device" : "a special file";
}

// What `path` (a link followed) is when it exists and is no regular file ("a named pipe"..., or a loop of links);
// nullptr for a regular file or a missing one. The one check of TempFile and require_regular_file.
const char* special_kind(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return errno == ELOOP ? "a link that leads to no file (a loop)" : nullptr;
    return S_ISREG(st.st_mode) ? nullptr : kind_of(st.st_mode);
}

using FileId = std::pair<dev_t, ino_t>;

std::optional<FileId> file_id(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return std::nullopt;
    return FileId{st.st_dev, st.st_ino};
}

// The same file: one inode, or (when it does not exist yet) one path once normalised.
bool same_file(const std::string& a, const std::string& b) {
    const auto ia = file_id(a), ib = file_id(b);
    if (ia && ib) return *ia == *ib;
    std::error_code ec;
    return fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec);
}

// Whether `path` is one of the files a file name or frame pattern names ("-": none).
bool names_file_of(const std::string& pattern_text, const std::string& path) {
    if (pattern_text.empty() || pattern_text == "-") return false;
    const FramePattern pattern = parse_pattern(pattern_text);
    if (!pattern.is_sequence) return same_file(pattern_text, path);
    std::error_code ec;
    const std::string absolute = fs::weakly_canonical(path, ec).string();
    const std::string dir = fs::weakly_canonical(fs::path(pattern.prefix).parent_path().empty() ? "." : fs::path(pattern.prefix).parent_path(), ec).string();
    const FramePattern in_dir = parse_pattern((fs::path(dir) / fs::path(pattern_text).filename()).string());
    if (in_dir.match(absolute)) return true;
    const auto id = file_id(path);
    if (!id) return false;
    for (std::int64_t n : scan_frames(pattern))
        if (file_id(pattern.path(n)) == id) return true;
    return false;
}

void write_all(int fd, std::string_view bytes, const std::string& what) {
    while (!bytes.empty()) {
        const ssize_t n = ::write(fd, bytes.data(), bytes.size());
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) throw std::runtime_error(fmt::format("{}: write failed: {}", what, write_failure(n < 0 ? errno : ENOSPC)));
        bytes.remove_prefix(static_cast<std::size_t>(n));
    }
}

// Where a write to `path` lands: the file a symbolic link names (the link is kept and its file replaced),
// else `path` itself.
std::string written_path(const std::string& path) {
    std::error_code ec;
    if (!fs::is_symlink(path, ec)) return path;
    fs::path p = path;
    // each link read in turn, so that one to a file not made yet is written through to it (weakly_canonical stopped
    // at such a link, which the commit then found was no regular file); a loop is left a link, which special_kind names
    for (int hops = 0; hops < 40 && fs::is_symlink(p, ec); ++hops) {
        const fs::path to = fs::read_symlink(p, ec);
        if (ec) return path;
        p = to.is_absolute() ? to : p.parent_path() / to;
    }
    return p.lexically_normal().string();
}

// An unnamed file (O_TMPFILE) in `dir` that the writers can open again by /proc/self/fd/N (returned in `reopen`), or -1
// where the file system or the system cannot (NFS, no /proc, a umask that takes the owner's write permission away).
int open_unnamed(const std::string& dir, std::string& reopen) {
    const int fd = ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
    if (fd < 0) return -1;
    reopen = fmt::format("/proc/self/fd/{}", fd);
    if (::access(reopen.c_str(), W_OK) == 0) return fd;
    ::close(fd);
    return -1;
}

// The stopping signals held off on this thread while it lives: the handler then runs on another thread, which
// can wait for this one.
class StopSignalsHeld {
public:
    StopSignalsHeld() {
        const sigset_t set = stop_signal_set();
        ::pthread_sigmask(SIG_BLOCK, &set, &old_);
    }
    ~StopSignalsHeld() { ::pthread_sigmask(SIG_SETMASK, &old_, nullptr); }
    StopSignalsHeld(const StopSignalsHeld&) = delete;
    StopSignalsHeld& operator=(const StopSignalsHeld&) = delete;

private:
    sigset_t old_{};
};

// A commit under way, which the signal handler waits for. Once the program is stopping, no commit starts: this
// thread waits for the handler to end the program (bounded, then "stopped" is thrown).
class NamingUnderWay {
public:
    NamingUnderWay() {
        g_naming.fetch_add(1);
        if (!g_stopping.load()) return;
        g_naming.fetch_sub(1);
        std::this_thread::sleep_for(std::chrono::seconds(10));
        throw std::runtime_error("stopped by a signal");
    }
    ~NamingUnderWay() { g_naming.fetch_sub(1); }
    NamingUnderWay(const NamingUnderWay&) = delete;
    NamingUnderWay& operator=(const NamingUnderWay&) = delete;
};

// Links the unnamed file `reopen` names (/proc/self/fd/N) as `path`; one left there by a dead process with this
// PID is replaced.
void link_unnamed(const std::string& reopen, const std::string& path) {
    int error = 0;
    for (int attempt = 0; attempt < 2; ++attempt) {
        if (::linkat(AT_FDCWD, reopen.c_str(), AT_FDCWD, path.c_str(), AT_SYMLINK_FOLLOW) == 0) return;
        error = errno;
        if (error != EEXIST) break;
        ::unlink(path.c_str());
    }
    throw std::runtime_error(fmt::format("cannot name the written file {}: {}", path, std::strerror(error)));
}

// A temporary's name in the signal handler's registry while this lives (when a slot is free).
class RegisteredTemporary {
public:
    explicit RegisteredTemporary(const std::string& path) : slot_(register_temporary(path)) {}
    ~RegisteredTemporary() { unregister_temporary(slot_); }
    RegisteredTemporary(const RegisteredTemporary&) = delete;
    RegisteredTemporary& operator=(const RegisteredTemporary&) = delete;

private:
    int slot_;
};

// Renames `from` onto `to`; throws naming both when it cannot.
void rename_into_place(const std::string& from, const std::string& to) {
    std::error_code ec;
    fs::rename(from, to, ec);
    if (ec) throw std::runtime_error(fmt::format("cannot rename {} to {}: {}", from, to, ec.message()));
}

constexpr std::size_t kNameMax = 255;  // bytes of a file name (NAME_MAX on Linux's file systems)

// ".NAME.lensfx-PID.EXT" for target NAME.EXT; where that would pass kNameMax, NAME is cut and a hash of the whole of it
// added ("~" and 16 hex digits), so that a long target name that is legal has a legal temporary too.
std::string temporary_name(const fs::path& target) {
    const std::string stem = target.stem().string(), ext = target.extension().string();
    const std::string tail = fmt::format("{}{}{}", kTempTag, ::getpid(), ext);
    if (1 + stem.size() + tail.size() <= kNameMax) return fmt::format(".{}{}", stem, tail);
    const std::string hash = fmt::format("~{:016x}", std::hash<std::string>{}(stem));
    const std::size_t room = kNameMax > 1 + hash.size() + tail.size() ? kNameMax - 1 - hash.size() - tail.size() : 0;
    return fmt::format(".{}{}{}", std::string_view(stem).substr(0, room), hash, tail);
}

}  // namespace

void handle_stopping_signals() { install_handlers_once(); }

TempFile::TempFile(const std::string& target) : name_(target), target_(written_path(target)) {
    install_handlers_once();  // also at the start of main (handle_stopping_signals); here for library users
    // A device, named pipe or directory is never replaced by a file (as root, /dev/null could be).
    if (const char* kind = special_kind(target_)) {
        const std::string link = target_ == target ? std::string() : fmt::format(" (a link to {})", target_);
        throw std::runtime_error(fmt::format("{}{}: {}, not a regular file", target, link, kind));
    }
    const fs::path t(target_);
    path_ = (t.parent_path() / temporary_name(t)).string();
    fd_ = open_unnamed(t.parent_path().empty() ? "." : t.parent_path().string(), write_path_);
    if (fd_ >= 0) return;
    write_path_ = path_;  // a named temporary from the start, in the handler's registry
    slot_ = register_temporary(path_);
}

TempFile::~TempFile() {
    if (fd_ >= 0) ::close(fd_);  // an unnamed file not committed is gone with its last descriptor
    if (!committed_ && fd_ < 0) {
        std::error_code ec;
        fs::remove(path_, ec);
    }
    unregister_temporary(slot_);
}

void TempFile::write(const std::function<void(const std::string&)>& write_to) {
    try {
        write_to(write_path_);
    } catch (const std::exception& e) {
        std::string message = e.what();
        for (auto at = message.find(write_path_); at != std::string::npos; at = message.find(write_path_, at + name_.size()))
            message.replace(at, write_path_.size(), name_);
        throw std::runtime_error(message);
    }
}

void TempFile::commit() {
    // Checked again: what the name holds may have changed while the file was written.
    struct stat st {};
    if (::lstat(target_.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
        throw std::runtime_error(fmt::format("{}: {} now, not a regular file; left as it is", target_, kind_of(st.st_mode)));
    if (fd_ >= 0) name_onto_target();
    else rename_into_place(path_, target_);
    committed_ = true;
}

void TempFile::name_onto_target() {
    const StopSignalsHeld held;
    const NamingUnderWay naming;
    const RegisteredTemporary registered(path_);  // for a handler that gave up waiting
    link_unnamed(write_path_, path_);
    try {
        rename_into_place(path_, target_);
    } catch (...) {
        std::error_code ec;
        fs::remove(path_, ec);  // the link just made; the unnamed file goes with its descriptor
        throw;
    }
}

void require_writable_file(const std::string& path, std::string_view option) {
    refuse_special_output(path, option);  // a device, pipe, directory or link loop, said with the option
    TempFile probe(path);  // refuses a device, pipe or directory; gone again, uncommitted, at the end of this scope
    const int fd = ::open(probe.path().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) throw std::runtime_error(fmt::format("{} {}: cannot write a file there: {}", option, path, std::strerror(errno)));
    const bool wrote = ::write(fd, "{", 1) == 1;
    const int error = errno;
    ::close(fd);
    if (!wrote) throw std::runtime_error(fmt::format("{} {}: cannot write a file there: {}", option, path, write_failure(error)));
}

void write_file(const std::string& path, std::string_view bytes) {
    TempFile tmp(path);
    const int fd = ::open(tmp.path().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) throw std::runtime_error(fmt::format("{}: cannot create: {}", path, std::strerror(errno)));
    try {
        write_all(fd, bytes, path);
    } catch (...) {
        ::close(fd);
        throw;
    }
    if (::close(fd) != 0) throw std::runtime_error(fmt::format("{}: write failed: {}", path, write_failure(errno)));
    tmp.commit();
}

std::string write_failure(int error) {
    return error == EPIPE ? "the output pipe was closed by its reader" : std::strerror(error);
}

void write_stdout(std::string_view bytes) {
    if (std::fflush(stdout) != 0) throw std::runtime_error(fmt::format("stdout: write failed: {}", write_failure(errno)));
    write_all(STDOUT_FILENO, bytes, "stdout");
}

std::size_t remove_stale_temporaries(const std::string& dir) {
    std::size_t removed = 0;
    std::error_code ec;
    for (fs::directory_iterator it(dir.empty() ? "." : dir, ec), end; !ec && it != end; it.increment(ec)) {
        const long pid = temporary_pid(it->path().filename().string());
        if (pid <= 0 || pid == ::getpid() || !process_is_gone(pid)) continue;
        std::error_code rm;
        if (it->is_regular_file(rm) && fs::remove(it->path(), rm)) ++removed;
    }
    return removed;
}

void refuse_special_output(const std::string& path, std::string_view option) {
    if (path.empty() || path == "-") return;
    require_regular_file(path, option);
    require_output_directory(path);
}

void require_output_directory(const std::string& path) {
    fs::path dir = fs::path(written_path(path)).parent_path();  // a link's target's folder: the file goes there
    if (dir.empty()) dir = ".";
    if (!fs::is_directory(dir)) {
        std::error_code ec;
        const bool exists = fs::exists(dir, ec);
        throw std::runtime_error(fmt::format("{}: output directory {} {}", path, dir.string(), exists ? "is not a directory" : "does not exist"));
    }
    if (::access(dir.c_str(), W_OK) != 0) throw std::runtime_error(fmt::format("{}: output directory {} is not writable", path, dir.string()));
}

void refuse_overwrite(const std::string& path, std::string_view option, const std::string& input, const std::string& other_output) {
    if (path.empty() || path == "-") return;
    if (names_file_of(input, path)) throw std::runtime_error(fmt::format("{} {}: refusing to overwrite an input file", option, path));
    if (names_file_of(other_output, path)) throw std::runtime_error(fmt::format("{} {}: refusing to overwrite the output {}", option, path, other_output));
}

void require_regular_file(const std::string& path, std::string_view what) {
    const char* kind = special_kind(path);
    if (!kind) return;  // a regular file, or a missing one: the reader says so
    const std::string where = what.empty() ? std::string() : fmt::format("{} {}: ", what, path);
    throw std::runtime_error(fmt::format("{}{}, not a regular file", where, kind));
}

}  // namespace lensfx::filter
