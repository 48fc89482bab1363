// PFM and raw planar float streams (see filter/stream.h).
#include <filter/stream.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/core.h>

#include <filter/output_files.h>

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
        throw std::runtime_error(fmt::format("write failed: {}", write_failure(errno)));
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

constexpr long kMaxPfmSide = 1 << 16;  // the widest and tallest PFM image read (pixels)

int header_int(std::FILE* in, std::string_view what) {
    const std::string token = header_token(in);
    char* end = nullptr;
    const long value = std::strtol(token.c_str(), &end, 10);
    if (end != token.c_str() + token.size() || value < 1) {
        throw std::runtime_error(fmt::format("malformed PFM header: {} \"{}\"", what, token));
    }
    if (value > kMaxPfmSide) throw std::runtime_error(fmt::format("PFM image {} {} is over the {} pixels lensfx reads", what, token, kMaxPfmSide));
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
    if (frame.luminance_only()) {
        channels = 1;
        return display_window_float(frame, {frame.rgb_channels[0]}, {0.0f});
    }
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

// ---- EXR images on a stream ----

// An EXR image being read from a stream: every byte read is kept, in order.
class ExrReader {
public:
    explicit ExrReader(std::FILE* in) : in_(in) {}

    std::string take() { return std::move(bytes_); }
    std::size_t size() const { return bytes_.size(); }
    bool empty() const { return bytes_.empty(); }

    // Reads `n` more bytes; throws at the end of the stream.
    std::string_view bytes(std::size_t n, std::string_view what) {
        const std::size_t at = bytes_.size();
        bytes_.resize(at + n);
        if (n > 0 && std::fread(bytes_.data() + at, 1, n, in_) != n) {
            if (std::ferror(in_)) throw std::runtime_error(fmt::format("read error in an EXR image: {}", std::strerror(errno)));
            throw std::runtime_error(fmt::format("stream ended inside an EXR image ({}, byte {})", what, at));
        }
        return std::string_view(bytes_).substr(at, n);
    }
    std::int64_t int_le(std::size_t n, std::string_view what) {
        const std::string_view b = bytes(n, what);
        std::uint64_t v = 0;
        for (std::size_t i = n; i-- > 0;) v = (v << 8) | static_cast<unsigned char>(b[i]);
        if (n == 4) return static_cast<std::int32_t>(static_cast<std::uint32_t>(v));
        return static_cast<std::int64_t>(v);
    }
    // A null-terminated string of at most `limit` characters.
    std::string name(std::size_t limit) {
        std::string text;
        for (;;) {
            const char c = bytes(1, "an attribute name")[0];
            if (c == '\0') return text;
            text.push_back(c);
            if (text.size() > limit) throw std::runtime_error("malformed EXR header: attribute name too long");
        }
    }

private:
    std::FILE* in_;
    std::string bytes_;
};

std::int32_t le32(std::string_view b, std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t i = 4; i-- > 0;) v = (v << 8) | static_cast<unsigned char>(b[at + i]);
    return static_cast<std::int32_t>(v);
}

// What the offset table of one part needs from its header.
struct ExrPart {
    int x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // data window
    int compression = 0;
    std::string type;                      // "scanlineimage", "tiledimage", "deep..." (multi-part files)
    bool tiled = false;
    std::uint32_t tile_w = 0, tile_h = 0;
    int level_mode = 0, rounding = 0;
    std::int64_t chunk_count = -1;          // the attribute, where the header has it
};

// Scanlines per chunk of each compression (OpenEXR's numbering: none, rle, zips, zip, piz, pxr24, b44,
// b44a, dwaa, dwab).
int lines_per_chunk(int compression) {
    static constexpr int kLines[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
    if (compression < 0 || compression >= static_cast<int>(std::size(kLines)))
        throw std::runtime_error(fmt::format("EXR image with an unknown compression ({}) on a stream", compression));
    return kLines[compression];
}

int round_log2(std::int64_t x, int rounding) {
    int n = 0;
    while ((std::int64_t{1} << (n + 1)) <= x) ++n;
    if (rounding == 1 && (std::int64_t{1} << n) < x) ++n;
    return n;
}

std::int64_t level_size(std::int64_t size, int level, int rounding) {
    std::int64_t s = size >> level;
    if (rounding == 1 && (s << level) < size) ++s;
    return std::max<std::int64_t>(s, 1);
}

std::int64_t tiles(std::int64_t size, std::uint32_t tile) { return (size + tile - 1) / tile; }

// The number of chunks of a part: its chunkCount attribute, else counted from the data window, the
// compression's lines per chunk or the tile layout (one level, mip or rip levels).
std::int64_t chunk_count(const ExrPart& p) {
    if (p.chunk_count >= 0) return p.chunk_count;
    const std::int64_t w = std::int64_t{p.x1} - p.x0 + 1, h = std::int64_t{p.y1} - p.y0 + 1;
    if (w < 1 || h < 1) throw std::runtime_error("malformed EXR header: empty data window");
    if (!p.tiled) return (h + lines_per_chunk(p.compression) - 1) / lines_per_chunk(p.compression);
    if (p.tile_w == 0 || p.tile_h == 0) throw std::runtime_error("malformed EXR header: zero tile size");
    const int nx = p.level_mode == 0 ? 1 : round_log2(p.level_mode == 1 ? std::max(w, h) : w, p.rounding) + 1;
    const int ny = p.level_mode == 0 ? 1 : p.level_mode == 1 ? nx : round_log2(h, p.rounding) + 1;
    std::int64_t count = 0;
    for (int ly = 0; ly < ny; ++ly)
        for (int lx = 0; lx < nx; ++lx) {
            if (p.level_mode == 1 && lx != ly) continue;  // mip levels shrink both ways at once
            count += tiles(level_size(w, lx, p.rounding), p.tile_w) * tiles(level_size(h, ly, p.rounding), p.tile_h);
        }
    return count;
}

// Reads one header's attributes up to its terminating null byte; false when the first name is empty
// (the end of a multi-part file's header list).
bool read_exr_header(ExrReader& r, ExrPart& part, std::size_t name_limit) {
    for (int n = 0;; ++n) {
        const std::string name = r.name(name_limit);
        if (name.empty()) return n > 0;
        const std::string type = r.name(name_limit);
        const std::int64_t size = r.int_le(4, "an attribute size");
        if (size < 0 || size > (std::int64_t{1} << 28)) throw std::runtime_error(fmt::format("malformed EXR header: attribute {} of {} bytes", name, size));
        const std::string_view value = r.bytes(static_cast<std::size_t>(size), name);
        if (name == "dataWindow" && size == 16) {
            part.x0 = le32(value, 0), part.y0 = le32(value, 4), part.x1 = le32(value, 8), part.y1 = le32(value, 12);
        } else if (name == "compression" && size == 1) {
            part.compression = static_cast<unsigned char>(value[0]);
        } else if (name == "tiles" && size == 9) {
            part.tile_w = static_cast<std::uint32_t>(le32(value, 0));
            part.tile_h = static_cast<std::uint32_t>(le32(value, 4));
            part.level_mode = value[8] & 0x0f;
            part.rounding = (value[8] >> 4) & 0x0f;
        } else if (name == "chunkCount" && size == 4) {
            part.chunk_count = le32(value, 0);
        } else if (name == "type") {
            part.type = std::string(value.substr(0, value.find('\0')));
        }
    }
}

}  // namespace

std::optional<std::string> read_exr_bytes(std::FILE* in) {
    ExrReader r(in);
    const int first = std::fgetc(in);
    if (first == EOF) {
        if (std::ferror(in)) throw std::runtime_error(fmt::format("read error: {}", std::strerror(errno)));
        return std::nullopt;
    }
    std::ungetc(first, in);
    const std::string_view magic = r.bytes(4, "the magic number");
    if (magic != std::string_view("\x76\x2f\x31\x01", 4)) throw std::runtime_error("not an EXR image (no EXR magic number)");
    const auto version = static_cast<std::uint32_t>(r.int_le(4, "the version"));
    const bool single_tiled = version & 0x200, long_names = version & 0x400, deep = version & 0x800, multipart = version & 0x1000;
    if (deep) throw std::runtime_error("deep EXR images are not supported on a stream");
    std::vector<ExrPart> parts;
    for (;;) {
        ExrPart part;
        part.tiled = single_tiled;
        if (!read_exr_header(r, part, long_names ? 255 : 31)) break;
        if (!part.type.empty()) part.tiled = part.type == "tiledimage";
        if (part.type.rfind("deep", 0) == 0) throw std::runtime_error("deep EXR images are not supported on a stream");
        parts.push_back(part);
        if (!multipart) break;
        if (parts.size() > 10000) throw std::runtime_error("malformed EXR header: too many parts");
    }
    if (parts.empty()) throw std::runtime_error("malformed EXR header: no part");
    // The offset tables: the chunk placed last ends the image.
    std::uint64_t last = 0;
    for (const ExrPart& part : parts) {
        const std::int64_t count = chunk_count(part);
        if (count < 1 || count > (std::int64_t{1} << 26)) throw std::runtime_error(fmt::format("malformed EXR header: {} chunks", count));
        for (std::int64_t i = 0; i < count; ++i) last = std::max(last, static_cast<std::uint64_t>(r.int_le(8, "the offset table")));
    }
    if (last < r.size() || last > (std::uint64_t{1} << 40)) throw std::runtime_error("malformed EXR offset table");
    r.bytes(static_cast<std::size_t>(last) - r.size(), "the chunks");
    // The last chunk: [part number,] its coordinates (y, or four tile numbers), its size, its data.
    std::int64_t part_number = 0;
    if (multipart) part_number = r.int_le(4, "the last chunk");
    if (part_number < 0 || part_number >= static_cast<std::int64_t>(parts.size())) throw std::runtime_error("malformed EXR chunk: part number");
    r.bytes(parts[static_cast<std::size_t>(part_number)].tiled ? 16 : 4, "the last chunk");
    const std::int64_t size = r.int_le(4, "the last chunk");
    if (size < 0) throw std::runtime_error("malformed EXR chunk: negative size");
    r.bytes(static_cast<std::size_t>(size), "the last chunk");
    return r.take();
}

StreamFormat detect_stream_format(std::FILE* in) {
    const int c = std::fgetc(in);
    if (c == EOF) {
        if (std::ferror(in)) throw std::runtime_error(fmt::format("read error: {}", std::strerror(errno)));
        return StreamFormat::pfm;
    }
    std::ungetc(c, in);
    if (c == 0x76) return StreamFormat::exr;
    if (c == 'P') return StreamFormat::pfm;
    throw std::runtime_error("not an EXR or PFM stream (raw planar float input needs --pix-fmt and --size)");
}

StreamFormat parse_stream_format(std::string_view text) {
    if (text == "exr") return StreamFormat::exr;
    if (text == "pfm") return StreamFormat::pfm;
    if (text == "raw") return StreamFormat::raw;
    throw std::invalid_argument(fmt::format("--stream-format must be exr, pfm or raw, not \"{}\"", text));
}

std::string_view to_string(StreamFormat format) {
    return format == StreamFormat::exr ? "exr" : format == StreamFormat::pfm ? "pfm" : "raw";
}

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
    const std::size_t row_bytes = w * sizeof(float);
    for (std::size_t plane = 0; plane < n; ++plane) {
        for (int y = 0; y < height; ++y) {
            // A short read is told in the frame's bytes (what arrived of all of them), not the row's.
            const std::size_t got = std::fread(row.data(), 1, row_bytes, in);
            if (got != row_bytes) {
                if (std::ferror(in)) throw std::runtime_error(fmt::format("read error in {}: {}", what, std::strerror(errno)));
                const std::size_t before = (plane * static_cast<std::size_t>(height) + static_cast<std::size_t>(y)) * row_bytes;
                if (before + got == 0) return std::nullopt;
                throw std::runtime_error(fmt::format("stream ended inside {} ({} of {} bytes)", what, before + got,
                                                     row_bytes * static_cast<std::size_t>(height) * n));
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
