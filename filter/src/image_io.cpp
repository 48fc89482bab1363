// Single image files: EXR through OpenEXR, PFM through our own code, the rest through the OpenImageIO
// module (see filter/image_io.h).
#include <filter/image_io.h>

#include <algorithm>
#include <functional>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>

#include <fmt/core.h>
#include <unistd.h>

#include <filter/colour/quantise.h>
#include <filter/output_files.h>

#include "exr_io.h"
#include "oiio_module.h"

namespace lensfx::filter {

namespace fs = std::filesystem;

namespace {

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

bool is_pfm_file(const std::string& path) {
    File f(std::fopen(path.c_str(), "rb"));
    if (!f) return false;
    char magic[3] = {};
    return std::fread(magic, 1, 3, f.get()) == 3 && magic[0] == 'P' && (magic[1] == 'F' || magic[1] == 'f') &&
           (magic[2] == '\n' || magic[2] == ' ' || magic[2] == '\r' || magic[2] == '\t');
}

std::string lower_extension(const std::string& path) {
    std::string ext = fs::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

void write_pfm_file(const Frame& frame, const std::string& path, const WriteOptions& options) {
    File f(std::fopen(path.c_str(), "wb"));
    if (!f) throw std::runtime_error(fmt::format("cannot create {}: {}", path, std::strerror(errno)));
    write_pfm(f.get(), frame, options.pfm_order == PfmOrder::top_first, options.memory);
    if (std::fclose(f.release()) != 0) throw std::runtime_error(fmt::format("cannot write {}", path));
}

bool is_exr_extension(const std::string& ext) { return ext == ".exr" || ext == ".sxr" || ext == ".mxr"; }

// The EXR compression of an output: --compression, else the input's own when it is lossless (re-encoding
// DWA or B44 would change the pixels of a pass-through), else piz.
std::string output_compression(const Frame& frame, const WriteOptions& options) {
    if (!options.compression.empty()) return options.compression;
    const std::string& kept = frame.spec.compression;
    const bool lossy = kept.rfind("dwa", 0) == 0 || kept.rfind("b44", 0) == 0;
    return frame.format != "openexr" || kept.empty() || lossy ? "piz" : kept;
}

// Rows converted and quantised at a time for a display format: a multiple of the dither patterns' periods
// (blue noise 64, Bayer 16), so the strips give exactly the values the whole image would.
constexpr int kStripRows = 256;

// Fills rows of R, G, B (and A) quantised to T (8 or 16 bits) with the output's dither from a strip of
// floats; called with strips of kStripRows rows (the last shorter), so the dither is the whole image's.
template <typename T>
OiioModule::RowSource quantised_rows(const Frame& frame, const std::vector<int>& channels, const WriteOptions& options) {
    const auto w = static_cast<std::size_t>(frame.spec.width), k = channels.size();
    auto floats = std::make_shared<std::vector<float>>();
    return [&frame, channels, &options, w, k, floats](int first, int count, void* out) {
        floats->resize(w * static_cast<std::size_t>(count) * k);
        rows_as_float(frame, channels, first, count, floats->data());
        const colour::PixelSpan span{floats->data(), w, static_cast<std::size_t>(count), static_cast<int>(k), 0};
        std::vector<T> q;
        if constexpr (sizeof(T) == 1) q = colour::quantise8(span, options.dither, frame.index);
        else q = colour::quantise16(span, options.dither, frame.index);
        std::copy(q.begin(), q.end(), static_cast<T*>(out));
    };
}

// Rows of `channels` as float.
OiioModule::RowSource float_rows(const Frame& frame, std::vector<int> channels) {
    return [&frame, channels = std::move(channels)](int first, int count, void* out) {
        rows_as_float(frame, channels, first, count, static_cast<float*>(out));
    };
}

// Rows of every channel in their own (one) type, as the frame holds them.
OiioModule::RowSource native_rows(const Frame& frame) {
    return [&frame](int first, int count, void* out) {
        const std::size_t row = frame.spec.pixel_bytes() * static_cast<std::size_t>(frame.spec.width);
        std::memcpy(out, frame.pixels.data() + static_cast<std::size_t>(first) * row, static_cast<std::size_t>(count) * row);
    };
}

// OpenImageIO's name of the format it writes for `path` ("png", "tiff"); throws unless it is known and makes an
// image file of R, G, B. Before null, term and zfile were refused, -o x.term printed the frame as escape codes on
// stdout and then failed, and -o x.zfile failed after the whole frame was rendered.
std::string image_file_format(const std::string& path) {
    const std::string format = oiio_module().output_format(path);
    if (format.empty()) throw std::runtime_error(fmt::format("{}: unknown output format \"{}\"", path, fs::path(path).extension().string()));
    if (format == "null" || format == "term" || format == "zfile")
        throw std::runtime_error(fmt::format("{}: OpenImageIO's \"{}\" writer makes no image file of R, G, B; choose EXR, TIFF, PNG...", path, format));
    return format;
}

}  // namespace

Frame read_image(const std::string& path, PfmOrder pfm_order, const MemoryBudget& budget) {
    if (!fs::exists(path)) throw std::runtime_error("file does not exist");
    require_regular_file(path, "");  // /dev/zero or a named pipe would never end
    // An unreadable file says so (the format probes would call it "not an OpenEXR file").
    if (::access(path.c_str(), R_OK) != 0) throw std::runtime_error(fmt::format("cannot read: {}", std::strerror(errno)));
    if (is_pfm_file(path)) {
        File f(std::fopen(path.c_str(), "rb"));
        if (!f) throw std::runtime_error(fmt::format("cannot open: {}", std::strerror(errno)));
        auto frame = read_pfm(f.get(), pfm_order == PfmOrder::top_first, budget);
        if (!frame) throw std::runtime_error("empty PFM file");
        frame->source = path;
        return std::move(*frame);
    }
    if (is_exr_file(path)) return read_exr(path, budget);
    Frame frame = oiio_module().read(path, budget);
    find_rgb_channels(frame);
    return frame;
}

void write_exr_stream(std::FILE* out, const Frame& frame, const WriteOptions& options) {
    const std::string bytes = write_exr_memory(frame, output_compression(frame, options));
    if (std::fwrite(bytes.data(), 1, bytes.size(), out) != bytes.size()) throw std::runtime_error(fmt::format("write failed: {}", write_failure(errno)));
}

std::optional<Frame> read_exr_stream(std::FILE* in) {
    const std::optional<std::string> bytes = read_exr_bytes(in);
    if (!bytes) return std::nullopt;
    return read_exr_memory(*bytes, "-");
}

Frame image_frame(int width, int height, int channels, PixelType type, const void* data) {
    Frame frame;
    frame.spec = ImageSpec(width, height, channels, type);
    frame.pixels = PixelBuffer(frame.spec.image_bytes());
    std::memcpy(frame.pixels.data(), data, frame.pixels.size());
    find_rgb_channels(frame);
    return frame;
}

void require_output_format(const std::string& path) {
    const std::string ext = lower_extension(path);
    if (ext != ".pfm" && !is_exr_extension(ext)) (void)image_file_format(path);
}

void write_image(const Frame& frame, const std::string& path, const WriteOptions& options) {
    TempFile file(path);
    write_image(frame, file, options);
    file.commit();
}

void write_image(const Frame& frame, TempFile& file, const WriteOptions& options) {
    const std::string& path = file.name();
    const std::string ext = lower_extension(path);
    if (ext == ".pfm") {
        file.write([&](const std::string& to) { write_pfm_file(frame, to, options); });
        return;
    }
    if (is_exr_extension(ext)) {
        const std::string compression = output_compression(frame, options);
        file.write([&](const std::string& to) { write_exr(frame, to, compression, options.memory); });
        return;
    }
    const std::string format = image_file_format(path);
    const OiioModule& oiio = oiio_module();

    ImageSpec spec = frame.spec;
    OiioModule::RowSource rows = native_rows(frame);
    // Only these channels, as float.
    auto select = [&](const std::vector<int>& channels) {
        spec.channelnames.clear();
        for (int c : channels) spec.channelnames.push_back(frame.spec.channel_name(c));
        spec.channeltypes.assign(channels.size(), PixelType::float32);
        rows = float_rows(frame, channels);
    };
    auto rgb = [&](bool with_alpha) {
        if (!frame.has_rgb()) throw std::runtime_error(fmt::format("{} output needs R, G, B channels", format));
        std::vector<int> channels(frame.rgb_channels.begin(), frame.rgb_channels.end());
        if (const int a = frame.spec.channel_index("A"); with_alpha && a >= 0) channels.push_back(a);
        return channels;
    };

    if (format == "tiff") {
        const bool mixed = std::adjacent_find(spec.channeltypes.begin(), spec.channeltypes.end(), std::not_equal_to<>()) !=
                           spec.channeltypes.end();
        if (mixed) {
            std::vector<int> all(static_cast<std::size_t>(frame.spec.nchannels()));
            for (int c = 0; c < frame.spec.nchannels(); ++c) all[static_cast<std::size_t>(c)] = c;
            select(all);
        }
    } else if (format == "hdr") {
        select(rgb(false));
    } else {
        const bool wide = options.display_bits == 16 && (format == "png" || format == "pnm" || format == "dpx");
        const std::vector<int> channels = rgb(true);
        spec.channelnames.clear();
        for (int c : channels) spec.channelnames.push_back(frame.spec.channel_name(c));
        spec.channeltypes.assign(channels.size(), wide ? PixelType::uint16 : PixelType::uint8);
        rows = wide ? quantised_rows<std::uint16_t>(frame, channels, options) : quantised_rows<std::uint8_t>(frame, channels, options);
    }

    file.write([&](const std::string& to) { oiio.write(to, path, spec, kStripRows, rows); });
}

}  // namespace lensfx::filter
