// Frame helpers: the RGB working buffer and per-channel conversions (see filter/frame.h).
#include <filter/frame_view.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <stdexcept>
#include <type_traits>

#include <Imath/half.h>
#if defined(__x86_64__)
#include <cpuid.h>
#include <immintrin.h>
#endif

#include <fmt/core.h>
#include <sys/mman.h>
#include <unistd.h>

#include <filter/colour.h>

namespace lensfx::filter {

PixelBuffer::PixelBuffer(const PixelBuffer& other) : PixelBuffer(other.size_) {
    if (size_ > 0) std::memcpy(data_.get(), other.data(), size_);
}

PixelBuffer PixelBuffer::adopt(std::vector<float>&& floats, std::size_t size) {
    if (size > floats.size() * sizeof(float)) throw std::logic_error("PixelBuffer::adopt: the floats hold fewer bytes than asked for");
    PixelBuffer out;
    out.adopted_ = std::move(floats);
    out.size_ = size;
    return out;
}

PixelBuffer& PixelBuffer::operator=(const PixelBuffer& other) {
    if (this != &other) {
        PixelBuffer copy(other);
        *this = std::move(copy);
    }
    return *this;
}

namespace {

// The Y row of the image's RGB -> XYZ: from its chromaticities, else Rec. 709 (OpenEXR's default).
std::array<double, 3> luminance_weights_of(const ImageSpec& spec) {
    if (!spec.chromaticities) return {0.2126, 0.7152, 0.0722};
    std::array<double, 8> c{};
    std::copy(spec.chromaticities->begin(), spec.chromaticities->end(), c.begin());
    const colour::Mat3 m = colour::rgb_to_xyz(colour::Chromaticities{c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]});
    return {m[3], m[4], m[5]};
}

// A luminance-only image (Y; Y and A) stands in Y for R, G, B. Luminance/chroma (Y with RY, BY) does not
// (its colour is in the chroma channels, which the flare would not change), nor Y beside some of R, G, B.
void find_luminance_channel(Frame& frame) {
    const ImageSpec& spec = frame.spec;
    const int y = spec.channel_index("Y");
    for (const char* other : {"R", "G", "B", "RY", "BY"})
        if (spec.channel_index(other) >= 0) return;
    if (y < 0) return;
    frame.rgb_channels = {y, y, y};
    frame.luminance_weights = luminance_weights_of(spec);
}

}  // namespace

void find_rgb_channels(Frame& frame) {
    const auto& names = frame.spec.channelnames;
    auto find = [&](const std::string& name) -> int {
        auto it = std::find(names.begin(), names.end(), name);
        return it == names.end() ? -1 : static_cast<int>(it - names.begin());
    };
    frame.rgb_channels = {find("R"), find("G"), find("B")};
    if (frame.has_rgb()) return;
    for (const auto& name : names) {
        if (name.size() < 3 || name.compare(name.size() - 2, 2, ".R") != 0) continue;
        const std::string layer = name.substr(0, name.size() - 1);
        std::array<int, 3> idx{find(layer + "R"), find(layer + "G"), find(layer + "B")};
        if (idx[0] >= 0 && idx[1] >= 0 && idx[2] >= 0) {
            frame.rgb_channels = idx;
            return;
        }
    }
    frame.rgb_channels = {-1, -1, -1};
    find_luminance_channel(frame);
}

std::vector<std::size_t> channel_offsets(const ImageSpec& spec) {
    std::vector<std::size_t> offsets(static_cast<std::size_t>(spec.nchannels()));
    std::size_t offset = 0;
    for (int c = 0; c < spec.nchannels(); ++c) {
        offsets[static_cast<std::size_t>(c)] = offset;
        offset += pixel_type_bytes(spec.channel_type(c));
    }
    return offsets;
}

namespace {

// Integer channels hold display values over their whole range: 0..max is 0..1 in float.
template <typename T>
float int_to_float(T t) {
    return static_cast<float>(static_cast<double>(t) / static_cast<double>(std::numeric_limits<T>::max()));
}

template <typename T>
T float_to_int(float v) {
    if (!(v > 0.0f)) return T{0};  // NaN and negatives
    const double q = std::round(static_cast<double>(v) * static_cast<double>(std::numeric_limits<T>::max()));
    return q >= static_cast<double>(std::numeric_limits<T>::max()) ? std::numeric_limits<T>::max() : static_cast<T>(q);
}

// A finite value beyond half's range becomes the largest finite half (what it would saturate to on any
// display), never Inf.
constexpr float kHalfMax = 65504.0f;

float clamp_to_half(float v) { return std::isfinite(v) ? std::clamp(v, -kHalfMax, kHalfMax) : v; }

float load(float t) { return t; }
float load(Imath::half t) { return static_cast<float>(t); }
template <typename T>
float load(T t) { return int_to_float(t); }

template <typename T>
T store(float v) {
    if constexpr (std::is_same_v<T, float>) return v;
    else if constexpr (std::is_same_v<T, Imath::half>) return Imath::half(clamp_to_half(v));
    else return float_to_int<T>(v);
}

// Calls f with a null pointer of the channel's C++ type.
template <typename F>
void with_type(PixelType type, F&& f) {
    switch (type) {
    case PixelType::float32: f(static_cast<float*>(nullptr)); break;
    case PixelType::half: f(static_cast<Imath::half*>(nullptr)); break;
    case PixelType::uint8: f(static_cast<std::uint8_t*>(nullptr)); break;
    case PixelType::uint16: f(static_cast<std::uint16_t*>(nullptr)); break;
    case PixelType::uint32: f(static_cast<std::uint32_t*>(nullptr)); break;
    }
}

// Half <-> float over strided arrays: the F16C instructions where the CPU has them (a frame's R, G, B are
// converted twice per frame: at 1080p that was ~25 ms through Imath's table and bit arithmetic).
#if defined(__x86_64__)
// Eight values at a time: gathered by stride, converted by one instruction, scattered by stride.
__attribute__((target("avx,f16c"))) void halves_to_floats_f16c(const std::byte* src, std::size_t src_stride, float* dst,
                                                              std::size_t dst_stride, std::size_t count) {
    std::size_t i = 0;
    for (; i + 8 <= count; i += 8) {
        alignas(16) std::uint16_t h[8];
        for (std::size_t k = 0; k < 8; ++k) std::memcpy(&h[k], src + (i + k) * src_stride, sizeof h[k]);
        alignas(32) float v[8];
        _mm256_store_ps(v, _mm256_cvtph_ps(_mm_load_si128(reinterpret_cast<const __m128i*>(h))));
        for (std::size_t k = 0; k < 8; ++k) dst[(i + k) * dst_stride] = v[k];
    }
    for (; i < count; ++i) {
        std::uint16_t h;
        std::memcpy(&h, src + i * src_stride, sizeof h);
        dst[i * dst_stride] = _cvtsh_ss(h);
    }
}

__attribute__((target("avx,f16c"))) void floats_to_halves_f16c(const float* src, std::size_t src_stride, std::byte* dst,
                                                              std::size_t dst_stride, std::size_t count) {
    const __m256 high = _mm256_set1_ps(kHalfMax), low = _mm256_set1_ps(-kHalfMax);
    const __m256 infinity = _mm256_set1_ps(std::numeric_limits<float>::infinity());
    const __m256 sign = _mm256_set1_ps(-0.0f);
    std::size_t i = 0;
    for (; i + 8 <= count; i += 8) {
        alignas(32) float v[8];
        for (std::size_t k = 0; k < 8; ++k) v[k] = src[(i + k) * src_stride];
        const __m256 x = _mm256_load_ps(v);
        // max/min return their second operand when one is NaN: NaN passes; +-Inf is kept, not clamped.
        const __m256 clamped = _mm256_min_ps(high, _mm256_max_ps(low, x));
        const __m256 is_inf = _mm256_cmp_ps(_mm256_andnot_ps(sign, x), infinity, _CMP_EQ_OQ);
        alignas(16) std::uint16_t h[8];
        _mm_store_si128(reinterpret_cast<__m128i*>(h), _mm256_cvtps_ph(_mm256_blendv_ps(clamped, x, is_inf), _MM_FROUND_TO_NEAREST_INT));
        for (std::size_t k = 0; k < 8; ++k) std::memcpy(dst + (i + k) * dst_stride, &h[k], sizeof h[k]);
    }
    for (; i < count; ++i) {
        // _mm_cvtps_ph rather than _cvtss_sh, whose clang macro is a compound literal (-Wpedantic).
        const __m128i one = _mm_cvtps_ph(_mm_set_ss(clamp_to_half(src[i * src_stride])), _MM_FROUND_TO_NEAREST_INT);
        const auto h = static_cast<std::uint16_t>(_mm_extract_epi16(one, 0));
        std::memcpy(dst + i * dst_stride, &h, sizeof h);
    }
}

bool has_f16c() {
    // F16C from CPUID: clang 14's __builtin_cpu_supports does not know "f16c" (its "avx" checks the OS too).
    static const bool yes = [] {
        unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
        return __builtin_cpu_supports("avx") && __get_cpuid(1, &eax, &ebx, &ecx, &edx) != 0 && (ecx & bit_F16C) != 0;
    }();
    return yes;
}
#endif

void halves_to_floats(const std::byte* src, std::size_t src_stride, float* dst, std::size_t dst_stride, std::size_t count) {
#if defined(__x86_64__)
    if (has_f16c()) return halves_to_floats_f16c(src, src_stride, dst, dst_stride, count);
#endif
    for (std::size_t i = 0; i < count; ++i) {
        Imath::half h;
        std::memcpy(&h, src + i * src_stride, sizeof h);
        dst[i * dst_stride] = static_cast<float>(h);
    }
}

void floats_to_halves(const float* src, std::size_t src_stride, std::byte* dst, std::size_t dst_stride, std::size_t count) {
#if defined(__x86_64__)
    if (has_f16c()) return floats_to_halves_f16c(src, src_stride, dst, dst_stride, count);
#endif
    for (std::size_t i = 0; i < count; ++i) {
        const Imath::half h(clamp_to_half(src[i * src_stride]));
        std::memcpy(dst + i * dst_stride, &h, sizeof h);
    }
}

// Channel `channel` of a frame whose pixels release_rgb_pixels() let go: one of R, G, B, read from `rgb`, which
// holds them (a depth or matte channel named R on an RGB frame). Any other channel has no values left.
void released_channel_to_float(const Frame& frame, int channel, std::size_t first, std::size_t count, float* dst,
                               std::size_t float_stride) {
    const auto found = std::find(frame.rgb_channels.begin(), frame.rgb_channels.end(), channel);
    if (found == frame.rgb_channels.end() || frame.rgb.size() != frame.pixel_count() * 3)
        throw std::logic_error(fmt::format("channel {} read after the frame's pixels were released", channel));
    const auto c = static_cast<std::size_t>(found - frame.rgb_channels.begin());
    for (std::size_t i = 0; i < count; ++i) dst[i * float_stride] = frame.rgb[(first + i) * 3 + c];
}

// Channel `channel` of pixels [first, first + count) to or from floats `float_stride` apart.
void channel_to_float(const Frame& frame, int channel, std::size_t first, std::size_t count, float* dst,
                      std::size_t float_stride) {
    if (channel < 0 || channel >= frame.spec.nchannels())
        throw std::out_of_range(fmt::format("channel {} of a frame with {} channels", channel, frame.spec.nchannels()));
    if (frame.pixels.size() != frame.spec.image_bytes()) return released_channel_to_float(frame, channel, first, count, dst, float_stride);
    const std::size_t stride = frame.spec.pixel_bytes();
    const std::byte* base = frame.pixels.data() + channel_offsets(frame.spec)[static_cast<std::size_t>(channel)] + first * stride;
    if (frame.spec.channel_type(channel) == PixelType::half) return halves_to_floats(base, stride, dst, float_stride, count);
    with_type(frame.spec.channel_type(channel), [&]<typename T>(T*) {
        for (std::size_t i = 0; i < count; ++i) {
            T t;
            std::memcpy(&t, base + i * stride, sizeof(T));
            dst[i * float_stride] = load(t);
        }
    });
}

void channel_from_float(Frame& frame, int channel, std::size_t first, std::size_t count, const float* src,
                        std::size_t float_stride) {
    const std::size_t stride = frame.spec.pixel_bytes();
    std::byte* base = frame.pixels.data() + channel_offsets(frame.spec)[static_cast<std::size_t>(channel)] + first * stride;
    if (frame.spec.channel_type(channel) == PixelType::half) return floats_to_halves(src, float_stride, base, stride, count);
    with_type(frame.spec.channel_type(channel), [&]<typename T>(T*) {
        for (std::size_t i = 0; i < count; ++i) {
            const T t = store<T>(src[i * float_stride]);
            std::memcpy(base + i * stride, &t, sizeof(T));
        }
    });
}

// The pixels in blocks that stay in cache while each of the channels is converted (one pass over memory
// instead of one per channel). `floats` holds the channels interleaved in the order given.
constexpr std::size_t kBlockPixels = 2048;

// Pixels [begin, end) of the data window; floats[0] is pixel `begin`'s first channel.
void channels_to_floats(const Frame& frame, std::span<const int> channels, std::size_t begin, std::size_t end, float* floats) {
    const std::size_t k = channels.size();
    for (std::size_t first = begin; first < end; first += kBlockPixels) {
        const std::size_t count = std::min(kBlockPixels, end - first);
        for (std::size_t c = 0; c < k; ++c)
            channel_to_float(frame, channels[c], first, count, floats + (first - begin) * k + c, k);
    }
}

void channels_to_floats(const Frame& frame, std::span<const int> channels, float* floats) {
    channels_to_floats(frame, channels, 0, frame.pixel_count(), floats);
}

void channels_from_floats(Frame& frame, std::span<const int> channels, const float* floats) {
    const std::size_t n = frame.pixel_count(), k = channels.size();
    for (std::size_t first = 0; first < n; first += kBlockPixels) {
        const std::size_t count = std::min(kBlockPixels, n - first);
        for (std::size_t c = 0; c < k; ++c) channel_from_float(frame, channels[c], first, count, floats + first * k + c, k);
    }
}

// A luminance-only frame's `rgb` written back to its Y as luminance, a block of pixels at a time (in
// double: R = G = B = Y comes back as Y exactly).
void store_luminance(Frame& frame) {
    const std::size_t n = frame.pixel_count();
    const auto& w = frame.luminance_weights;
    std::vector<float> y(std::min(kBlockPixels, n));
    for (std::size_t first = 0; first < n; first += kBlockPixels) {
        const std::size_t count = std::min(kBlockPixels, n - first);
        const float* rgb = frame.rgb.data() + first * 3;
        for (std::size_t i = 0; i < count; ++i)
            y[i] = static_cast<float>(w[0] * static_cast<double>(rgb[i * 3]) + w[1] * static_cast<double>(rgb[i * 3 + 1]) +
                                      w[2] * static_cast<double>(rgb[i * 3 + 2]));
        channel_from_float(frame, frame.rgb_channels[0], first, count, y.data(), 1);
    }
}

// Gives the whole pages of [base + used, base + total) back to the system: their contents are no longer
// needed (the tail of a float buffer that now holds smaller pixels: 0.4 GB of an 8K half frame).
void release_unused_pages(std::byte* base, std::size_t used, std::size_t total) {
    const auto page = static_cast<std::uintptr_t>(::sysconf(_SC_PAGESIZE));
    const auto start = reinterpret_cast<std::uintptr_t>(base);
    const std::uintptr_t first = (start + used + page - 1) / page * page;
    const std::uintptr_t last = (start + total) / page * page;
    if (last > first) ::madvise(reinterpret_cast<void*>(first), last - first, MADV_DONTNEED);
}

// A released RGB-only frame (release_rgb_pixels) stored into its float working buffer's own memory: a
// pixel's bytes (at most 12) never reach past its own floats, and each block of floats is copied aside
// before its pixels are written over it. At 8K this saves the 0.4 GB the half pixels would take beside
// the 0.8 GB of floats.
void store_rgb_in_place(Frame& frame) {
    const std::size_t n = frame.pixel_count();
    std::vector<float> block(std::min(kBlockPixels, n) * 3);
    frame.pixels = PixelBuffer::adopt(std::move(frame.rgb), frame.spec.image_bytes());
    frame.rgb = {};
    const auto* floats = reinterpret_cast<const float*>(frame.pixels.data());
    for (std::size_t first = 0; first < n; first += kBlockPixels) {
        const std::size_t count = std::min(kBlockPixels, n - first);
        std::copy_n(floats + first * 3, count * 3, block.data());
        for (std::size_t c = 0; c < 3; ++c) channel_from_float(frame, frame.rgb_channels[c], first, count, block.data() + c, 3);
    }
    release_unused_pages(frame.pixels.data(), frame.pixels.size(), n * 3 * sizeof(float));
}

}  // namespace

detect::ImageView rgb_view(const Frame& frame) {
    detect::ImageView view;
    view.data = frame.rgb.data();
    view.width = frame.spec.width;
    view.height = frame.spec.height;
    view.channels = 3;
    view.x_offset = frame.spec.x - frame.spec.full_x;
    view.y_offset = frame.spec.y - frame.spec.full_y;
    return view;
}

void load_rgb(Frame& frame) {
    if (!frame.has_rgb()) throw std::runtime_error("the image has no R, G, B channels");
    frame.rgb.resize(frame.pixel_count() * 3);
    channels_to_floats(frame, frame.rgb_channels, frame.rgb.data());
}

void store_rgb(Frame& frame) {
    if (frame.rgb.size() != frame.pixel_count() * 3) {
        throw std::runtime_error(fmt::format("the RGB working buffer holds {} values, the data window needs {}",
                                             frame.rgb.size(), frame.pixel_count() * 3));
    }
    if (frame.pixels.size() != frame.spec.image_bytes()) frame.pixels = PixelBuffer(frame.spec.image_bytes());
    if (frame.luminance_only()) return store_luminance(frame);
    channels_from_floats(frame, frame.rgb_channels, frame.rgb.data());
}

void store_rgb_and_drop(Frame& frame) {
    const bool released = frame.pixels.size() == 0 && frame.rgb.size() == frame.pixel_count() * 3;
    if (released && !frame.luminance_only() && frame.spec.pixel_bytes() <= 3 * sizeof(float)) return store_rgb_in_place(frame);
    store_rgb(frame);
    frame.rgb = {};
}

bool release_rgb_pixels(Frame& frame) {
    if (frame.spec.nchannels() != 3 || !frame.has_rgb() || frame.luminance_only() || frame.rgb.size() != frame.pixel_count() * 3)
        return false;
    frame.pixels = PixelBuffer();
    return true;
}

std::vector<float> channels_as_float(const Frame& frame, const std::vector<int>& channels) {
    std::vector<float> out(frame.pixel_count() * channels.size());
    channels_to_floats(frame, channels, out.data());
    return out;
}

void store_channels(Frame& frame, const std::vector<int>& channels, const std::vector<float>& values) {
    if (values.size() != frame.pixel_count() * channels.size())
        throw std::runtime_error(fmt::format("{} values for {} channels of {} pixels", values.size(), channels.size(), frame.pixel_count()));
    channels_from_floats(frame, channels, values.data());
}

void rows_as_float(const Frame& frame, const std::vector<int>& channels, int first_row, int rows, float* out) {
    const auto w = static_cast<std::size_t>(frame.spec.width);
    channels_to_floats(frame, channels, static_cast<std::size_t>(first_row) * w,
                       static_cast<std::size_t>(first_row + rows) * w, out);
}

std::vector<float> rgb_in_window(const std::vector<float>& rgb, const ImageSpec& was, const ImageSpec& now) {
    std::vector<float> out(now.pixel_count() * 3, 0.0f);
    const auto old_w = static_cast<std::size_t>(was.width), new_w = static_cast<std::size_t>(now.width);
    const auto dx = static_cast<std::size_t>(was.x - now.x), dy = static_cast<std::size_t>(was.y - now.y);
    for (std::size_t y = 0; y < static_cast<std::size_t>(was.height); ++y)
        std::copy_n(rgb.data() + y * old_w * 3, old_w * 3, out.data() + ((y + dy) * new_w + dx) * 3);
    return out;
}

void grow_data_window(Frame& frame, int x0, int y0, int x1, int y1) {
    const ImageSpec was = frame.spec;
    const int nx0 = std::min(was.x, x0), ny0 = std::min(was.y, y0);
    const int nx1 = std::max(was.x + was.width, x1), ny1 = std::max(was.y + was.height, y1);
    if (nx0 == was.x && ny0 == was.y && nx1 == was.x + was.width && ny1 == was.y + was.height) return;
    ImageSpec& spec = frame.spec;
    spec.x = nx0;
    spec.y = ny0;
    spec.width = nx1 - nx0;
    spec.height = ny1 - ny0;
    const std::size_t px_bytes = spec.pixel_bytes();
    const auto new_w = static_cast<std::size_t>(spec.width), old_w = static_cast<std::size_t>(was.width);
    const auto dx = static_cast<std::size_t>(was.x - nx0), dy = static_cast<std::size_t>(was.y - ny0);
    if (frame.pixels.size() != 0) {  // else released (release_rgb_pixels()): `rgb` holds every channel
        PixelBuffer pixels(spec.image_bytes());
        std::memset(pixels.data(), 0, pixels.size());
        for (std::size_t y = 0; y < static_cast<std::size_t>(was.height); ++y)
            std::memcpy(pixels.data() + ((y + dy) * new_w + dx) * px_bytes, frame.pixels.data() + y * old_w * px_bytes, old_w * px_bytes);
        frame.pixels = std::move(pixels);
    }
    if (!frame.rgb.empty()) frame.rgb = rgb_in_window(frame.rgb, was, spec);
}

void add_rgb_layer(Frame& frame, const std::string& layer, const std::vector<float>& rgb) {
    if (rgb.size() != frame.pixel_count() * 3)
        throw std::invalid_argument(fmt::format("layer {}: {} values for a data window of {} pixels", layer, rgb.size(),
                                                frame.pixel_count()));
    if (frame.pixels.size() != frame.spec.image_bytes()) store_rgb(frame);  // made again after release_rgb_pixels()
    ImageSpec spec = frame.spec;
    const PixelType type = frame.rgb_channels[0] >= 0 ? spec.channel_type(frame.rgb_channels[0]) : PixelType::half;
    for (const char* c : {".R", ".G", ".B"}) {
        const std::string name = layer + c;
        if (std::find(spec.channelnames.begin(), spec.channelnames.end(), name) != spec.channelnames.end())
            throw std::invalid_argument(fmt::format("layer {}: the image already has a channel {}", layer, name));
        spec.channelnames.push_back(name);
        spec.channeltypes.push_back(type);
    }
    const std::size_t old_px = frame.spec.pixel_bytes(), new_px = spec.pixel_bytes();
    const std::size_t n = frame.pixel_count();
    PixelBuffer pixels(n * new_px);
    for (std::size_t i = 0; i < n; ++i) std::memcpy(pixels.data() + i * new_px, frame.pixels.data() + i * old_px, old_px);
    frame.spec = std::move(spec);
    frame.pixels = std::move(pixels);
    const int first = frame.spec.nchannels() - 3;
    channels_from_floats(frame, std::array<int, 3>{first, first + 1, first + 2}, rgb.data());
}

}  // namespace lensfx::filter
