// PFM, raw planar float and EXR streams: byte layout, row order, endianness, end of stream, truncation.
#include <filter/stream.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfMultiPartOutputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfOutputPart.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfTiledOutputFile.h>
#include <OpenEXR/ImfTiledOutputPart.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

using namespace lensfx::filter;

namespace {

struct Closer {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, Closer>;

File memory_file(const std::string& bytes) {
    File f(std::tmpfile());
    std::fwrite(bytes.data(), 1, bytes.size(), f.get());
    std::rewind(f.get());
    return f;
}

std::string read_all(std::FILE* f) {
    std::rewind(f);
    std::string out;
    char buf[4096];
    for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) out.append(buf, n);
    return out;
}

std::string floats(const std::vector<float>& v) { return std::string(reinterpret_cast<const char*>(v.data()), v.size() * 4); }

float px(const Frame& f, std::size_t i) {
    float v = 0;
    std::memcpy(&v, f.pixels.data() + i * 4, 4);
    return v;
}

}  // namespace

TEST(Pfm, ReadsBothRowOrdersAndEndianness) {
    // 1x2 RGB: the row stored first holds 1,2,3; the second 4,5,6.
    const std::string body = floats({1, 2, 3, 4, 5, 6});
    auto top = memory_file("PF\n1 2\n-1.0\n" + body);
    auto f = read_pfm(top.get(), true);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->spec.width, 1);
    EXPECT_EQ(f->spec.height, 2);
    EXPECT_EQ(f->spec.channelnames, (std::vector<std::string>{"R", "G", "B"}));
    EXPECT_EQ(px(*f, 0), 1.0f);  // top row first
    EXPECT_EQ(px(*f, 3), 4.0f);
    auto bottom = memory_file("PF\n1 2\n-1.0\n" + body);
    f = read_pfm(bottom.get(), false);
    EXPECT_EQ(px(*f, 0), 4.0f);  // the spec's order: the file's first row is the bottom one
    std::string big = body;
    for (std::size_t i = 0; i < big.size(); i += 4) std::swap(big[i], big[i + 3]), std::swap(big[i + 1], big[i + 2]);
    auto be = memory_file("PF 1 2 1.0\n" + big);
    f = read_pfm(be.get(), true);
    EXPECT_EQ(px(*f, 5), 6.0f);
}

TEST(Pfm, ConcatenatedStreamEndsCleanly) {
    const std::string one = "Pf\n2 1\n-1\n" + floats({7, 8});
    auto s = memory_file(one + one + "\n");
    int frames = 0;
    while (auto f = read_pfm(s.get(), true)) {
        EXPECT_EQ(f->spec.channelnames, std::vector<std::string>{"Y"});
        EXPECT_EQ(px(*f, 1), 8.0f);
        ++frames;
    }
    EXPECT_EQ(frames, 2);
}

TEST(Pfm, TruncatedOrMalformedThrows) {
    auto short_body = memory_file("PF\n2 2\n-1.0\n" + floats({1, 2, 3}));
    EXPECT_THROW(read_pfm(short_body.get(), true), std::runtime_error);
    auto bad_magic = memory_file("P6\n2 2\n255\n");
    EXPECT_THROW(read_pfm(bad_magic.get(), true), std::runtime_error);
    auto bad_size = memory_file("PF\n-2 2\n-1.0\n");
    EXPECT_THROW(read_pfm(bad_size.get(), true), std::runtime_error);
}

// A well-formed header of an image wider than lensfx reads says so, not that the header is malformed.
TEST(Pfm, TooWideSaysHowWideItReads) {
    auto wide = memory_file("PF\n100000 2\n-1.0\n");
    try {
        read_pfm(wide.get(), true);
        FAIL() << "a 100000-wide PFM was read";
    } catch (const std::runtime_error& e) {
        EXPECT_STREQ(e.what(), "PFM image width 100000 is over the 65536 pixels lensfx reads");
    }
}

TEST(Pfm, WriteReadRoundTripInBothOrders) {
    auto src = memory_file("PF\n2 3\n-1.0\n" + floats({1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18}));
    const Frame frame = *read_pfm(src.get(), true);
    for (bool top : {true, false}) {
        File out(std::tmpfile());
        write_pfm(out.get(), frame, top);
        const std::string bytes = read_all(out.get());
        EXPECT_EQ(bytes.substr(0, 12), "PF\n2 3\n-1.0\n");
        std::rewind(out.get());
        const Frame back = *read_pfm(out.get(), top);
        ASSERT_EQ(back.pixels.size(), frame.pixels.size());
        EXPECT_EQ(std::memcmp(back.pixels.data(), frame.pixels.data(), frame.pixels.size()), 0);
    }
}

TEST(Raw, PlanesAreGbrAndRoundTrip) {
    // 2x1 gbrapf32le: planes G, B, R, A.
    auto in = memory_file(floats({10, 11, 20, 21, 30, 31, 40, 41}));
    const auto f = read_raw(in.get(), RawPixFmt::gbrapf32le, 2, 1);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->spec.channelnames, (std::vector<std::string>{"R", "G", "B", "A"}));
    EXPECT_EQ(px(*f, 0), 30.0f);  // R of pixel 0
    EXPECT_EQ(px(*f, 1), 10.0f);  // G
    EXPECT_EQ(px(*f, 2), 20.0f);  // B
    EXPECT_EQ(px(*f, 3), 40.0f);  // A
    EXPECT_FALSE(read_raw(in.get(), RawPixFmt::gbrapf32le, 2, 1));  // clean end
    File out(std::tmpfile());
    write_raw(out.get(), *f, RawPixFmt::gbrapf32le);
    EXPECT_EQ(read_all(out.get()), floats({10, 11, 20, 21, 30, 31, 40, 41}));
    File rgb(std::tmpfile());
    write_raw(rgb.get(), *f, RawPixFmt::gbrpf32le);
    EXPECT_EQ(read_all(rgb.get()), floats({10, 11, 20, 21, 30, 31}));
    auto partial = memory_file(floats({1, 2, 3}));
    EXPECT_THROW(read_raw(partial.get(), RawPixFmt::gbrpf32le, 2, 1), std::runtime_error);
}

TEST(Raw, AddsOpaqueAlphaWhenTheFrameHasNone) {
    auto in = memory_file(floats({1, 2, 3}));
    const auto f = read_raw(in.get(), RawPixFmt::gbrpf32le, 1, 1);
    File out(std::tmpfile());
    write_raw(out.get(), *f, RawPixFmt::gbrapf32le);
    EXPECT_EQ(read_all(out.get()), floats({1, 2, 3, 1}));
}

// ---- EXR images on a stream ----

namespace exr_stream {

std::string file_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    std::filesystem::remove(path);
    return ss.str();
}

std::string temp_path(const std::string& name) {
    return (std::filesystem::temp_directory_path() / ("lensfx_exr_stream_" + name + ".exr")).string();
}

// R, G, B, A float slices over a w x h window at (-3, 5), values in the thousands.
struct Pixels {
    Pixels(int width, int height) : w(width), h(height), px(static_cast<std::size_t>(w * h * 4)) {
        for (std::size_t i = 0; i < px.size(); ++i) px[i] = static_cast<float>(i % 997) * 3.5f;
    }
    Imf::FrameBuffer frame_buffer(int x0, int y0) {
        Imf::FrameBuffer fb;
        const char* names[] = {"R", "G", "B", "A"};
        char* base = reinterpret_cast<char*>(px.data()) - (static_cast<std::ptrdiff_t>(x0) + static_cast<std::ptrdiff_t>(y0) * w) * 16;
        for (int c = 0; c < 4; ++c) fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * 4, 16, static_cast<std::size_t>(w) * 16));
        return fb;
    }
    int w, h;
    std::vector<float> px;
};

Imf::Header header(int w, int h, Imf::Compression compression) {
    Imf::Header hd(Imath::Box2i({0, 0}, {w + 9, h + 9}), Imath::Box2i({-3, 5}, {w - 4, h + 4}));
    hd.compression() = compression;
    for (const char* c : {"R", "G", "B", "A"}) hd.channels().insert(c, Imf::Channel(Imf::FLOAT));
    return hd;
}

// A scanline EXR of the given compression.
std::string scanline_exr(const std::string& name, Imf::Compression compression) {
    {
        Pixels p(37, 29);
        Imf::OutputFile out(temp_path(name).c_str(), header(p.w, p.h, compression));
        out.setFrameBuffer(p.frame_buffer(-3, 5));
        out.writePixels(p.h);
    }  // the offset table is written when the file closes
    return file_bytes(temp_path(name));
}

// A tiled EXR of one level, mip levels or rip levels (rounding up).
std::string tiled_exr(const std::string& name, Imf::LevelMode mode) {
    Imf::Header hd = header(37, 29, Imf::ZIP_COMPRESSION);
    hd.setTileDescription(Imf::TileDescription(8, 8, mode, Imf::ROUND_UP));
    {
        Imf::TiledOutputFile out(temp_path(name).c_str(), hd);
        for (int ly = 0; ly < out.numYLevels(); ++ly)
            for (int lx = 0; lx < out.numXLevels(); ++lx) {
                if (!out.isValidLevel(lx, ly)) continue;
                const Imath::Box2i dw = out.dataWindowForLevel(lx, ly);
                Pixels p(dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1);
                out.setFrameBuffer(p.frame_buffer(dw.min.x, dw.min.y));
                out.writeTiles(0, out.numXTiles(lx) - 1, 0, out.numYTiles(ly) - 1, lx, ly);
            }
    }
    return file_bytes(temp_path(name));
}

// Two parts: a scanline one and a tiled one.
std::string multipart_exr(const std::string& name) {
    Imf::Header a = header(37, 29, Imf::PIZ_COMPRESSION), b = header(37, 29, Imf::ZIPS_COMPRESSION);
    a.setName("beauty");
    a.setType(Imf::SCANLINEIMAGE);
    b.setName("tiles");
    b.setType(Imf::TILEDIMAGE);
    b.setTileDescription(Imf::TileDescription(16, 16));
    {
        Imf::MultiPartOutputFile out(temp_path(name).c_str(), std::vector<Imf::Header>{a, b}.data(), 2);
        Pixels p(37, 29);
        Imf::OutputPart scan(out, 0);
        scan.setFrameBuffer(p.frame_buffer(-3, 5));
        scan.writePixels(p.h);
        Imf::TiledOutputPart tiled(out, 1);
        tiled.setFrameBuffer(p.frame_buffer(-3, 5));
        tiled.writeTiles(0, tiled.numXTiles(0) - 1, 0, tiled.numYTiles(0) - 1);
    }
    return file_bytes(temp_path(name));
}

}  // namespace exr_stream

// Each EXR of a concatenated stream comes back byte for byte: scanline images of every compression's
// chunk height, tiled, mip-mapped and multi-part ones; then a clean end.
TEST(ExrStream, SplitsConcatenatedImagesExactly) {
    using namespace exr_stream;
    std::vector<std::string> images;
    for (const auto c : {Imf::NO_COMPRESSION, Imf::RLE_COMPRESSION, Imf::ZIPS_COMPRESSION, Imf::ZIP_COMPRESSION, Imf::PIZ_COMPRESSION,
                         Imf::PXR24_COMPRESSION, Imf::B44_COMPRESSION, Imf::DWAA_COMPRESSION, Imf::DWAB_COMPRESSION})
        images.push_back(scanline_exr("scan" + std::to_string(static_cast<int>(c)), c));
    images.push_back(tiled_exr("tiled", Imf::ONE_LEVEL));
    images.push_back(tiled_exr("mip", Imf::MIPMAP_LEVELS));
    images.push_back(tiled_exr("rip", Imf::RIPMAP_LEVELS));
    images.push_back(multipart_exr("multipart"));
    std::string all;
    for (const auto& i : images) all += i;
    File f = memory_file(all);
    for (std::size_t i = 0; i < images.size(); ++i) {
        ASSERT_EQ(detect_stream_format(f.get()), StreamFormat::exr) << i;
        std::optional<std::string> got;
        try {
            got = read_exr_bytes(f.get());
        } catch (const std::exception& e) {
            FAIL() << "image " << i << ": " << e.what();
        }
        ASSERT_TRUE(got) << i;
        EXPECT_EQ(got->size(), images[i].size()) << i;
        EXPECT_TRUE(*got == images[i]) << i;
    }
    EXPECT_FALSE(read_exr_bytes(f.get()));
}

TEST(ExrStream, TruncatedOrForeignBytesThrow) {
    const std::string image = exr_stream::scanline_exr("trunc", Imf::ZIP_COMPRESSION);
    for (std::size_t cut : {std::size_t{6}, std::size_t{40}, image.size() - 1}) {
        File f = memory_file(image.substr(0, cut));
        EXPECT_THROW(read_exr_bytes(f.get()), std::runtime_error) << cut;
    }
    File text = memory_file("hello");
    EXPECT_THROW(detect_stream_format(text.get()), std::runtime_error);
    File pfm = memory_file("PF\n1 1\n-1\n");
    EXPECT_EQ(detect_stream_format(pfm.get()), StreamFormat::pfm);
    EXPECT_EQ(std::fgetc(pfm.get()), 'P');  // left unread
}
