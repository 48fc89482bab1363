// The ray table's disk cache (see ray_cache.h).
#include <dof/ray_cache.h>


#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>

#include <fmt/core.h>
#include <flare/cache.h>
#include <optics/stopwatch.h>

namespace lensfx::dof {

namespace {

constexpr char kMagic[8] = {'L', 'F', 'X', 'D', 'O', 'F', 'R', '2'};
constexpr int kMaxGrid = 4096;
constexpr int kMaxSamples = 1 << 16;
constexpr int kMaxChannels = 128;

// FNV-1a over the bytes written after the magic: a changed byte anywhere is seen.
struct Checksum {
    std::uint64_t h = 0xcbf29ce484222325ull;
    void add(const void* data, std::size_t n) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
    }
};

// Shape and scalars of a table, as stored.
struct Header {
    std::int32_t grid_x = 0, grid_y = 0, samples = 0, channels = 0, achromatic = 0, reserved = 0;
    double cell_w = 0, cell_h = 0, focus_w = 0, max_slope = 0, focus_spread = 0;
};

std::size_t entries(const Header& h) {
    return static_cast<std::size_t>(h.channels) * static_cast<std::size_t>(h.grid_x) * static_cast<std::size_t>(h.grid_y) *
           static_cast<std::size_t>(h.samples);
}

bool plausible(const Header& h) {
    return h.grid_x >= 2 && h.grid_x <= kMaxGrid && h.grid_y >= 2 && h.grid_y <= kMaxGrid && h.samples >= 1 &&
           h.samples <= kMaxSamples && h.channels >= 1 && h.channels <= kMaxChannels && h.achromatic >= 0 && h.achromatic < h.channels &&
           h.reserved == 0 && std::isfinite(h.cell_w) && h.cell_w > 0 &&
           std::isfinite(h.cell_h) && h.cell_h > 0 && std::isfinite(h.focus_w) && std::isfinite(h.max_slope) && h.max_slope >= 0 &&
           std::isfinite(h.focus_spread) && h.focus_spread >= 0;
}

// Reads exactly n bytes into data and adds them to the checksum.
bool read_bytes(std::istream& in, void* data, std::size_t n, Checksum& sum) {
    if (!in.read(static_cast<char*>(data), static_cast<std::streamsize>(n))) return false;
    sum.add(data, n);
    return true;
}

void write_bytes(std::ostream& out, const void* data, std::size_t n, Checksum& sum) {
    out.write(static_cast<const char*>(data), static_cast<std::streamsize>(n));
    sum.add(data, n);
}

bool all_finite(const RayTable& t) {
    for (const auto& w : t.channel_weight)
        for (float v : w)
            if (!std::isfinite(v)) return false;
    for (const auto& l : t.line)
        for (float v : l)
            if (!std::isfinite(v)) return false;
    for (float w : t.weight)
        if (!(w == 0.0f || w == 1.0f)) return false;
    return true;
}

}  // namespace

std::string ray_table_key(const Camera& c, int samples, int grid) {
    std::string key = fmt::format("lensfx dof rays v3 system {:016x} focus {:.17g} sensor {:.17g} raster {}x{} display {:.17g} "
                                  "centre {:.17g},{:.17g} tilt {:.17g},{:.17g} samples {} grid {}",
                                  flare::system_hash(c.system), c.focus_m, c.sensor_width_mm, c.width, c.height, c.display_width,
                                  c.centre_x, c.centre_y, c.tilt_x_deg, c.tilt_y_deg, samples, grid);
    key += fmt::format(" surface {:.17g}", c.focus_power);
    for (const FocusPoint& p : c.focus_points) key += fmt::format(" {:.17g},{:.17g},{:.17g}", p.x, p.y, p.metres);
    key += " bands";
    for (const Band& b : bands_of(c)) key += fmt::format(" {:.17g}:{:.17g},{:.17g},{:.17g}", b.wavelength_nm, b.weight[0], b.weight[1], b.weight[2]);
    return key;
}

std::string ray_table_path(const std::string& dir, const std::string& key) {
    return flare::cache_file(dir, "dof-rays", flare::key_hash(key));
}

std::optional<RayTable> read_ray_table(const std::string& path, const std::string& key) {
    flare::CacheFile in = flare::open_cache_file(path);  // a FIFO or device under the name is a miss, not a wait
    if (!in) return std::nullopt;
    const std::uintmax_t file_size = in.size();  // of the file opened, not of whatever holds the name now
    char magic[sizeof kMagic] = {};
    Checksum sum;
    std::uint64_t key_size = 0;
    if (!in.read(magic, sizeof magic) || std::string(magic, sizeof magic) != std::string(kMagic, sizeof kMagic) ||
        !read_bytes(in, &key_size, sizeof key_size, sum) || key_size != key.size())
        return std::nullopt;
    std::string stored(key.size(), '\0');
    Header h;
    if (!read_bytes(in, stored.data(), stored.size(), sum) || stored != key || !read_bytes(in, &h, sizeof h, sum) || !plausible(h))
        return std::nullopt;
    const std::size_t n = entries(h);
    const std::size_t weights = 3 * static_cast<std::size_t>(h.channels);
    const std::size_t expected =
        sizeof kMagic + sizeof key_size + key.size() + sizeof h + weights * sizeof(float) + n * (sizeof(float) * 5) + sizeof(std::uint64_t);
    if (file_size != expected) return std::nullopt;  // truncated or padded: before allocating by the header
    RayTable t;
    t.grid_x = h.grid_x, t.grid_y = h.grid_y, t.samples = h.samples, t.channels = h.channels, t.achromatic = h.achromatic;
    t.channel_weight.resize(static_cast<std::size_t>(h.channels));
    t.cell_w = h.cell_w, t.cell_h = h.cell_h, t.focus_w = h.focus_w, t.max_slope = h.max_slope, t.focus_spread = h.focus_spread;
    t.line.resize(n);
    t.weight.resize(n);
    std::uint64_t stored_sum = 0;
    if (!read_bytes(in, t.channel_weight.data(), weights * sizeof(float), sum) || !read_bytes(in, t.line.data(), n * sizeof(t.line[0]), sum) || !read_bytes(in, t.weight.data(), n * sizeof(float), sum) ||
        !in.read(reinterpret_cast<char*>(&stored_sum), sizeof stored_sum) || stored_sum != sum.h || !all_finite(t))
        return std::nullopt;
    return t;
}

bool write_ray_table(const std::string& path, const std::string& key, const RayTable& t) {
    return flare::try_write_cache_file(path, [&](std::ostream& out) {
        Checksum sum;
        const std::uint64_t key_size = key.size();
        const Header h{t.grid_x, t.grid_y, t.samples, t.channels, t.achromatic, 0, t.cell_w, t.cell_h, t.focus_w, t.max_slope, t.focus_spread};
        out.write(kMagic, sizeof kMagic);
        write_bytes(out, &key_size, sizeof key_size, sum);
        write_bytes(out, key.data(), key.size(), sum);
        write_bytes(out, &h, sizeof h, sum);
        write_bytes(out, t.channel_weight.data(), t.channel_weight.size() * sizeof(t.channel_weight[0]), sum);
        write_bytes(out, t.line.data(), t.line.size() * sizeof(t.line[0]), sum);
        write_bytes(out, t.weight.data(), t.weight.size() * sizeof(float), sum);
        out.write(reinterpret_cast<const char*>(&sum.h), sizeof sum.h);
    });
}

RayTable cached_ray_table(const Camera& camera, int samples, int grid, const std::string& dir, RayTableSource* source) {
    const auto start = std::chrono::steady_clock::now();
    RayTableSource s;
    std::optional<RayTable> table;
    std::string key, path;
    if (!dir.empty()) {
        key = ray_table_key(camera, samples, grid);
        path = ray_table_path(dir, key);
        table = read_ray_table(path, key);
        s.loaded = table.has_value();
        std::error_code ec;
        s.rejected = !table && std::filesystem::exists(path, ec);
    }
    if (!table) {
        table = make_ray_table(camera, samples, grid);
        if (!dir.empty()) s.saved = write_ray_table(path, key, *table);
    }
    s.ms = ms_since(start);
    if (source) *source = s;
    return std::move(*table);
}

}  // namespace lensfx::dof
