// EXR reading and writing with OpenEXR (see exr_io.h).
#include "exr_io.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <cstring>
#include <map>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>

#include <fmt/core.h>
#include <filter/dof_stage.h>
#include <Imath/half.h>
#include <OpenEXR/IlmThreadPool.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfChromaticitiesAttribute.h>
#include <OpenEXR/ImfFloatAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfInputPart.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStdIO.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfStringVectorAttribute.h>
#include <OpenEXR/ImfThreading.h>

#include <optics/image_window.h>

namespace lensfx::filter {

namespace {

// Largest frame we agree to allocate: a damaged header must not ask for terabytes.
constexpr std::size_t kMaxFrameBytes = std::size_t{16} << 30;

constexpr std::array<std::pair<Imf::Compression, const char*>, 10> kCompressions{{
    {Imf::NO_COMPRESSION, "none"},
    {Imf::RLE_COMPRESSION, "rle"},
    {Imf::ZIPS_COMPRESSION, "zips"},
    {Imf::ZIP_COMPRESSION, "zip"},
    {Imf::PIZ_COMPRESSION, "piz"},
    {Imf::PXR24_COMPRESSION, "pxr24"},
    {Imf::B44_COMPRESSION, "b44"},
    {Imf::B44A_COMPRESSION, "b44a"},
    {Imf::DWAA_COMPRESSION, "dwaa"},
    {Imf::DWAB_COMPRESSION, "dwab"},
}};

std::string compression_name(Imf::Compression c) {
    for (const auto& [value, name] : kCompressions)
        if (value == c) return name;
    return {};  // a newer OpenEXR's method: outputs fall back to piz
}

// Removes attribute `name` when the header has it. OpenEXR's Header::erase drops the map entry without deleting
// the attribute it owns (a leak per call, seen under LeakSanitizer), so the header is rebuilt without it; its
// compression levels live beside the attributes and are carried over.
void erase_attribute(Imf::Header& header, const std::string& name) {
    if (header.find(name) == header.end()) return;
    Imf::Header kept;
    for (auto it = header.begin(); it != header.end(); ++it)
        if (name != it.name()) kept.insert(it.name(), it.attribute());
    kept.zipCompressionLevel() = header.zipCompressionLevel();
    kept.dwaCompressionLevel() = header.dwaCompressionLevel();
    header = kept;
}

// "name" or "name:level" (zip and dwa levels) into the header.
void set_compression(Imf::Header& header, const std::string& text) {
    const auto colon = text.find(':');
    const std::string name = text.substr(0, colon);
    erase_attribute(header, "dwaCompressionLevel");  // the input's
    for (const auto& [value, known] : kCompressions) {
        if (name != known) continue;
        header.compression() = value;
        if (colon == std::string::npos) return;
        const std::string level = text.substr(colon + 1);
        try {
            std::size_t used = 0;
            if (value == Imf::DWAA_COMPRESSION || value == Imf::DWAB_COMPRESSION) {
                const float dwa = std::stof(level, &used);
                if (!(dwa >= 0.0f && dwa <= 1e6f)) throw std::invalid_argument("out of range");
                header.dwaCompressionLevel() = dwa;
                // Also as an attribute, for readers (OpenImageIO shows it as openexr:dwaCompressionLevel).
                header.insert("dwaCompressionLevel", Imf::FloatAttribute(header.dwaCompressionLevel()));
            } else if (value == Imf::ZIP_COMPRESSION || value == Imf::ZIPS_COMPRESSION) {
                const int zip = std::stoi(level, &used);
                if (zip < -1 || zip > 9) throw std::invalid_argument("out of range");  // zlib's levels
                header.zipCompressionLevel() = zip;
            } else {
                throw std::invalid_argument("no level");
            }
            if (used != level.size()) throw std::invalid_argument("trailing characters");
        } catch (const std::exception&) {
            throw std::runtime_error(fmt::format("EXR compression \"{}\": bad level \"{}\"", text, level));
        }
        return;
    }
    throw std::runtime_error(fmt::format("unknown EXR compression \"{}\" (none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa, dwab)", text));
}

PixelType from_exr(Imf::PixelType t) {
    switch (t) {
    case Imf::HALF: return PixelType::half;
    case Imf::FLOAT: return PixelType::float32;
    case Imf::UINT: return PixelType::uint32;
    default: throw std::runtime_error("unknown EXR channel type");
    }
}

// R, G, B, A first within each layer (the text before the last '.'), the rest in the file's order.
int channel_rank(const std::string& name) {
    const auto dot = name.rfind('.');
    std::string base = dot == std::string::npos ? name : name.substr(dot + 1);
    std::transform(base.begin(), base.end(), base.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    static constexpr std::array<std::array<const char*, 2>, 4> kOrder{{{"r", "red"}, {"g", "green"}, {"b", "blue"}, {"a", "alpha"}}};
    for (std::size_t k = 0; k < kOrder.size(); ++k)
        if (base == kOrder[k][0] || base == kOrder[k][1]) return static_cast<int>(k);
    return static_cast<int>(kOrder.size());
}

std::string layer_of(const std::string& name) {
    const auto dot = name.rfind('.');
    return dot == std::string::npos ? std::string() : name.substr(0, dot);
}

using File = std::unique_ptr<std::FILE, int (*)(std::FILE*)>;

// A header name as OpenEXR 3.1 reads it (Xdr::read with Name::MAX_LENGTH, whatever the long-names flag):
// up to a zero byte, or 256 characters without one. Nothing at the end of the file.
std::optional<std::string> header_name(std::FILE* f) {
    std::string name;
    for (int n = 0; n < 256; ++n) {
        const int c = std::fgetc(f);
        if (c == EOF) return std::nullopt;
        if (c == 0) break;
        name.push_back(static_cast<char>(c));
    }
    return name;
}

// The size OpenEXR's C++ reader consumes for an attribute of a fixed-size type, whatever the size the file
// declares (0 for the types read by their declared size).
std::int32_t fixed_attribute_size(const std::string& type) {
    static const std::map<std::string, std::int32_t> sizes{
        {"box2i", 16}, {"box2f", 16}, {"chromaticities", 32}, {"compression", 1}, {"deepImageState", 1}, {"double", 8},
        {"envmap", 1}, {"float", 4}, {"int", 4}, {"keycode", 28}, {"lineOrder", 1}, {"m33f", 36}, {"m33d", 72},
        {"m44f", 64}, {"m44d", 128}, {"rational", 8}, {"tiledesc", 9}, {"timecode", 8}, {"v2i", 8}, {"v2f", 8},
        {"v2d", 16}, {"v3i", 12}, {"v3f", 12}, {"v3d", 24}};
    const auto it = sizes.find(type);
    return it == sizes.end() ? 0 : it->second;
}

// Whether `size` bytes at the file's position hold a channel list that ends exactly there (name, 16
// bytes, ..., an empty name): OpenEXR's C++ reader reads a channel list up to its empty name, whatever
// its declared size, and goes on reading attributes from wherever that ends.
bool channel_list_fits(std::FILE* f, std::int32_t size) {
    std::int64_t used = 0;
    while (true) {
        const std::optional<std::string> name = header_name(f);
        if (!name) return false;
        used += static_cast<std::int64_t>(name->size()) + 1;
        if (name->empty()) return used == size;
        if (std::fseek(f, 16, SEEK_CUR) != 0) return false;
        used += 16;
        if (used > size) return false;
    }
}

// The largest data window side and tile side lensfx reads: OpenEXR allocates its per-line tables and line
// or tile buffers by the declared window and tiles when the file is opened, before any check of ours (a
// fuzzed header of a few hundred bytes took seconds and gigabytes). No real frame comes near these.
constexpr std::int64_t kMaxExrSide = std::int64_t{1} << 20;
constexpr std::int64_t kMaxExrTileSide = std::int64_t{1} << 16;

std::int64_t little_endian_int(const unsigned char* b) {
    return static_cast<std::int32_t>(static_cast<std::uint32_t>(b[0]) | static_cast<std::uint32_t>(b[1]) << 8 |
                                     static_cast<std::uint32_t>(b[2]) << 16 | static_cast<std::uint32_t>(b[3]) << 24);
}

// Refuses a data window or tile size beyond what lensfx reads, and a chunk count the file cannot hold (one
// 8-byte offset a chunk; OpenEXR sizes its offset table by it, and a negative count threw std::length_error
// out of its constructor), from the attribute's value at the file's position (its size already checked
// against its type).
void check_declared_value(std::FILE* f, const std::string& name, const std::string& type, long file_size) {
    unsigned char b[16];
    if (type == "box2i" && name == "dataWindow" && std::fread(b, 1, 16, f) == 16) {
        const std::int64_t width = little_endian_int(b + 8) - little_endian_int(b) + 1;
        const std::int64_t height = little_endian_int(b + 12) - little_endian_int(b + 4) + 1;
        if (width > kMaxExrSide || height > kMaxExrSide)
            throw std::runtime_error(fmt::format("data window {}x{} is beyond the {} pixels a side lensfx reads", width, height, kMaxExrSide));
    } else if (type == "tiledesc" && std::fread(b, 1, 8, f) == 8) {
        const auto side = [](const unsigned char* p) { return static_cast<std::int64_t>(static_cast<std::uint32_t>(little_endian_int(p))); };
        if (side(b) > kMaxExrTileSide || side(b + 4) > kMaxExrTileSide)
            throw std::runtime_error(fmt::format("tiles of {}x{} are beyond the {} pixels a side lensfx reads", side(b), side(b + 4), kMaxExrTileSide));
    } else if (type == "int" && name == "chunkCount" && std::fread(b, 1, 4, f) == 4) {
        const std::int64_t chunks = little_endian_int(b);
        if (chunks < 0 || chunks > file_size / 8)
            throw std::runtime_error(fmt::format("header attribute \"chunkCount\" declares {} chunks, which a file of {} bytes cannot hold",
                                                 chunks, file_size));
    }
}

// OpenEXR 3.1's C++ reader allocates every header attribute at the size the file declares before reading
// it, and reads channel lists and fixed-size values by their own layout whatever the size declared, so an
// 800-byte file could make it allocate and clear gigabytes for seconds (found by fuzz/fuzz_exr_reader.cpp).
// Walks the headers first: each declared size must fit in the file and agree with the attribute's own
// layout, and the data window and tiles must be of a size lensfx reads (check_declared_value). Throws
// std::runtime_error naming the attribute; a layout cut short is left to OpenEXR to report.
void check_attribute_sizes(const std::string& path) {
    File f(std::fopen(path.c_str(), "rb"), &std::fclose);
    unsigned char start[8];
    if (!f || std::fseek(f.get(), 0, SEEK_END) != 0) return;
    const long file_size = std::ftell(f.get());
    std::rewind(f.get());
    if (std::fread(start, 1, 8, f.get()) != 8) return;
    const bool multipart = (start[5] & 0x10) != 0;
    for (bool more = true; more;) {
        more = false;
        for (std::optional<std::string> name; (name = header_name(f.get())) && !name->empty();) {
            more = multipart;  // a multi-part file's headers end with an empty one
            const std::optional<std::string> type = header_name(f.get());
            unsigned char b[4];
            if (!type || std::fread(b, 1, 4, f.get()) != 4) return;
            const auto size = static_cast<std::int32_t>(little_endian_int(b));
            const long value = std::ftell(f.get()), left = file_size - value;
            const std::int32_t fixed = fixed_attribute_size(*type);
            const bool fits = size >= 0 && size <= left && (fixed == 0 || size == fixed) &&
                              (*type != "chlist" || channel_list_fits(f.get(), size));
            if (!fits)
                throw std::runtime_error(fmt::format("header attribute \"{}\" of type {} declares {} bytes, which do not fit the file ({} left) or the type",
                                                     *name, *type, size, left));
            if (std::fseek(f.get(), value, SEEK_SET) != 0) return;
            check_declared_value(f.get(), *name, *type, file_size);
            if (std::fseek(f.get(), value + size, SEEK_SET) != 0) return;
        }
    }
}

// OpenEXR's own errors (Iex), and what else its reader lets out of a damaged file (std::length_error,
// std::bad_alloc from a size it took from the file), as the std::runtime_error callers expect.
[[noreturn]] void rethrow_reader_error() {
    try {
        throw;
    } catch (const std::runtime_error&) {
        throw;
    } catch (const Iex::BaseExc& e) {
        throw std::runtime_error(e.what());
    } catch (const std::bad_alloc&) {
        throw std::runtime_error("out of memory while OpenEXR read the file (a damaged header?)");
    } catch (const std::exception& e) {
        throw std::runtime_error(fmt::format("damaged EXR: OpenEXR's reader failed ({})", e.what()));
    }
}

}  // namespace

void check_exr_header(const std::string& path) { check_attribute_sizes(path); }

bool is_exr_file(const std::string& path) {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
    unsigned char magic[4] = {};
    return f && std::fread(magic, 1, 4, f.get()) == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 &&
           magic[3] == 0x01;
}

namespace {

// A whole EXR held in memory, for OpenEXR to read (an EXR of a stream on stdin).
class MemoryInput : public Imf::IStream {
public:
    explicit MemoryInput(const std::string& bytes) : Imf::IStream("stdin"), bytes_(bytes) {}
    bool read(char c[], int n) override {
        if (n < 0 || pos_ + static_cast<std::uint64_t>(n) > bytes_.size()) throw Iex::InputExc("unexpected end of the EXR image");
        std::memcpy(c, bytes_.data() + pos_, static_cast<std::size_t>(n));
        pos_ += static_cast<std::uint64_t>(n);
        return pos_ < bytes_.size();
    }
    std::uint64_t tellg() override { return pos_; }
    void seekg(std::uint64_t pos) override { pos_ = pos; }

private:
    const std::string& bytes_;
    std::uint64_t pos_ = 0;
};

// An EXR written to memory (OpenEXR seeks back to fill in the offset table), for a stream on stdout.
class MemoryOutput : public Imf::OStream {
public:
    explicit MemoryOutput(std::string& bytes) : Imf::OStream("stdout"), bytes_(bytes) {}
    void write(const char c[], int n) override {
        const auto end = static_cast<std::size_t>(pos_) + static_cast<std::size_t>(n);
        if (end > bytes_.size()) bytes_.resize(end);
        std::memcpy(bytes_.data() + pos_, c, static_cast<std::size_t>(n));
        pos_ = end;
    }
    std::uint64_t tellp() override { return pos_; }
    void seekp(std::uint64_t pos) override { pos_ = pos; }

private:
    std::string& bytes_;
    std::uint64_t pos_ = 0;
};

Frame read_exr_file(Imf::MultiPartInputFile& file, const std::string& path, const MemoryBudget& budget);

}  // namespace

Frame read_exr(const std::string& path, const MemoryBudget& budget) {
    try {
        check_exr_header(path);
        Imf::MultiPartInputFile file(path.c_str(), Imf::globalThreadCount());
        return read_exr_file(file, path, budget);
    } catch (...) {
        rethrow_reader_error();
    }
}

Frame read_exr_memory(const std::string& bytes, const std::string& source, const MemoryBudget& budget) {
    try {
        MemoryInput in(bytes);
        Imf::MultiPartInputFile file(in, Imf::globalThreadCount());
        return read_exr_file(file, source, budget);
    } catch (...) {
        rethrow_reader_error();
    }
}

namespace {

// The refusal of a subsampled channel: a luminance/chroma image (Y, RY, BY, as OpenEXR's RGBA interface
// writes them) is named as such, with what lensfx reads instead.
std::runtime_error subsampled_channel(const Imf::Header& header, const std::string& name) {
    const Imf::ChannelList& list = header.channels();
    if (list.findChannel("RY") && list.findChannel("BY"))
        return std::runtime_error(fmt::format("channel {} is subsampled: a luminance/chroma image (Y, RY, BY) is not read; "
                                              "convert it to R, G, B, or to Y alone, first", name));
    return std::runtime_error(fmt::format("channel {} is subsampled, which is not supported", name));
}

// The first part of an open EXR as a frame. Throws Iex or std exceptions.
Frame read_exr_file(Imf::MultiPartInputFile& file, const std::string& path, const MemoryBudget& budget) {
    {
        const Imf::Header& header = file.header(0);
        if (header.hasType() && Imf::isDeepData(header.type())) return read_deep_exr_frame(path, budget);  // flattened
        Frame frame;
        frame.source = path;
        frame.format = "openexr";
        ImageSpec& spec = frame.spec;
        const Imath::Box2i dw = header.dataWindow(), disp = header.displayWindow();
        spec.x = dw.min.x;
        spec.y = dw.min.y;
        spec.width = window_side(dw.min.x, dw.max.x, "data window");
        spec.height = window_side(dw.min.y, dw.max.y, "data window");
        spec.full_x = disp.min.x;
        spec.full_y = disp.min.y;
        spec.full_width = window_side(disp.min.x, disp.max.x, "display window");
        spec.full_height = window_side(disp.min.y, disp.max.y, "display window");

        struct Channel {
            std::string name;
            PixelType type;
        };
        std::vector<Channel> channels;
        for (auto it = header.channels().begin(); it != header.channels().end(); ++it) {
            if (it.channel().xSampling != 1 || it.channel().ySampling != 1) throw subsampled_channel(header, it.name());
            channels.push_back({it.name(), from_exr(it.channel().type)});
        }
        if (channels.empty()) throw std::runtime_error("the image has no channels");
        std::stable_sort(channels.begin(), channels.end(), [](const Channel& a, const Channel& b) {
            const std::string la = layer_of(a.name), lb = layer_of(b.name);
            return la != lb ? la < lb : channel_rank(a.name) < channel_rank(b.name);
        });
        for (const Channel& c : channels) {
            spec.channelnames.push_back(c.name);
            spec.channeltypes.push_back(c.type);
        }
        const double bytes = bytes_of(spec.width, spec.height, static_cast<double>(spec.pixel_bytes()));
        budget.check(bytes, fmt::format("its {}x{} data window with {} channels", spec.width, spec.height, spec.nchannels()));
        if (bytes > static_cast<double>(kMaxFrameBytes))
            throw std::runtime_error(fmt::format("implausible image size {}x{} with {} channels", spec.width, spec.height,
                                                 spec.nchannels()));

        spec.compression = compression_name(header.compression());
        if (Imf::hasChromaticities(header)) {
            const Imf::Chromaticities& c = Imf::chromaticities(header);
            spec.chromaticities = std::array<float, 8>{c.red.x, c.red.y, c.green.x, c.green.y, c.blue.x, c.blue.y, c.white.x, c.white.y};
        }
        spec.pixel_aspect = header.pixelAspectRatio();
        spec.exr = std::make_shared<const ExrHeader>(header);

        frame.pixels = PixelBuffer(spec.image_bytes());
        const std::vector<std::size_t> offsets = channel_offsets(spec);
        const std::size_t xs = spec.pixel_bytes(), ys = xs * static_cast<std::size_t>(spec.width);
        Imf::FrameBuffer fb;
        for (int c = 0; c < spec.nchannels(); ++c) {
            const Imf::PixelType t = header.channels().findChannel(spec.channel_name(c))->type;
            fb.insert(spec.channel_name(c),
                      Imf::Slice::Make(t, frame.pixels.data() + offsets[static_cast<std::size_t>(c)], dw, xs, ys));
        }
        Imf::InputPart part(file, 0);
        part.setFrameBuffer(fb);
        part.readPixels(dw.min.y, dw.max.y);
        find_rgb_channels(frame);
        return frame;
    }
}

// The header of an output: the input's when it was an EXR (every attribute passes through), less what
// described its file layout, with the frame's windows, channels and metadata. Throws Iex exceptions.
Imf::Header output_header(const ImageSpec& spec, const std::string& compression) {
    Imf::Header header = spec.exr ? spec.exr->header : Imf::Header();
    for (const char* name : {"tiles", "type", "chunkCount", "version", "maxSamplesPerPixel"})
        erase_attribute(header, name);
    header.dataWindow() = Imath::Box2i({spec.x, spec.y}, {spec.x + spec.width - 1, spec.y + spec.height - 1});
    header.displayWindow() = Imath::Box2i({spec.full_x, spec.full_y}, {spec.full_x + spec.full_width - 1, spec.full_y + spec.full_height - 1});
    header.lineOrder() = Imf::INCREASING_Y;
    header.pixelAspectRatio() = spec.pixel_aspect;
    set_compression(header, compression);
    if (spec.chromaticities) {
        const auto& c = *spec.chromaticities;
        Imf::addChromaticities(header, Imf::Chromaticities({c[0], c[1]}, {c[2], c[3]}, {c[4], c[5]}, {c[6], c[7]}));
    } else if (header.find("chromaticities") != header.end()) {
        erase_attribute(header, "chromaticities");
    }
    for (const auto& [name, value] : spec.text) {
        erase_attribute(header, name);  // an input's of another type
        header.insert(name, Imf::StringAttribute(value));
    }
    Imf::ChannelList list;
    for (int c = 0; c < spec.nchannels(); ++c) {
        const std::string& name = spec.channel_name(c);
        // OpenEXR keeps 255 bytes of a name: longer ones would be cut and two channels merge unseen.
        if (name.size() > 255) throw std::runtime_error(fmt::format("channel name of {} characters (EXR holds 255): \"{}...\"", name.size(), name.substr(0, 32)));
        const PixelType type = spec.channel_type(c);
        Imf::Channel channel(type == PixelType::float32 ? Imf::FLOAT : type == PixelType::uint32 ? Imf::UINT : Imf::HALF);
        // B44's perceptual quantisation flag stays as the input had it.
        if (spec.exr) {
            if (const Imf::Channel* in = spec.exr->header.channels().findChannel(name)) channel.pLinear = in->pLinear;
        }
        list.insert(name, channel);
    }
    header.channels() = list;
    return header;
}

// Writes the frame to an OpenEXR output stream (a file or memory). Throws Iex or std exceptions.
void write_exr_to(const Frame& frame, Imf::OStream& target, const std::string& compression, const MemoryBudget& budget) {
    const ImageSpec& spec = frame.spec;
    double widened_bytes = 0.0;
    for (int c = 0; c < spec.nchannels(); ++c)
        if (spec.channel_type(c) == PixelType::uint8 || spec.channel_type(c) == PixelType::uint16)
            widened_bytes += bytes_of(spec.width, spec.height, sizeof(Imath::half) + sizeof(float));
    budget.check(widened_bytes, "EXR output's half copies of the 8- and 16-bit channels");
    const std::vector<std::size_t> offsets = channel_offsets(spec);
    const std::size_t xs = spec.pixel_bytes(), ys = xs * static_cast<std::size_t>(spec.width);
    {
        const Imf::Header header = output_header(spec, compression);
        const Imath::Box2i dw = header.dataWindow();
        Imf::FrameBuffer fb;
        std::vector<std::vector<Imath::half>> widened;  // 8- and 16-bit channels, which EXR lacks
        for (int c = 0; c < spec.nchannels(); ++c) {
            const std::string& name = spec.channel_name(c);
            const Imf::PixelType t = header.channels().findChannel(name)->type;
            if (spec.channel_type(c) == PixelType::uint8 || spec.channel_type(c) == PixelType::uint16) {
                const std::vector<float> values = channels_as_float(frame, {c});
                widened.emplace_back(values.begin(), values.end());
                fb.insert(name, Imf::Slice::Make(Imf::HALF, widened.back().data(), dw, sizeof(Imath::half),
                                                 sizeof(Imath::half) * static_cast<std::size_t>(spec.width)));
            } else {
                fb.insert(name, Imf::Slice::Make(t, frame.pixels.data() + offsets[static_cast<std::size_t>(c)], dw, xs, ys));
            }
        }
        Imf::OutputFile out(target, header, Imf::globalThreadCount());
        out.setFrameBuffer(fb);
        out.writePixels(spec.height);
    }
}

}  // namespace

void write_exr(const Frame& frame, const std::string& path, const std::string& compression, const MemoryBudget& budget) {
    try {
        Imf::StdOFStream out(path.c_str());
        write_exr_to(frame, out, compression, budget);
    } catch (const Iex::BaseExc& e) {
        throw std::runtime_error(e.what());
    }
}

std::string write_exr_memory(const Frame& frame, const std::string& compression, const MemoryBudget& budget) {
    std::string bytes;
    try {
        MemoryOutput out(bytes);
        write_exr_to(frame, out, compression, budget);
    } catch (const Iex::BaseExc& e) {
        throw std::runtime_error(e.what());
    }
    return bytes;
}

std::vector<std::string> exr_views(const ImageSpec& spec) {
    if (!spec.exr) return {};
    const auto* views = spec.exr->header.findTypedAttribute<Imf::StringVectorAttribute>("multiView");
    return views ? views->value() : std::vector<std::string>{};
}

void set_exr_threads(int threads) { Imf::setGlobalThreadCount(threads); }

void check_exr_compression(const std::string& compression) {
    if (compression.empty()) return;
    Imf::Header header;
    set_compression(header, compression);
}

}  // namespace lensfx::filter
