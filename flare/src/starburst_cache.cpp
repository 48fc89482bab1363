// The starburst texture's disk cache (starburst_cache.h): one file per iris and texture setting, holding
// the whole key, so a changed iris or a damaged file never gives a stale texture.
#include <flare/starburst_cache.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>

#include <fmt/core.h>
#include <flare/cache.h>

namespace lensfx::flare {

namespace {

constexpr char kStarburstMagic[] = "lensfx-starburst-2";

// Everything a texture depends on: the iris and every texture setting.
std::string starburst_key(const optics::Aperture& a, const optics::StarburstOptions& o) {
    std::string key = fmt::format("b{} r{:.17g} c{:.17g} s{} p{} {:g} {:g} {:g} {:g}", a.blades, a.rotation_deg, a.blade_curvature,
                                  o.size, o.pupil_samples, o.first_nm, o.last_nm, o.step_nm, o.smoothing);
    for (double v : o.xyz_to_rgb) key += fmt::format(" {:.17g}", v);
    const optics::PupilImperfections& d = o.dirt;
    key += fmt::format(" dust {:.17g} {:.17g} {:.17g} scratches {} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} seed {}", d.dust_density,
                       d.dust_radius, d.dust_opacity, d.scratches, d.scratch_length, d.scratch_width, d.scratch_angle_deg,
                       d.scratch_spread_deg, d.scratch_opacity, d.seed);
    if (!o.image.empty()) {
        key += fmt::format(" image {}x{} ", o.image.width, o.image.height);
        key.append(reinterpret_cast<const char*>(o.image.value.data()), o.image.value.size() * sizeof(float));
    }
    return key;
}

// A texture as the starburst code makes it (starburst.h): texels in [0, 1], each channel summing to 1 (or all
// 0). A file's NaN or huge texels put NaN into the frame and took the added light's core away.
bool normalised(const std::vector<float>& rgb) {
    std::array<double, 3> sum{};
    for (std::size_t i = 0; i < rgb.size(); ++i) {
        if (!(rgb[i] >= 0.0f && rgb[i] <= 1.0f)) return false;
        sum[i % 3] += static_cast<double>(rgb[i]);
    }
    return std::all_of(sum.begin(), sum.end(), [](double s) { return s == 0.0 || std::abs(s - 1.0) < 1e-3; });
}

std::optional<optics::Starburst> read_starburst(const std::string& path, const std::string& key) {
    CacheFile in = open_cache_file(path);
    if (!in) return std::nullopt;
    char magic[sizeof(kStarburstMagic)] = {};
    optics::Starburst sb;
    std::int32_t size = 0;
    in.read(magic, sizeof(magic));
    if (!in || std::string(magic, sizeof(magic) - 1) != kStarburstMagic || !read_key(in, key)) return std::nullopt;
    in.read(reinterpret_cast<char*>(&size), sizeof(size));
    in.read(reinterpret_cast<char*>(&sb.texel_per_fnumber_mm), sizeof(sb.texel_per_fnumber_mm));
    if (!in || size < 16 || size > 8192 ||
        !(sb.texel_per_fnumber_mm > 0.0))
        return std::nullopt;
    sb.size = size;
    sb.rgb.resize(static_cast<std::size_t>(size) * static_cast<std::size_t>(size) * 3);
    in.read(reinterpret_cast<char*>(sb.rgb.data()), static_cast<std::streamsize>(sb.rgb.size() * sizeof(float)));
    if (!in || in.peek() != std::char_traits<char>::eof() || !normalised(sb.rgb)) return std::nullopt;
    return sb;
}

void write_starburst(const std::string& path, const std::string& key, const optics::Starburst& sb) {
    try_write_cache_file(path, [&](std::ostream& out) {
        const std::int32_t size = sb.size;
        out.write(kStarburstMagic, sizeof(kStarburstMagic));
        write_key(out, key);
        out.write(reinterpret_cast<const char*>(&size), sizeof(size));
        out.write(reinterpret_cast<const char*>(&sb.texel_per_fnumber_mm), sizeof(sb.texel_per_fnumber_mm));
        out.write(reinterpret_cast<const char*>(sb.rgb.data()), static_cast<std::streamsize>(sb.rgb.size() * sizeof(float)));
    });
}

}  // namespace

optics::Starburst cached_starburst(const optics::Aperture& aperture, const optics::StarburstOptions& options,
                                   const std::string& cache_dir) {
    if (cache_dir.empty()) return optics::make_starburst(aperture, options);
    const std::string key = starburst_key(aperture, options);
    const std::string path = cache_file(cache_dir, "starburst", key_hash(key));
    if (auto cached = read_starburst(path, key)) return std::move(*cached);
    optics::Starburst sb = optics::make_starburst(aperture, options);
    write_starburst(path, key, sb);
    return sb;
}

}  // namespace lensfx::flare
