// liblensfx_oiio: TIFF, Radiance HDR, PNG, JPEG and OpenImageIO's other formats for lensfx (see
// filter/src/oiio_module.h for why this is a module of its own).
#include "../src/oiio_module.h"

#include <cerrno>
#include <cstring>
#include <memory>
#include <optional>
#include <stdexcept>
#include <vector>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <fmt/core.h>
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <unistd.h>

namespace lensfx::filter {

namespace {

// Largest frame we agree to allocate: a damaged header must not ask for terabytes.
constexpr OIIO::imagesize_t kMaxFrameBytes = OIIO::imagesize_t{16} << 30;

bool native_type(OIIO::TypeDesc t, PixelType& out) {
    if (t == OIIO::TypeDesc::UINT8) out = PixelType::uint8;
    else if (t == OIIO::TypeDesc::UINT16) out = PixelType::uint16;
    else if (t == OIIO::TypeDesc::UINT32) out = PixelType::uint32;
    else if (t == OIIO::TypeDesc::HALF) out = PixelType::half;
    else if (t == OIIO::TypeDesc::FLOAT) out = PixelType::float32;
    else return false;
    return true;
}

OIIO::TypeDesc oiio_type(PixelType t) {
    switch (t) {
    case PixelType::uint8: return OIIO::TypeDesc::UINT8;
    case PixelType::uint16: return OIIO::TypeDesc::UINT16;
    case PixelType::uint32: return OIIO::TypeDesc::UINT32;
    case PixelType::half: return OIIO::TypeDesc::HALF;
    case PixelType::float32: return OIIO::TypeDesc::FLOAT;
    }
    return OIIO::TypeDesc::FLOAT;
}

Frame read(const std::string& path, const MemoryBudget& budget) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        std::string message = OIIO::geterror();
        throw std::runtime_error(message.empty() ? "cannot open (unknown format?)" : message);
    }
    const OIIO::ImageSpec& s = in->spec(0, 0);
    if (s.deep) throw std::runtime_error("deep images are not supported");
    if (s.nchannels < 1 || s.width < 1 || s.height < 1 || s.depth != 1)
        throw std::runtime_error(fmt::format("unsupported image shape {}x{}x{}, {} channels", s.width, s.height, s.depth, s.nchannels));
    const OIIO::imagesize_t bytes = s.image_bytes(true);
    budget.check(bytes_of(s.width, s.height, static_cast<double>(s.nchannels) * sizeof(float)),
                 fmt::format("its {}x{} data window with {} channels", s.width, s.height, s.nchannels));
    if (bytes == 0 || bytes > kMaxFrameBytes)
        throw std::runtime_error(fmt::format("implausible image size {}x{} with {} channels", s.width, s.height, s.nchannels));

    Frame frame;
    frame.source = path;
    frame.format = in->format_name();
    ImageSpec& spec = frame.spec;
    spec.x = s.x;
    spec.y = s.y;
    spec.width = s.width;
    spec.height = s.height;
    spec.full_x = s.full_x;
    spec.full_y = s.full_y;
    spec.full_width = s.full_width;
    spec.full_height = s.full_height;
    bool all_native = true;
    for (int c = 0; c < s.nchannels; ++c) {
        PixelType t = PixelType::float32;
        all_native = native_type(s.channelformat(c), t) && all_native;
        spec.channelnames.push_back(s.channel_name(c));
        spec.channeltypes.push_back(t);
    }
    // Types lensfx does not keep (signed, double) make the whole image float.
    if (!all_native) spec.channeltypes.assign(spec.channeltypes.size(), PixelType::float32);
    spec.pixel_aspect = s.get_float_attribute("PixelAspectRatio", 1.0f);
    spec.oiio_attributes = std::make_shared<const OIIO::ParamValueList>(s.extra_attribs);
    std::array<float, 8> chroma{};
    if (s.getattribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), chroma.data())) spec.chromaticities = chroma;

    frame.pixels = PixelBuffer(spec.image_bytes());
    const bool ok = all_native ? in->read_image(0, 0, 0, s.nchannels, OIIO::TypeUnknown, frame.pixels.data())
                               : in->read_image(0, 0, 0, s.nchannels, OIIO::TypeFloat, frame.pixels.data());
    if (!ok) {
        std::string message = in->geterror();
        throw std::runtime_error(message.empty() ? "cannot read the pixels" : message);
    }
    in->close();
    return frame;
}

// An anonymous file in memory (memfd), named by its /proc/self/fd path for writers that want a name.
class MemoryFile {
public:
    MemoryFile() : fd_(::memfd_create("lensfx-encode", MFD_CLOEXEC)) {
        if (fd_ < 0) throw std::runtime_error(fmt::format("memfd_create: {}", std::strerror(errno)));
    }
    MemoryFile(const MemoryFile&) = delete;
    MemoryFile& operator=(const MemoryFile&) = delete;
    ~MemoryFile() { ::close(fd_); }
    std::string path() const { return fmt::format("/proc/self/fd/{}", fd_); }
    std::vector<unsigned char> contents() const {
        struct stat st {};
        if (::fstat(fd_, &st) != 0) throw std::runtime_error(fmt::format("memfd: {}", std::strerror(errno)));
        std::vector<unsigned char> bytes(static_cast<std::size_t>(st.st_size));
        std::size_t done = 0;
        while (done < bytes.size()) {
            const ssize_t n = ::pread(fd_, bytes.data() + done, bytes.size() - done, static_cast<off_t>(done));
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) throw std::runtime_error(fmt::format("memfd: {}", std::strerror(n < 0 ? errno : EIO)));
            done += static_cast<std::size_t>(n);
        }
        return bytes;
    }

private:
    int fd_;
};

// Writes `bytes` to `path`, every write checked (a full disk is an error naming the file).
void write_bytes(const std::string& path, const std::vector<unsigned char>& bytes) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) throw std::runtime_error(fmt::format("cannot create {}: {}", path, std::strerror(errno)));
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            const int err = n < 0 ? errno : ENOSPC;
            ::close(fd);
            throw std::runtime_error(fmt::format("cannot write {}: {}", path, std::strerror(err)));
        }
        done += static_cast<std::size_t>(n);
    }
    if (::close(fd) != 0) throw std::runtime_error(fmt::format("cannot write {}: {}", path, std::strerror(errno)));
}

void write(const std::string& path, const ImageSpec& spec, const void* data) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out) {
        (void)OIIO::geterror();
        throw std::runtime_error(fmt::format("{}: no OpenImageIO writer for this extension", path));
    }
    const OIIO::TypeDesc type = oiio_type(spec.channeltypes.empty() ? PixelType::float32 : spec.channeltypes[0]);
    OIIO::ImageSpec s(spec.width, spec.height, spec.nchannels(), type);
    s.x = spec.x;
    s.y = spec.y;
    s.full_x = spec.full_x;
    s.full_y = spec.full_y;
    s.full_width = spec.full_width;
    s.full_height = spec.full_height;
    s.channelnames = spec.channelnames;
    s.alpha_channel = spec.channel_index("A");
    if (spec.oiio_attributes) {
        // The input's own, but its compression: the writer of this format picks its own.
        for (const OIIO::ParamValue& p : *static_cast<const OIIO::ParamValueList*>(spec.oiio_attributes.get()))
            if (p.name() != "compression") s.attribute(p.name(), p.type(), p.data());
    }
    if (spec.pixel_aspect != 1.0f) s.attribute("PixelAspectRatio", spec.pixel_aspect);
    for (const auto& [name, value] : spec.text) s.attribute(name, value);
    // Encoded in memory, then written here with every write checked: some writers (PNG, TIFF) ignore a
    // failed write, so a full disk gave a truncated file and a success. Writers that take an I/O proxy
    // write into a vector; the others into a memory file (memfd) by its /proc path.
    std::vector<unsigned char> encoded;
    OIIO::Filesystem::IOVecOutput memory(encoded);
    const bool proxy = out->supports("ioproxy");
    std::optional<MemoryFile> memfile;
    if (proxy) {
        out->set_ioproxy(&memory);
    } else {
        memfile.emplace();
    }
    const std::string target = proxy ? path : memfile->path();
    if (!out->open(target, s)) {
        std::string message = out->geterror();
        throw std::runtime_error(message.empty() ? fmt::format("cannot create {}", path) : message);
    }
    if (!out->write_image(type, data) || !out->close()) {
        std::string message = out->geterror();
        throw std::runtime_error(message.empty() ? fmt::format("cannot write {}", path) : message);
    }
    write_bytes(path, proxy ? encoded : memfile->contents());
}

std::string output_format(const std::string& path) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out) {
        (void)OIIO::geterror();
        return {};
    }
    return out->format_name();
}

void set_threads(int threads) { OIIO::attribute("threads", threads); }

constexpr OiioModule kModule{&read, &write, &output_format, &set_threads};

}  // namespace

}  // namespace lensfx::filter

extern "C" __attribute__((visibility("default"))) const lensfx::filter::OiioModule* lensfx_oiio_module() {
    return &lensfx::filter::kModule;
}
