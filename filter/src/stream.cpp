// PFM and raw planar float streams (see filter/stream.h).
#include <filter/stream.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <vector>

#include <fmt/core.h>

namespace lensfx::filter {

namespace {

void swap_bytes(float* values, std::size_t count) {
    for (std::size_t i = 0; i < count; ++i) {
        std::uint32_t bits = 0;
        std::memcpy(&bits, values + i, 4);
        bits = ((bits & 0xffu) << 24) | ((bits & 0xff00u) << 8) | ((bits >> 8) & 0xff00u) | (bits >> 24);
        std::memcpy(values + i, &bits, 4);
    }
}

// Reads exactly `size` bytes. Returns false when the stream ended before the first byte; throws when it
// ended part way.
bool read_exact(std::FILE* in, void* data, std::size_t size, std::string_view what) {
    const std::size_t got = std::fread(data, 1, size, in);
    if (got == size) return true;
    if (std::ferror(in)) throw std::runtime_error(fmt::format("read error in {}: {}", what, std::strerror(errno)));
    if (got == 0) return false;
    throw std::runtime_error(fmt::format("stream ended inside {} ({} of {} bytes)", what, got, size));
}

void write_exact(std::FILE* out, const void* data, std::size_t size) {
    if (std::fwrite(data, 1, size, out) != size) {
        throw std::runtime_error(fmt::format("write failed: {}", std::strerror(errno)));
    }
}

// One whitespace-delimited header token of a PFM; the single whitespace byte after it is consumed.
std::string header_token(std::FILE* in) {
    int c = std::fgetc(in);
    while (c != EOF && std::isspace(c)) c = std::fgetc(in);
    std::string token;
    while (c != EOF && !std::isspace(c)) {
        token.push_back(static_cast<char>(c));
        if (token.size() > 32) throw std::runtime_error("malformed PFM header: token too long");
        c = std::fgetc(in);
    }
    if (c == EOF) throw std::runtime_error("stream ended inside a PFM header");
    return token;
}

int header_int(std::FILE* in, std::string_view what) {
    const std::string token = header_token(in);
    char* end = nullptr;
    const long value = std::strtol(token.c_str(), &end, 10);
    if (end != token.c_str() + token.size() || value < 1 || value > (1 << 16)) {
        throw std::runtime_error(fmt::format("malformed PFM header: {} \"{}\"", what, token));
    }
    return static_cast<int>(value);
}

// Bytes of a frame's pixels read before the frame is allocated: a header that declares a huge image on a
// short stream fails after at most this much memory instead of allocating what it declared.
constexpr std::size_t kPixelsBeforeAllocation = std::size_t{64} << 20;

// Reads `size` bytes into the buffer `allocate()` returns, calling it only once the first
// kPixelsBeforeAllocation bytes have arrived (held meanwhile in a buffer that grows as they come).
// Returns false when the stream ended before the first byte; throws on a short read, as read_exact does.
template <typename Allocate>
bool read_pixels(std::FILE* in, std::size_t size, std::string_view what, Allocate allocate) {
    std::vector<std::byte> head;
    const std::size_t head_size = std::min(size, kPixelsBeforeAllocation);
    constexpr std::size_t kStep = std::size_t{1} << 20;
    while (head.size() < head_size) {
        const std::size_t have = head.size(), step = std::min(kStep, head_size - have);
        head.resize(have + step);
        const std::size_t got = std::fread(head.data() + have, 1, step, in);
        if (got == step) continue;
        if (std::ferror(in)) throw std::runtime_error(fmt::format("read error in {}: {}", what, std::strerror(errno)));
        if (have + got == 0) return false;
        throw std::runtime_error(fmt::format("stream ended inside {} ({} of {} bytes)", what, have + got, size));
    }
    std::byte* data = allocate();
    std::memcpy(data, head.data(), head.size());
    if (size > head.size() && !read_exact(in, data + head.size(), size - head.size(), what))
        throw std::runtime_error(fmt::format("stream ended inside {} ({} of {} bytes)", what, head.size(), size));
    return true;
}

Frame float_frame(int width, int height, int channels, std::string_view format) {
    Frame frame;
    frame.spec = ImageSpec(width, height, channels, PixelType::float32);
    if (channels == 1) frame.spec.channelnames = {"Y"};
    frame.format = std::string(format);
    frame.pixels = PixelBuffer(frame.spec.image_bytes());
    find_rgb_channels(frame);
    return frame;
}

void flip_rows(std::byte* data, std::size_t row_bytes, int height) {
    std::vector<std::byte> tmp(row_bytes);
    for (int top = 0, bottom = height - 1; top < bottom; ++top, --bottom) {
        std::byte* a = data + static_cast<std::size_t>(top) * row_bytes;
        std::byte* b = data + static_cast<std::size_t>(bottom) * row_bytes;
        std::memcpy(tmp.data(), a, row_bytes);
        std::memcpy(a, b, row_bytes);
        std::memcpy(b, tmp.data(), row_bytes);
    }
}

// The given channels as interleaved float over the display window (a stream has one size for every
// frame): the data window's pixels where it overlaps, `fill` elsewhere. Rows top first.
std::vector<float> display_window_float(const Frame& frame, const std::vector<int>& channels, const std::vector<float>& fill) {
    const auto& s = frame.spec;
    std::vector<float> data = channels_as_float(frame, channels);
    if (s.x == s.full_x && s.y == s.full_y && s.width == s.full_width && s.height == s.full_height) return data;
    const std::size_t n = channels.size();
    std::vector<float> full(static_cast<std::size_t>(s.full_width) * static_cast<std::size_t>(s.full_height) * n);
    for (std::size_t i = 0; i < full.size(); ++i) full[i] = fill[i % n];
    const int x0 = std::max(s.x, s.full_x), x1 = std::min(s.x + s.width, s.full_x + s.full_width);
    const int y0 = std::max(s.y, s.full_y), y1 = std::min(s.y + s.height, s.full_y + s.full_height);
    for (int y = y0; y < y1; ++y) {
        if (x1 <= x0) break;
        const float* src = data.data() + (static_cast<std::size_t>(y - s.y) * static_cast<std::size_t>(s.width) + static_cast<std::size_t>(x0 - s.x)) * n;
        float* dst = full.data() + (static_cast<std::size_t>(y - s.full_y) * static_cast<std::size_t>(s.full_width) + static_cast<std::size_t>(x0 - s.full_x)) * n;
        std::copy(src, src + static_cast<std::size_t>(x1 - x0) * n, dst);
    }
    return full;
}

// R, G, B (or the single channel) of a frame as interleaved float over the display window.
std::vector<float> output_channels(const Frame& frame, int& channels) {
    if (frame.has_rgb()) {
        channels = 3;
        return display_window_float(frame, {frame.rgb_channels[0], frame.rgb_channels[1], frame.rgb_channels[2]}, {0.0f, 0.0f, 0.0f});
    }
    if (frame.spec.nchannels() == 1) {
        channels = 1;
        return display_window_float(frame, {0}, {0.0f});
    }
    throw std::runtime_error("the image has no R, G, B channels to write");
}

}  // namespace

PfmOrder parse_pfm_order(std::string_view text) {
    if (text == "auto") return PfmOrder::automatic;
    if (text == "top") return PfmOrder::top_first;
    if (text == "bottom") return PfmOrder::bottom_first;
    throw std::invalid_argument(fmt::format("--pfm-order must be top, bottom or auto, not \"{}\"", text));
}

RawPixFmt parse_raw_pix_fmt(std::string_view text) {
    if (text == "gbrpf32le") return RawPixFmt::gbrpf32le;
    if (text == "gbrapf32le") return RawPixFmt::gbrapf32le;
    throw std::invalid_argument(fmt::format("--pix-fmt must be gbrpf32le or gbrapf32le, not \"{}\"", text));
}

std::string_view to_string(RawPixFmt fmt) { return fmt == RawPixFmt::gbrpf32le ? "gbrpf32le" : "gbrapf32le"; }

int channel_count(RawPixFmt fmt) { return fmt == RawPixFmt::gbrpf32le ? 3 : 4; }

std::optional<Frame> read_pfm(std::FILE* in, bool top_first, const MemoryBudget& budget) {
    int c = std::fgetc(in);
    while (c != EOF && std::isspace(c)) c = std::fgetc(in);
    if (c == EOF) {
        if (std::ferror(in)) throw std::runtime_error(fmt::format("read error: {}", std::strerror(errno)));
        return std::nullopt;
    }
    const int kind = std::fgetc(in);
    if (c != 'P' || (kind != 'F' && kind != 'f')) {
        throw std::runtime_error("not a PFM image (the header does not start with PF or Pf)");
    }
    const int channels = kind == 'F' ? 3 : 1;
    const int width = header_int(in, "width");
    const int height = header_int(in, "height");
    const std::string scale_token = header_token(in);
    char* end = nullptr;
    const double scale = std::strtod(scale_token.c_str(), &end);
    if (end != scale_token.c_str() + scale_token.size() || scale == 0.0 || !std::isfinite(scale)) {
        throw std::runtime_error(fmt::format("malformed PFM header: scale \"{}\"", scale_token));
    }
    budget.check(bytes_of(width, height, channels * sizeof(float)), fmt::format("a {}x{} PFM image", width, height));
    Frame frame;
    const std::size_t count = static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * static_cast<std::size_t>(channels);
    const auto allocate = [&] {
        frame = float_frame(width, height, channels, "pfm");
        return frame.pixels.data();
    };
    if (!read_pixels(in, count * sizeof(float), "a PFM image's pixels", allocate)) {
        throw std::runtime_error("stream ended after a PFM header");
    }
    const bool little = scale < 0.0;
    if (little != (std::endian::native == std::endian::little)) {
        swap_bytes(reinterpret_cast<float*>(frame.pixels.data()), count);
    }
    if (!top_first) flip_rows(frame.pixels.data(), static_cast<std::size_t>(width) * static_cast<std::size_t>(channels) * sizeof(float), height);
    return frame;
}

void write_pfm(std::FILE* out, const Frame& frame, bool top_first, const MemoryBudget& budget) {
    budget.check(bytes_of(frame.spec.full_width, frame.spec.full_height, 3 * sizeof(float)),
                 fmt::format("PFM output of the {}x{} display window", frame.spec.full_width, frame.spec.full_height));
    int channels = 0;
    std::vector<float> data = output_channels(frame, channels);
    if (std::endian::native != std::endian::little) swap_bytes(data.data(), data.size());
    const std::string header = fmt::format("P{}\n{} {}\n-1.0\n", channels == 3 ? 'F' : 'f', frame.spec.full_width, frame.spec.full_height);
    write_exact(out, header.data(), header.size());
    const std::size_t row = static_cast<std::size_t>(frame.spec.full_width) * static_cast<std::size_t>(channels);
    if (top_first) {
        write_exact(out, data.data(), data.size() * sizeof(float));
    } else {
        for (int y = frame.spec.full_height - 1; y >= 0; --y)
            write_exact(out, data.data() + static_cast<std::size_t>(y) * row, row * sizeof(float));
    }
}

std::optional<Frame> read_raw(std::FILE* in, RawPixFmt fmt, int width, int height, const MemoryBudget& budget) {
    const int channels = channel_count(fmt);
    const std::string what = fmt::format("a {}x{} {} frame", width, height, to_string(fmt));
    budget.check(bytes_of(width, height, channels * sizeof(float)), fmt::format("{} (--size)", what));
    const auto w = static_cast<std::size_t>(width), n = static_cast<std::size_t>(channels);
    // Planes G, B, R[, A] -> interleaved R, G, B[, A], a row at a time (no second copy of the frame).
    constexpr std::size_t target_channel[4] = {1, 2, 0, 3};
    std::vector<float> row(w);
    std::optional<Frame> frame;
    for (std::size_t plane = 0; plane < n; ++plane) {
        for (int y = 0; y < height; ++y) {
            if (!read_exact(in, row.data(), w * sizeof(float), what)) {
                if (frame) throw std::runtime_error(fmt::format("stream ended inside {}", what));
                return std::nullopt;
            }
            if (!frame) frame = float_frame(width, height, channels, "raw");
            if (std::endian::native != std::endian::little) swap_bytes(row.data(), row.size());
            auto* px = reinterpret_cast<float*>(frame->pixels.data()) + static_cast<std::size_t>(y) * w * n;
            const std::size_t c = target_channel[plane];
            for (std::size_t x = 0; x < w; ++x) px[x * n + c] = row[x];
        }
    }
    return frame;
}

void write_raw(std::FILE* out, const Frame& frame, RawPixFmt fmt, const MemoryBudget& budget) {
    if (!frame.has_rgb()) throw std::runtime_error("the image has no R, G, B channels to write");
    budget.check(bytes_of(frame.spec.full_width, frame.spec.full_height, 2.0 * channel_count(fmt) * sizeof(float)),
                 fmt::format("raw output of the {}x{} display window", frame.spec.full_width, frame.spec.full_height));
    std::vector<int> channels{frame.rgb_channels[1], frame.rgb_channels[2], frame.rgb_channels[0]};
    const auto alpha = std::find(frame.spec.channelnames.begin(), frame.spec.channelnames.end(), "A");
    const bool has_alpha = alpha != frame.spec.channelnames.end();
    if (fmt == RawPixFmt::gbrapf32le && has_alpha) channels.push_back(static_cast<int>(alpha - frame.spec.channelnames.begin()));
    const std::vector<float> interleaved = display_window_float(frame, channels, {0.0f, 0.0f, 0.0f, 1.0f});
    const std::size_t plane = static_cast<std::size_t>(frame.spec.full_width) * static_cast<std::size_t>(frame.spec.full_height);
    const std::size_t n = channels.size();
    std::vector<float> planes(plane * static_cast<std::size_t>(channel_count(fmt)), 1.0f);
    for (std::size_t c = 0; c < n; ++c) {
        float* dst = planes.data() + c * plane;
        for (std::size_t i = 0; i < plane; ++i) dst[i] = interleaved[i * n + c];
    }
    if (std::endian::native != std::endian::little) swap_bytes(planes.data(), planes.size());
    write_exact(out, planes.data(), planes.size() * sizeof(float));
}

}  // namespace lensfx::filter
