// liblensfx_oiio: TIFF, Radiance HDR, PNG, JPEG and OpenImageIO's other formats for lensfx (see
// filter/src/oiio_module.h for why this is a module of its own).
#include "../src/oiio_module.h"

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
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
    // A movie of more than one frame (OpenImageIO's ffmpeg reader, an animated GIF; a still GIF is a movie of one)
    // would give its first frame alone, and the run would look whole: lensfx takes a movie's frames through a pipe.
    if (s.get_int_attribute("oiio:Movie", 0) != 0 && in->seek_subimage(1, 0)) {
        const int frames = s.get_int_attribute("oiio:subimages", 0);  // ffmpeg's reader says; a GIF's does not
        throw std::runtime_error(fmt::format(
            "a movie of {} frames, of which lensfx would read the first alone; pipe its frames through ffmpeg: "
            "ffmpeg -i {} -f image2pipe -c:v exr - | lensfx -i - -o out.%04d.exr",
            frames > 1 ? std::to_string(frames) : "several", path));
    }
    if (!in->seek_subimage(0, 0)) {
        std::string message = in->geterror();
        throw std::runtime_error(message.empty() ? "cannot read its first image" : message);
    }
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

// A file opened for writing whose every write is checked; `error()` is the first failure. OpenImageIO's
// PNG and TIFF writers ignore a failed write, so a full disk gave a truncated file and a success: the
// failure is kept here and thrown after the writer closes.
class CheckedFd {
public:
    explicit CheckedFd(int fd) : fd_(fd) {}
    int fd() const { return fd_; }
    int error() const { return error_; }
    // Writes all of `size` bytes at `offset`, or records why not; the bytes written.
    std::size_t write_at(const void* data, std::size_t size, std::int64_t offset) {
        std::size_t done = 0;
        while (done < size && error_ == 0) {
            const ssize_t n = ::pwrite(fd_, static_cast<const char*>(data) + done, size - done, static_cast<off_t>(offset) + static_cast<off_t>(done));
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) error_ = n < 0 ? errno : ENOSPC;
            else done += static_cast<std::size_t>(n);
        }
        return done;
    }

private:
    int fd_;
    int error_ = 0;
};

// Opens `path` for writing (created or truncated); throws naming it.
int create_file(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) throw std::runtime_error(fmt::format("cannot create {}: {}", path, std::strerror(errno)));
    return fd;
}

// Closes `fd`, throwing naming `path` when an earlier write or the close failed.
void close_checked(const std::string& path, const CheckedFd& file) {
    const int err = file.error();
    if (::close(file.fd()) != 0 && err == 0) throw std::runtime_error(fmt::format("cannot write {}: {}", path, std::strerror(errno)));
    if (err != 0) throw std::runtime_error(fmt::format("cannot write {}: {}", path, std::strerror(err)));
}

// An OpenImageIO I/O proxy onto a checked file: the encoder writes to disk as it goes, no copy in memory.
class CheckedFileProxy : public OIIO::Filesystem::IOProxy {
public:
    explicit CheckedFileProxy(const std::string& path) : IOProxy(path, Write), file_(create_file(path)) {}
    const char* proxytype() const override { return "lensfx-checked-file"; }
    void close() override {}  // finish() closes, after the writer is done
    std::size_t write(const void* buf, std::size_t size) override {
        const std::size_t n = pwrite(buf, size, m_pos);
        m_pos += static_cast<std::int64_t>(n);
        return n;
    }
    std::size_t pwrite(const void* buf, std::size_t size, std::int64_t offset) override {
        std::lock_guard lock(mutex_);
        const std::size_t n = file_.write_at(buf, size, offset);
        size_ = std::max(size_, static_cast<std::size_t>(offset) + n);
        return n;
    }
    std::size_t pread(void* buf, std::size_t size, std::int64_t offset) override {
        const ssize_t n = ::pread(file_.fd(), buf, size, static_cast<off_t>(offset));
        return n < 0 ? 0 : static_cast<std::size_t>(n);
    }
    std::size_t read(void* buf, std::size_t size) override {
        const std::size_t n = pread(buf, size, m_pos);
        m_pos += static_cast<std::int64_t>(n);
        return n;
    }
    std::size_t size() const override { return size_; }
    void finish() {
        closed_ = true;
        close_checked(filename(), file_);
    }
    ~CheckedFileProxy() override {
        if (!closed_) ::close(file_.fd());
    }

private:
    CheckedFd file_;
    std::size_t size_ = 0;
    bool closed_ = false;
    std::mutex mutex_;
};

// An anonymous file in memory (memfd), named by its /proc/self/fd path, for writers that take no proxy
// and want a name; copied to the real file in blocks, every write checked.
class MemoryFile {
public:
    MemoryFile() : fd_(::memfd_create("lensfx-encode", MFD_CLOEXEC)) {
        if (fd_ < 0) throw std::runtime_error(fmt::format("memfd_create: {}", std::strerror(errno)));
    }
    MemoryFile(const MemoryFile&) = delete;
    MemoryFile& operator=(const MemoryFile&) = delete;
    ~MemoryFile() { ::close(fd_); }
    std::string path() const { return fmt::format("/proc/self/fd/{}", fd_); }
    std::size_t size() const {
        struct stat st {};
        return ::fstat(fd_, &st) == 0 ? static_cast<std::size_t>(st.st_size) : 0;
    }
    void copy_to(const std::string& path) const {
        CheckedFd out(create_file(path));
        std::vector<char> block(std::size_t{1} << 20);
        for (std::int64_t offset = 0; out.error() == 0;) {
            const ssize_t n = ::pread(fd_, block.data(), block.size(), static_cast<off_t>(offset));
            if (n < 0 && errno == EINTR) continue;
            if (n < 0) {
                ::close(out.fd());
                throw std::runtime_error(fmt::format("memfd: {}", std::strerror(errno)));
            }
            if (n == 0) break;
            out.write_at(block.data(), static_cast<std::size_t>(n), offset);
            offset += n;
        }
        close_checked(path, out);
    }

private:
    int fd_;
};

OIIO::ImageSpec oiio_spec(const ImageSpec& spec) {
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
    for (const auto& [name, value] : spec.text) {
        if (name == "oiio:UnassociatedAlpha") s.attribute(name, value == "1" ? 1 : 0);  // an int to OpenImageIO
        else s.attribute(name, value);
    }
    return s;
}

// The writer's message, else `fallback`.
std::runtime_error writer_error(OIIO::ImageOutput& out, const std::string& fallback) {
    std::string message = out.geterror();
    return std::runtime_error(message.empty() ? fallback : message);
}

// Sends the image to an open writer a strip of rows at a time. A writer that made the file tiled when it opened
// it (Maya IFF always does) takes the strips as rows of tiles: its write_scanlines fails, and says nothing.
void write_strips(OIIO::ImageOutput& out, const OIIO::ImageSpec& s, int strip_rows, const OiioModule::RowSource& rows,
                  const std::string& path) {
    const int tile_rows = out.spec().tile_width > 0 ? std::max(out.spec().tile_height, 1) : 0;
    // A whole number of tile rows where tiled, as write_tiles takes them
    const int strip = tile_rows > 0 ? std::max(1, strip_rows / tile_rows) * tile_rows : std::max(1, std::min(strip_rows, s.height));
    std::vector<std::byte> buffer(static_cast<std::size_t>(s.scanline_bytes()) * static_cast<std::size_t>(std::min(strip, s.height)));
    for (int y = 0; y < s.height; y += strip) {
        const int count = std::min(strip, s.height - y);
        rows(y, count, buffer.data());
        const bool written = tile_rows > 0 ? out.write_tiles(s.x, s.x + s.width, s.y + y, s.y + y + count, 0, 1, s.format, buffer.data())
                                           : out.write_scanlines(s.y + y, s.y + y + count, 0, s.format, buffer.data());
        if (!written) throw writer_error(out, fmt::format("cannot write {}", path));
    }
}

// The data window as `out` can hold it: a format without an image origin (BMP, WebP, FITS...) is given the data
// window at 0,0 with a display window of its size, the placement dropped. Given the origin, BMP refused the frame,
// FITS wrote too few rows and WebP freed its buffer twice.
OIIO::ImageSpec placed_for(const OIIO::ImageOutput& out, OIIO::ImageSpec s) {
    if (out.supports("origin")) return s;
    s.x = s.y = s.full_x = s.full_y = 0;
    s.full_width = s.width;
    s.full_height = s.height;
    return s;
}

// OpenJPEG's six resolution levels need 32 pixels a side; OpenImageIO writes a header alone below that, no error.
constexpr int kJpeg2000MinSide = 32;

// Refuses an image the writer would write wrong without saying so.
void require_writable_size(const OIIO::ImageOutput& out, const OIIO::ImageSpec& s) {
    if (std::string_view(out.format_name()) == "jpeg2000" && std::min(s.width, s.height) < kJpeg2000MinSide)
        throw std::runtime_error(fmt::format("JPEG 2000 needs at least {} pixels a side (OpenJPEG's resolution levels); the image is {}x{}",
                                             kJpeg2000MinSide, s.width, s.height));
}

void write(const std::string& path, const std::string& name, const ImageSpec& spec, int strip_rows, const OiioModule::RowSource& rows) {
    // Writers that take an I/O proxy write through a checked file, opened under `name` (some take their variant
    // from its extension: JPEG 2000's .jp2 or .j2k); the others into a memory file (memfd) by its /proc path,
    // copied with every write checked. Both outlive the writer, which may close on destruction.
    std::optional<CheckedFileProxy> proxy;
    std::optional<MemoryFile> memfile;
    auto out = OIIO::ImageOutput::create(name);
    if (!out) {
        (void)OIIO::geterror();
        throw std::runtime_error(fmt::format("{}: no OpenImageIO writer for this extension", name));
    }
    const OIIO::ImageSpec s = placed_for(*out, oiio_spec(spec));
    require_writable_size(*out, s);
    if (out->supports("ioproxy")) {
        proxy.emplace(path);
        out->set_ioproxy(&*proxy);
    } else {
        memfile.emplace();
    }
    if (!out->open(proxy ? name : memfile->path(), s)) throw writer_error(*out, fmt::format("cannot create {}", name));
    write_strips(*out, s, strip_rows, rows, name);
    if (!out->close()) throw writer_error(*out, fmt::format("cannot write {}", name));
    // A writer that fails without saying so (once JPEG 2000 under a name without its extension) leaves no file.
    if ((proxy ? proxy->size() : memfile->size()) == 0) throw std::runtime_error(fmt::format("{}: the {} writer wrote nothing", name, out->format_name()));
    if (proxy) proxy->finish();
    else memfile->copy_to(path);
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
