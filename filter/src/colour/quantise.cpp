// Quantisation of display-referred pixels with Bayer or blue-noise dither (filter/colour/quantise.h).
#include <filter/colour/quantise.h>

#include <algorithm>
#include <initializer_list>
#include <cctype>
#include <cmath>
#include <limits>
#include <string>

#include "pixel_ops.h"

namespace lensfx::colour {

namespace {

// The lower-case extension of a path, or the whole text when it has no dot ("png" or "out.PNG").
std::string lower_extension_of(std::string_view path) {
    const auto dot = path.rfind('.');
    std::string ext(dot == std::string_view::npos ? path : path.substr(dot + 1));
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
    return ext;
}

bool is_one_of(const std::string& ext, std::initializer_list<const char*> extensions) {
    return std::any_of(extensions.begin(), extensions.end(), [&](const char* e) { return ext == e; });
}

}  // namespace

// Every extension of the formats lensfx writes as 8- or 16-bit integers (image_io's write_image: all OpenImageIO
// writes but TIFF and Radiance HDR), by format: PNG, JPEG, BMP, GIF, WebP, PNM, Targa, JPEG 2000, DPX, Cineon,
// HEIF/AVIF, Maya IFF, ICO, SGI, RLA, FITS. Before IFF, ICO, SGI, RLA and FITS were here, their files held the
// scene-linear values clipped to 0..1 and quantised: dark, banded, with no view transform.
bool is_display_referred_format(std::string_view path) {
    return is_one_of(lower_extension_of(path), {"png", "jpg", "jpeg", "jpe", "jif", "jfif", "jfi", "bmp", "dib", "gif", "webp", "ppm",
                                                "pgm", "pbm", "pnm", "tga", "tpic", "jp2", "j2k", "j2c", "dpx", "cin", "heic", "heif",
                                                "heics", "hif", "avif", "iff", "z", "ico", "sgi", "rgb", "rgba", "bw", "int", "inta", "rla", "fits"});
}

bool holds_straight_alpha(std::string_view path) {
    return is_one_of(lower_extension_of(path), {"png", "webp", "tga", "gif", "avif", "heic"});
}

namespace {

// 16x16 Bayer index: the bits of (x xor y, y) interleaved, lowest level most significant.
unsigned bayer16(std::size_t x, std::size_t y) {
    unsigned v = 0;
    for (unsigned k = 0; k < 4; ++k) {
        const unsigned xb = (x >> k) & 1u, yb = (y >> k) & 1u;
        v |= (((xb ^ yb) << 1) | yb) << (2 * (3 - k));
    }
    return v;
}

constexpr std::size_t bn_size = 64;

// A 64x64 blue-noise rank table by the void-and-cluster method (Ulichney 1993): Gaussian energy on the
// torus (sigma 1.5), a seeded initial pattern relaxed by moving its tightest cluster into its largest void,
// then ranks by removing clusters and filling voids. Deterministic; built once.
std::vector<float> make_blue_noise() {
    constexpr std::size_t n = bn_size, count = n * n;
    std::vector<double> kernel(count);
    for (std::size_t y = 0; y < n; ++y)
        for (std::size_t x = 0; x < n; ++x) {
            const double dx = static_cast<double>(std::min(x, n - x)), dy = static_cast<double>(std::min(y, n - y));
            kernel[y * n + x] = std::exp(-(dx * dx + dy * dy) / (2.0 * 1.5 * 1.5));
        }
    std::vector<char> on(count, 0);
    std::vector<double> energy(count, 0.0);
    auto splat = [&](std::size_t i, double sign) {
        const std::size_t px = i % n, py = i / n;
        for (std::size_t y = 0; y < n; ++y)
            for (std::size_t x = 0; x < n; ++x)
                energy[y * n + x] += sign * kernel[((y + n - py) % n) * n + (x + n - px) % n];
    };
    auto tightest = [&] {  // the set pixel of highest energy
        std::size_t best = 0;
        double e = -1.0;
        for (std::size_t i = 0; i < count; ++i)
            if (on[i] && energy[i] > e) e = energy[i], best = i;
        return best;
    };
    auto largest_void = [&] {  // the empty pixel of lowest energy
        std::size_t best = 0;
        double e = std::numeric_limits<double>::max();
        for (std::size_t i = 0; i < count; ++i)
            if (!on[i] && energy[i] < e) e = energy[i], best = i;
        return best;
    };
    std::uint64_t state = 0x9e3779b97f4a7c15ull;  // xorshift64 with a fixed seed
    std::size_t ones = 0;
    while (ones < count / 10) {
        state ^= state << 13, state ^= state >> 7, state ^= state << 17;
        const std::size_t i = state % count;
        if (!on[i]) on[i] = 1, splat(i, 1.0), ++ones;
    }
    for (;;) {
        const std::size_t c = tightest();
        on[c] = 0, splat(c, -1.0);
        const std::size_t v = largest_void();
        on[v] = 1, splat(v, 1.0);
        if (v == c) break;
    }
    std::vector<std::size_t> rank(count, 0);
    const std::vector<char> initial = on;
    const std::vector<double> initial_energy = energy;
    for (std::size_t r = ones; r-- > 0;) {
        const std::size_t c = tightest();
        on[c] = 0, splat(c, -1.0);
        rank[c] = r;
    }
    on = initial, energy = initial_energy;
    for (std::size_t r = ones; r < count; ++r) {
        const std::size_t v = largest_void();
        on[v] = 1, splat(v, 1.0);
        rank[v] = r;
    }
    std::vector<float> table(count);
    for (std::size_t i = 0; i < count; ++i)
        table[i] = static_cast<float>((static_cast<double>(rank[i]) + 0.5) / static_cast<double>(count) - 0.5);
    return table;
}

const std::vector<float>& blue_noise() {
    static const std::vector<float> table = make_blue_noise();
    return table;
}

// The dither offsets of one row, channel by channel (what dither_offset gives, computed once per row).
void row_offsets(Dither dither, std::size_t width, std::size_t y, std::size_t channels, std::uint64_t frame,
                 std::vector<float>& out) {
    out.resize(width * channels);
    if (dither == Dither::Ordered && width > 16) {  // periodic: compute one period and repeat it
        for (std::size_t x = 0; x < 16; ++x)
            for (std::size_t c = 0; c < channels; ++c)
                out[x * channels + c] = dither_offset(dither, x, y, static_cast<int>(c), frame);
        for (std::size_t i = 16 * channels; i < out.size(); ++i) out[i] = out[i - 16 * channels];
        return;
    }
    for (std::size_t x = 0; x < width; ++x)
        for (std::size_t c = 0; c < channels; ++c)
            out[x * channels + c] = dither_offset(dither, x, y, static_cast<int>(c), frame);
}

template <typename T>
std::vector<T> quantise(const PixelSpan& px, Dither dither, std::uint64_t frame, float max) {
    const std::size_t nc = static_cast<std::size_t>(px.channels);
    const std::size_t stride = px.row_stride ? px.row_stride : px.width * nc;
    const std::size_t n = px.width * nc;
    std::vector<T> out(px.width * px.height * nc);
    std::vector<float> offsets(n, 0.0f);
    // Blue noise repeats every 64 rows and columns: rows 64 apart share their offsets.
    std::vector<std::vector<float>> blue_rows;
    for (std::size_t y = 0; y < px.height; ++y) {
        if (dither == Dither::Ordered) {
            row_offsets(dither, px.width, y, nc, frame, offsets);
        } else if (dither == Dither::BlueNoise) {
            if (blue_rows.size() <= y % bn_size) {
                blue_rows.emplace_back();
                row_offsets(dither, px.width, y, nc, frame, blue_rows.back());
            }
            offsets = blue_rows[y % bn_size];
        }
        const float* row = px.data + y * stride;
        T* o = out.data() + y * n;
        for (std::size_t i = 0; i < n; ++i) {
            const float q = std::floor(clamp01(row[i]) * max + 0.5f + offsets[i]);
            o[i] = static_cast<T>(q < 0.0f ? 0.0f : (q > max ? max : q));
        }
    }
    return out;
}

}  // namespace

float dither_offset(Dither dither, std::size_t x, std::size_t y, int channel, std::uint64_t frame) {
    switch (dither) {
        case Dither::None: return 0.0f;
        case Dither::Ordered: {
            // One threshold for all channels (no colour noise); the pattern moves by a coprime step per frame.
            const std::size_t shift = static_cast<std::size_t>(frame % 256);
            return (static_cast<float>(bayer16(x + shift * 7, y + shift * 11)) + 0.5f) / 256.0f - 0.5f;
        }
        case Dither::BlueNoise: {
            const auto& t = blue_noise();
            // Channels read the tile at offsets of about a third of it (decorrelated); frames add the golden
            // ratio to the threshold (each pixel's threshold sequence over time is low-discrepancy).
            const std::size_t c = static_cast<std::size_t>(channel);
            const float v = t[((y + c * 23) % bn_size) * bn_size + (x + c * 41) % bn_size];
            const double g = std::fmod(static_cast<double>(frame % 1000003) * 0.6180339887498949, 1.0);
            double s = static_cast<double>(v) + 0.5 + g;
            s -= std::floor(s);
            return static_cast<float>(s - 0.5);
        }
    }
    return 0.0f;
}

std::vector<std::uint8_t> quantise8(const PixelSpan& pixels, Dither dither, std::uint64_t frame) {
    return quantise<std::uint8_t>(pixels, dither, frame, 255.0f);
}

std::vector<std::uint16_t> quantise16(const PixelSpan& pixels, Dither dither, std::uint64_t frame) {
    return quantise<std::uint16_t>(pixels, dither, frame, 65535.0f);
}

}  // namespace lensfx::colour
