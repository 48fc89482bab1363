// PFM and raw planar float streams: byte layout, row order, endianness, end of stream, truncation.
#include <filter/stream.h>

#include <cstdio>
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
