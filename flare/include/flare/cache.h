// The disk cache of what the program computes once per lens and reuses (ghost bounds tables, direct-power
// tables, starburst textures, the lens blur's ray tables): one folder rule, one key hash, one atomic writer.
// Each file is <folder>/<kind>-<16 hex digits of its key's hash>.bin and holds its whole key, so a reader
// rejects a foreign, stale, truncated or damaged file and the value is computed again; a cache that cannot
// be written only costs time.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <istream>
#include <memory>
#include <string>
#include <string_view>

#include <optics/system.h>

namespace lensfx::flare {

// The folder when --cache-dir is not given: $LENSFX_CACHE_DIR ("none": empty), else $XDG_CACHE_HOME/lensfx,
// else $HOME/.cache/lensfx, else empty (no disk cache).
std::string default_cache_dir();
// The folder a --cache-dir value names: empty -> default_cache_dir(); "none" -> empty (no disk cache).
std::string cache_dir_of(const std::string& option);

// The one key hash: 64-bit FNV-1a over the bytes given, in order.
struct KeyHash {
    std::uint64_t h = 0xcbf29ce484222325ull;
    void bytes(const void* data, std::size_t n);
    void num(double v) { bytes(&v, sizeof v); }
    void num(std::int64_t v) { bytes(&v, sizeof v); }
    void text(const std::string& s);  // its length, then its bytes
};
std::uint64_t key_hash(std::string_view key);

// A stable hash of everything about a system that changes what is traced through it: every interface
// (shape, position, media, coatings), the stop, the sensor and the iris.
std::uint64_t system_hash(const optics::System& system);

// <dir>/<kind>-<hash as 16 hex digits>.bin
std::string cache_file(const std::string& dir, std::string_view kind, std::uint64_t hash);

// Writes a cache file atomically: its folder made, `write` filling a temporary beside it (unique to this
// process and thread), renamed into place; the temporary is removed when a step fails. Throws
// std::runtime_error naming the file and the reason.
void write_cache_file(const std::string& path, const std::function<void(std::ostream&)>& write);
// The same, returning false instead of throwing (callers for which the cache is best effort).
bool try_write_cache_file(const std::string& path, const std::function<void(std::ostream&)>& write);

// The largest cache file a reader takes by default: above any file the tool writes (a starburst texture
// is at most 8192^2 RGB floats, 805 MB); each reader bounds what it allocates by its own header too.
inline constexpr std::uintmax_t kMaxCacheFileBytes = std::uintmax_t{4} << 30;

// A cache file opened for reading, or a miss when the name is not a regular file of at most max_bytes: a
// FIFO or device left in the cache folder would otherwise block or feed the reader for ever, and a huge
// file fill its memory. Opened first (not following a symbolic link; non-blocking, so a FIFO does not wait
// for a writer) and then checked through the open descriptor, so the name cannot be swapped for something
// else between the check and the open.
class CacheFile;
CacheFile open_cache_file(const std::filesystem::path& path, std::uintmax_t max_bytes = kMaxCacheFileBytes);

// A cache file open for reading (open_cache_file): an input stream over the descriptor that was opened and
// checked, so what is read is the file that passed the checks even if the name is replaced meanwhile, and no
// more than the size it had then. A miss is a stream that fails at once. Neither copied nor moved.
class CacheFile : public std::istream {
public:
    CacheFile();  // a miss
    ~CacheFile() override;
    CacheFile(const CacheFile&) = delete;
    CacheFile& operator=(const CacheFile&) = delete;

    bool is_open() const { return buffer_ != nullptr; }
    // The file's size when it was opened, in bytes (0 for a miss).
    std::uintmax_t size() const { return size_; }

private:
    class Buffer;  // reads the descriptor, at most size_ bytes
    CacheFile(int fd, std::uintmax_t size);
    friend CacheFile open_cache_file(const std::filesystem::path& path, std::uintmax_t max_bytes);

    std::unique_ptr<Buffer> buffer_;
    std::uintmax_t size_ = 0;
};

// The key as a file stores it (its length as uint64, then its bytes), and whether a stream holds exactly it.
void write_key(std::ostream& out, std::string_view key);
bool read_key(std::istream& in, std::string_view key);

}  // namespace lensfx::flare
