// Single image files through OpenImageIO, PFM through our own code (see filter/image_io.h).
#include <filter/image_io.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>

#include <fmt/core.h>
#include <unistd.h>

namespace lensfx::filter {

namespace fs = std::filesystem;

namespace {

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// Largest frame we agree to allocate: a damaged header must not ask for terabytes.
constexpr OIIO::imagesize_t max_frame_bytes = OIIO::imagesize_t{16} << 30;

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

// A temporary file beside the target, removed unless commit() renamed it into place.
class TempFile {
public:
    explicit TempFile(const std::string& target) : target_(target) {
        const fs::path t(target);
        // Keep the extension last: some writers check it.
        const std::string name = fmt::format(".{}.lensfx-{}{}", t.stem().string(), ::getpid(), t.extension().string());
        path_ = (t.parent_path() / name).string();
    }
    TempFile(const TempFile&) = delete;
    TempFile& operator=(const TempFile&) = delete;
    ~TempFile() {
        if (!committed_) {
            std::error_code ec;
            fs::remove(path_, ec);
        }
    }
    const std::string& path() const { return path_; }
    void commit() {
        std::error_code ec;
        fs::rename(path_, target_, ec);
        if (ec) throw std::runtime_error(fmt::format("cannot rename {} to {}: {}", path_, target_, ec.message()));
        committed_ = true;
    }

private:
    std::string target_;
    std::string path_;
    bool committed_ = false;
};

void write_pfm_file(const Frame& frame, const std::string& path, const WriteOptions& options) {
    TempFile tmp(path);
    File f(std::fopen(tmp.path().c_str(), "wb"));
    if (!f) throw std::runtime_error(fmt::format("cannot create {}: {}", tmp.path(), std::strerror(errno)));
    write_pfm(f.get(), frame, options.pfm_order == PfmOrder::top_first);
    if (std::fclose(f.release()) != 0) throw std::runtime_error(fmt::format("cannot write {}", tmp.path()));
    tmp.commit();
}

}  // namespace

Frame read_image(const std::string& path, PfmOrder pfm_order) {
    if (!fs::exists(path)) throw std::runtime_error("file does not exist");
    if (is_pfm_file(path)) {
        File f(std::fopen(path.c_str(), "rb"));
        if (!f) throw std::runtime_error(fmt::format("cannot open: {}", std::strerror(errno)));
        auto frame = read_pfm(f.get(), pfm_order == PfmOrder::top_first);
        if (!frame) throw std::runtime_error("empty PFM file");
        frame->source = path;
        return std::move(*frame);
    }
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        std::string message = OIIO::geterror();
        throw std::runtime_error(message.empty() ? "cannot open (unknown format?)" : message);
    }
    Frame frame;
    frame.source = path;
    frame.format = in->format_name();
    frame.spec = in->spec(0, 0);
    if (frame.spec.deep) throw std::runtime_error("deep images are not supported");
    if (frame.spec.nchannels < 1 || frame.spec.width < 1 || frame.spec.height < 1 || frame.spec.depth != 1) {
        throw std::runtime_error(fmt::format("unsupported image shape {}x{}x{}, {} channels", frame.spec.width,
                                             frame.spec.height, frame.spec.depth, frame.spec.nchannels));
    }
    const OIIO::imagesize_t bytes = frame.spec.image_bytes(true);
    if (bytes == 0 || bytes > max_frame_bytes) {
        throw std::runtime_error(fmt::format("implausible image size {}x{} with {} channels", frame.spec.width,
                                             frame.spec.height, frame.spec.nchannels));
    }
    frame.pixels = PixelBuffer(bytes);
    if (!in->read_image(0, 0, 0, frame.spec.nchannels, OIIO::TypeUnknown, frame.pixels.data())) {
        std::string message = in->geterror();
        throw std::runtime_error(message.empty() ? "cannot read the pixels" : message);
    }
    in->close();
    // The file's tiling and mip levels are not part of the frame: it is written back as scanlines.
    frame.spec.tile_width = frame.spec.tile_height = 0;
    frame.spec.tile_depth = 1;
    frame.spec.erase_attribute("openexr:levelmode");
    frame.spec.erase_attribute("openexr:roundingmode");
    find_rgb_channels(frame);
    return frame;
}

bool is_known_output_format(const std::string& path) {
    if (lower_extension(path) == ".pfm") return true;
    const bool known = OIIO::ImageOutput::create(path) != nullptr;
    if (!known) (void)OIIO::geterror();
    return known;
}

void write_image(const Frame& frame, const std::string& path, const WriteOptions& options) {
    if (lower_extension(path) == ".pfm") {
        write_pfm_file(frame, path, options);
        return;
    }
    auto out = OIIO::ImageOutput::create(path);
    if (!out) {
        (void)OIIO::geterror();
        throw std::runtime_error(fmt::format("unknown output format \"{}\"", fs::path(path).extension().string()));
    }
    const std::string format = out->format_name();
    OIIO::ImageSpec spec = frame.spec;
    const void* data = frame.pixels.data();
    OIIO::TypeDesc data_type = OIIO::TypeUnknown;  // native, channel by channel
    std::vector<float> converted;
    std::vector<std::uint8_t> quantised8;
    std::vector<std::uint16_t> quantised16;

    auto select = [&](std::vector<int> channels, OIIO::TypeDesc file_type) {
        std::vector<std::string> names;
        for (int c : channels) names.push_back(frame.spec.channel_name(c));
        converted = channels_as_float(frame, channels);
        spec.nchannels = static_cast<int>(channels.size());
        spec.channelnames = names;
        spec.channelformats.clear();
        spec.format = file_type;
        spec.alpha_channel = static_cast<int>(std::find(names.begin(), names.end(), "A") - names.begin());
        if (spec.alpha_channel >= spec.nchannels) spec.alpha_channel = -1;
        spec.z_channel = -1;
        data = converted.data();
        data_type = OIIO::TypeFloat;
    };
    auto rgb = [&](bool with_alpha) {
        if (!frame.has_rgb()) throw std::runtime_error(fmt::format("{} output needs R, G, B channels", format));
        std::vector<int> channels(frame.rgb_channels.begin(), frame.rgb_channels.end());
        const auto& names = frame.spec.channelnames;
        if (auto a = std::find(names.begin(), names.end(), "A"); with_alpha && a != names.end())
            channels.push_back(static_cast<int>(a - names.begin()));
        return channels;
    };

    if (format == "openexr") {
        if (!options.compression.empty()) {
            spec.attribute("compression", options.compression);
        } else {
            // Keep the input's compression when it is lossless; re-encoding DWA or B44 would change the
            // pixels of a pass-through, so those become PIZ unless --compression asks for them.
            const std::string kept = spec.get_string_attribute("compression");
            const bool lossy = kept.rfind("dwa", 0) == 0 || kept.rfind("b44", 0) == 0;
            if (frame.format != "openexr" || kept.empty() || lossy) spec.attribute("compression", "piz");
        }
    } else if (format == "tiff") {
        spec.erase_attribute("compression");
        if (!spec.channelformats.empty()) {
            std::vector<int> all(static_cast<std::size_t>(frame.spec.nchannels));
            for (int c = 0; c < frame.spec.nchannels; ++c) all[static_cast<std::size_t>(c)] = c;
            select(all, OIIO::TypeFloat);
        }
    } else if (format == "hdr") {
        spec.erase_attribute("compression");
        select(rgb(false), OIIO::TypeFloat);
    } else {
        spec.erase_attribute("compression");
        const bool wide = options.display_bits == 16 && (format == "png" || format == "pnm" || format == "dpx");
        select(rgb(true), wide ? OIIO::TypeUInt16 : OIIO::TypeUInt8);
        const colour::PixelSpan span{converted.data(), static_cast<std::size_t>(spec.width),
                                     static_cast<std::size_t>(spec.height), spec.nchannels, 0};
        if (wide) {
            quantised16 = colour::quantise16(span, options.dither, frame.index);
            data = quantised16.data();
            data_type = OIIO::TypeUInt16;
        } else {
            quantised8 = colour::quantise8(span, options.dither, frame.index);
            data = quantised8.data();
            data_type = OIIO::TypeUInt8;
        }
    }

    TempFile tmp(path);
    if (!out->open(tmp.path(), spec)) {
        std::string message = out->geterror();
        throw std::runtime_error(message.empty() ? fmt::format("cannot create {}", tmp.path()) : message);
    }
    if (!out->write_image(data_type, data) || !out->close()) {
        std::string message = out->geterror();
        throw std::runtime_error(message.empty() ? fmt::format("cannot write {}", tmp.path()) : message);
    }
    tmp.commit();
}

}  // namespace lensfx::filter
