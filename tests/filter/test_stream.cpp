// PFM, raw planar float and EXR streams: byte layout, row order, endianness, end of stream, truncation.
#include <filter/stream.h>

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
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

// The bytes of a small EXR written by OpenImageIO with the given layout.
std::string exr_bytes(const std::string& name, const std::string& compression, int tile, const std::string& mip, int parts) {
    const std::string path = (std::filesystem::temp_directory_path() / ("lensfx_exr_stream_" + name + ".exr")).string();
    auto out = OIIO::ImageOutput::create(path);
    std::vector<OIIO::ImageSpec> specs;
    for (int p = 0; p < parts; ++p) {
        OIIO::ImageSpec spec(37 + p, 29, 4, p == 0 ? OIIO::TypeHalf : OIIO::TypeFloat);
        spec.x = -3;
        spec.y = 5;
        spec.attribute("compression", compression);
        spec.attribute("name", "part" + std::to_string(p));
        if (tile) spec.tile_width = spec.tile_height = tile;
        if (!mip.empty()) {
            spec.attribute("openexr:levelmode", 1);
            spec.attribute("openexr:roundingmode", 1);
        }
        specs.push_back(spec);
    }
    EXPECT_TRUE(parts > 1 ? out->open(path, parts, specs.data()) : out->open(path, specs[0])) << out->geterror();
    for (int p = 0; p < parts; ++p) {
        if (p > 0) EXPECT_TRUE(out->open(path, specs[static_cast<std::size_t>(p)], OIIO::ImageOutput::AppendSubimage));
        int w = specs[static_cast<std::size_t>(p)].width, h = 29;
        for (int level = 0;; ++level) {
            std::vector<float> px(static_cast<std::size_t>(w * h * 4));
            for (std::size_t i = 0; i < px.size(); ++i) px[i] = static_cast<float>(i % 997) * 3.5f + static_cast<float>(level);
            EXPECT_TRUE(out->write_image(OIIO::TypeFloat, px.data())) << out->geterror();
            if (mip.empty() || (w == 1 && h == 1)) break;
            w = std::max(1, (w + 1) / 2);
            h = std::max(1, (h + 1) / 2);
            OIIO::ImageSpec level_spec = specs[static_cast<std::size_t>(p)];
            level_spec.width = level_spec.full_width = w;
            level_spec.height = level_spec.full_height = h;
            EXPECT_TRUE(out->open(path, level_spec, OIIO::ImageOutput::AppendMIPLevel)) << out->geterror();
        }
    }
    EXPECT_TRUE(out->close());
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::filesystem::remove(path);
    return bytes;
}

}  // namespace exr_stream

// Each EXR of a concatenated stream comes back byte for byte: scanline images of every compression's
// chunk height, tiled, mip-mapped and multi-part ones; then a clean end.
TEST(ExrStream, SplitsConcatenatedImagesExactly) {
    using exr_stream::exr_bytes;
    std::vector<std::string> images;
    for (const char* c : {"none", "rle", "zips", "zip", "piz", "pxr24", "b44", "dwaa", "dwab"})
        images.push_back(exr_bytes(std::string("scan_") + c, c, 0, "", 1));
    images.push_back(exr_bytes("tiled", "zip", 16, "", 1));
    images.push_back(exr_bytes("mip", "piz", 8, "mip", 1));
    images.push_back(exr_bytes("multipart", "zip", 0, "", 2));
    std::string all;
    for (const auto& i : images) all += i;
    File f = memory_file(all);
    for (std::size_t i = 0; i < images.size(); ++i) {
        ASSERT_EQ(detect_stream_format(f.get()), StreamFormat::exr) << i;
        const auto got = read_exr_bytes(f.get());
        ASSERT_TRUE(got) << i;
        EXPECT_EQ(got->size(), images[i].size()) << i;
        EXPECT_TRUE(*got == images[i]) << i;
    }
    EXPECT_FALSE(read_exr_bytes(f.get()));
}

TEST(ExrStream, TruncatedOrForeignBytesThrow) {
    const std::string image = exr_stream::exr_bytes("trunc", "zip", 0, "", 1);
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
