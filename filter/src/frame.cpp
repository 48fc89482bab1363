// Frame helpers: the RGB working buffer and per-channel conversions (see filter/frame.h).
#include <filter/frame.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <type_traits>

#include <Imath/half.h>

#include <fmt/core.h>

namespace lensfx::filter {

PixelBuffer::PixelBuffer(const PixelBuffer& other) : PixelBuffer(other.size_) {
    if (size_ > 0) std::memcpy(data_.get(), other.data_.get(), size_);
}

PixelBuffer& PixelBuffer::operator=(const PixelBuffer& other) {
    if (this != &other) {
        PixelBuffer copy(other);
        *this = std::move(copy);
    }
    return *this;
}

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

float load(float t) { return t; }
float load(Imath::half t) { return static_cast<float>(t); }
template <typename T>
float load(T t) { return int_to_float(t); }

template <typename T>
T store(float v) {
    if constexpr (std::is_same_v<T, float>) return v;
    else if constexpr (std::is_same_v<T, Imath::half>) return Imath::half(v);
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

void channel_to_float(const Frame& frame, int channel, float* dst, std::size_t float_stride) {
    const std::size_t count = frame.spec.pixel_count(), stride = frame.spec.pixel_bytes();
    const std::byte* base = frame.pixels.data() + channel_offsets(frame.spec)[static_cast<std::size_t>(channel)];
    with_type(frame.spec.channel_type(channel), [&]<typename T>(T*) {
        for (std::size_t i = 0; i < count; ++i) {
            T t;
            std::memcpy(&t, base + i * stride, sizeof(T));
            dst[i * float_stride] = load(t);
        }
    });
}

void channel_from_float(Frame& frame, int channel, const float* src, std::size_t float_stride) {
    const std::size_t count = frame.spec.pixel_count(), stride = frame.spec.pixel_bytes();
    std::byte* base = frame.pixels.data() + channel_offsets(frame.spec)[static_cast<std::size_t>(channel)];
    with_type(frame.spec.channel_type(channel), [&]<typename T>(T*) {
        for (std::size_t i = 0; i < count; ++i) {
            const T t = store<T>(src[i * float_stride]);
            std::memcpy(base + i * stride, &t, sizeof(T));
        }
    });
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
    for (std::size_t k = 0; k < 3; ++k) channel_to_float(frame, frame.rgb_channels[k], frame.rgb.data() + k, 3);
}

void store_rgb(Frame& frame) {
    if (frame.rgb.size() != frame.pixel_count() * 3) {
        throw std::runtime_error(fmt::format("the RGB working buffer holds {} values, the data window needs {}",
                                             frame.rgb.size(), frame.pixel_count() * 3));
    }
    // A finite value beyond half's range would become Inf: an effect's bright result is kept at the largest
    // finite half instead (what it would saturate to on any display), never turned into a non-number.
    bool any_half = false;
    for (int c : frame.rgb_channels) any_half = any_half || frame.spec.channel_type(c) == PixelType::half;
    if (any_half) {
        constexpr float kHalfMax = 65504.0f;
        for (float& v : frame.rgb)
            if (std::isfinite(v)) v = std::clamp(v, -kHalfMax, kHalfMax);
    }
    for (std::size_t k = 0; k < 3; ++k) channel_from_float(frame, frame.rgb_channels[k], frame.rgb.data() + k, 3);
}

std::vector<float> channels_as_float(const Frame& frame, const std::vector<int>& channels) {
    std::vector<float> out(frame.pixel_count() * channels.size());
    for (std::size_t k = 0; k < channels.size(); ++k) channel_to_float(frame, channels[k], out.data() + k, channels.size());
    return out;
}

void grow_data_window(Frame& frame, int x0, int y0, int x1, int y1) {
    ImageSpec& spec = frame.spec;
    const int nx0 = std::min(spec.x, x0), ny0 = std::min(spec.y, y0);
    const int nx1 = std::max(spec.x + spec.width, x1), ny1 = std::max(spec.y + spec.height, y1);
    if (nx0 == spec.x && ny0 == spec.y && nx1 == spec.x + spec.width && ny1 == spec.y + spec.height) return;
    const std::size_t px_bytes = spec.pixel_bytes();
    const auto new_w = static_cast<std::size_t>(nx1 - nx0), new_h = static_cast<std::size_t>(ny1 - ny0);
    const auto old_w = static_cast<std::size_t>(spec.width);
    const auto dx = static_cast<std::size_t>(spec.x - nx0), dy = static_cast<std::size_t>(spec.y - ny0);
    PixelBuffer pixels(new_w * new_h * px_bytes);
    std::memset(pixels.data(), 0, pixels.size());
    std::vector<float> rgb(frame.rgb.empty() ? 0 : new_w * new_h * 3, 0.0f);
    for (std::size_t y = 0; y < static_cast<std::size_t>(spec.height); ++y) {
        std::memcpy(pixels.data() + ((y + dy) * new_w + dx) * px_bytes, frame.pixels.data() + y * old_w * px_bytes,
                    old_w * px_bytes);
        if (!rgb.empty())
            std::copy_n(frame.rgb.data() + y * old_w * 3, old_w * 3, rgb.data() + ((y + dy) * new_w + dx) * 3);
    }
    spec.x = nx0;
    spec.y = ny0;
    spec.width = nx1 - nx0;
    spec.height = ny1 - ny0;
    frame.pixels = std::move(pixels);
    if (!frame.rgb.empty()) frame.rgb = std::move(rgb);
}

void add_rgb_layer(Frame& frame, const std::string& layer, const std::vector<float>& rgb) {
    if (rgb.size() != frame.pixel_count() * 3)
        throw std::invalid_argument(fmt::format("layer {}: {} values for a data window of {} pixels", layer, rgb.size(),
                                                frame.pixel_count()));
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
    for (int k = 0; k < 3; ++k) channel_from_float(frame, frame.spec.nchannels() - 3 + k, rgb.data() + k, 3);
}

}  // namespace lensfx::filter
