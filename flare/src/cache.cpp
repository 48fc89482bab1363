// The disk cache's folder rule, key hash and atomic writer (cache.h).
#include <flare/cache.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <system_error>
#include <thread>

#include <fmt/core.h>

#include <optics/process_liveness.h>

namespace lensfx::flare {

std::string default_cache_dir() {
    if (const char* dir = std::getenv("LENSFX_CACHE_DIR"); dir && *dir) return std::string(dir) == "none" ? std::string() : dir;
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) return std::string(xdg) + "/lensfx";
    if (const char* home = std::getenv("HOME"); home && *home) return std::string(home) + "/.cache/lensfx";
    return {};
}

std::string cache_dir_of(const std::string& option) {
    if (option == "none") return {};
    return option.empty() ? default_cache_dir() : option;
}

void KeyHash::bytes(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) {
        h ^= p[i];
        h *= 0x100000001b3ull;
    }
}

void KeyHash::text(const std::string& s) {
    num(static_cast<std::int64_t>(s.size()));
    bytes(s.data(), s.size());
}

std::uint64_t key_hash(std::string_view key) {
    KeyHash h;
    h.bytes(key.data(), key.size());
    return h.h;
}

namespace {

void add_glass(KeyHash& f, const optics::Glass& g) {
    f.text(g.name);
    f.num(static_cast<std::int64_t>(g.formula));
    f.num(static_cast<std::int64_t>(g.coefficients.size()));
    for (double c : g.coefficients) f.num(c);
    f.num(g.nd);
    f.num(g.vd);
}

// A temporary name beside path, unique to this process and thread.
std::string temporary_beside(const std::string& path) {
    return fmt::format("{}.{}.{:x}.tmp", path, static_cast<long>(::getpid()), std::hash<std::thread::id>{}(std::this_thread::get_id()));
}

// Removes the temporaries of `path` (temporary_beside's names) left by processes that no longer run: a run
// stopped by a signal while it wrote a cache file left its temporary for good.
void remove_stale_temporaries_of(const std::string& path) {
    const std::filesystem::path target(path);
    const std::string prefix = target.filename().string() + ".";
    std::error_code ec;
    for (std::filesystem::directory_iterator it(target.parent_path().empty() ? "." : target.parent_path(), ec), end; !ec && it != end;
         it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.size() <= prefix.size() + 4 || name.compare(0, prefix.size(), prefix) != 0 || !name.ends_with(".tmp")) continue;
        char* digits_end = nullptr;
        const long pid = std::strtol(name.c_str() + prefix.size(), &digits_end, 10);
        if (pid <= 0 || *digits_end != '.' || pid == static_cast<long>(::getpid())) continue;
        if (process_is_gone(pid)) {
            std::error_code ignored;
            std::filesystem::remove(it->path(), ignored);
        }
    }
}

}  // namespace

std::uint64_t system_hash(const optics::System& system) {
    KeyHash f;
    f.text("lensfx bounds v2");
    f.text(system.name);
    f.num(static_cast<std::int64_t>(system.interfaces.size()));
    for (const optics::System::Interface& s : system.interfaces) {
        f.num(s.radius_mm);
        f.num(s.z_mm);
        f.num(s.semi_diameter_mm);
        add_glass(f, s.before);
        add_glass(f, s.after);
        f.num(static_cast<std::int64_t>(s.coating.kind));
        f.num(s.coating.design_wavelength_nm);
        f.num(s.coating.layer_index);
        f.num(s.coating.thickness_offset);
        f.num(static_cast<std::int64_t>(s.coating.layers.size()));
        for (const optics::Coating::Layer& layer : s.coating.layers) {
            add_glass(f, layer.material);
            f.num(layer.thickness_nm);
        }
        f.num(static_cast<std::int64_t>(s.coating.design));
        f.num(static_cast<std::int64_t>(s.coating.layer_errors.size()));
        for (double e : s.coating.layer_errors) f.num(e);
        f.num(static_cast<std::int64_t>(s.is_stop));
        f.num(s.conic);
        f.num(static_cast<std::int64_t>(s.aspheric.size()));
        for (double a : s.aspheric) f.num(a);
    }
    f.num(static_cast<std::int64_t>(system.stop));
    f.num(system.sensor_z_mm);
    f.num(static_cast<std::int64_t>(system.aperture.blades));
    f.num(system.aperture.rotation_deg);
    f.num(system.aperture.blade_curvature);
    return f.h;
}

std::string cache_file(const std::string& dir, std::string_view kind, std::uint64_t hash) {
    return (std::filesystem::path(dir) / fmt::format("{}-{:016x}.bin", kind, hash)).string();
}

void write_cache_file(const std::string& path, const std::function<void(std::ostream&)>& write) {
    const std::filesystem::path folder = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!folder.empty()) std::filesystem::create_directories(folder, ec);
    if (ec) throw std::runtime_error(fmt::format("{}: cannot create the cache directory: {}", folder.string(), ec.message()));
    const std::string temporary = temporary_beside(path);
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        if (out) write(out);
        out.close();
        if (!out) {
            std::filesystem::remove(temporary, ec);
            throw std::runtime_error(fmt::format("{}: cannot write the cache file", temporary));
        }
    }
    std::filesystem::rename(temporary, path, ec);
    if (ec) {
        std::error_code ignored;
        std::filesystem::remove(temporary, ignored);
        throw std::runtime_error(fmt::format("{}: cannot write the cache file: {}", path, ec.message()));
    }
    remove_stale_temporaries_of(path);
}

bool try_write_cache_file(const std::string& path, const std::function<void(std::ostream&)>& write) {
    try {
        write_cache_file(path, write);
        return true;
    } catch (const std::exception&) {
        return false;
    }
}

void write_key(std::ostream& out, std::string_view key) {
    const auto size = static_cast<std::uint64_t>(key.size());
    out.write(reinterpret_cast<const char*>(&size), sizeof size);
    out.write(key.data(), static_cast<std::streamsize>(key.size()));
}

// A read-only stream buffer over an open descriptor (closed with it) that gives at most `left` bytes.
class CacheFile::Buffer : public std::streambuf {
public:
    Buffer(int fd, std::uintmax_t left) : fd_(fd), left_(left) {}
    ~Buffer() override { ::close(fd_); }
    Buffer(const Buffer&) = delete;
    Buffer& operator=(const Buffer&) = delete;

protected:
    int_type underflow() override {
        if (gptr() == egptr()) {
            const std::size_t got = read_some(chunk_.data(), chunk_.size());
            if (got == 0) return traits_type::eof();
            setg(chunk_.data(), chunk_.data(), chunk_.data() + got);
        }
        return traits_type::to_int_type(*gptr());
    }
    // What the buffer holds, then large reads straight into the caller's memory (tables of megabytes).
    std::streamsize xsgetn(char* to, std::streamsize n) override {
        std::streamsize done = 0;
        while (done < n) {
            if (gptr() == egptr()) {
                const auto want = static_cast<std::size_t>(n - done);
                if (want >= chunk_.size()) {
                    const std::size_t got = read_some(to + done, want);
                    if (got == 0) break;
                    done += static_cast<std::streamsize>(got);
                    continue;
                }
                if (traits_type::eq_int_type(underflow(), traits_type::eof())) break;
            }
            const std::streamsize k = std::min(n - done, static_cast<std::streamsize>(egptr() - gptr()));
            std::memcpy(to + done, gptr(), static_cast<std::size_t>(k));
            gbump(static_cast<int>(k));
            done += k;
        }
        return done;
    }

private:
    // Up to n bytes from the file, never past `left_`; 0 at its end or on an error.
    std::size_t read_some(char* to, std::size_t n) {
        const auto want = static_cast<std::size_t>(std::min<std::uintmax_t>(n, left_));
        if (want == 0) return 0;
        ssize_t got = 0;
        do got = ::read(fd_, to, want);
        while (got < 0 && errno == EINTR);
        if (got <= 0) {
            left_ = 0;
            return 0;
        }
        left_ -= static_cast<std::uintmax_t>(got);
        return static_cast<std::size_t>(got);
    }

    int fd_;
    std::uintmax_t left_;
    std::array<char, std::size_t{64} << 10> chunk_{};
};

CacheFile::CacheFile() : std::istream(nullptr) { setstate(std::ios::failbit); }
CacheFile::CacheFile(int fd, std::uintmax_t size)
    : std::istream(nullptr), buffer_(std::make_unique<Buffer>(fd, size)), size_(size) {
    rdbuf(buffer_.get());
}
CacheFile::~CacheFile() = default;

CacheFile open_cache_file(const std::filesystem::path& path, std::uintmax_t max_bytes) {
    // Open, then check what was opened: a name checked first could be swapped before the open.
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) return CacheFile();
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size < 0 || static_cast<std::uintmax_t>(st.st_size) > max_bytes) {
        ::close(fd);
        return CacheFile();
    }
    // A regular file's reads do not block; the flag served the open alone.
    if (const int flags = ::fcntl(fd, F_GETFL); flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
    return CacheFile(fd, static_cast<std::uintmax_t>(st.st_size));
}

bool read_key(std::istream& in, std::string_view key) {
    std::uint64_t size = 0;
    if (!in.read(reinterpret_cast<char*>(&size), sizeof size) || size != key.size()) return false;
    std::string stored(key.size(), '\0');
    return in.read(stored.data(), static_cast<std::streamsize>(stored.size())) && stored == key;
}

}  // namespace lensfx::flare
