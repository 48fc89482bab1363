// Deep EXR reading (dof/deep_exr.h): a small deep file read back sample by sample, and the hostile headers
// that are refused against the memory budget before their tables are made (fuzz/fuzz_exr_reader.cpp found
// a 2 KB header that declared a 1048576 x 400 deep window and took gigabytes).
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfDeepFrameBuffer.h>
#include <OpenEXR/ImfDeepScanLineOutputFile.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfPartType.h>
#include <unistd.h>

#include <dof/deep_exr.h>

#include "exr_rgbz.h"

namespace lensfx::dof {
using test::write_small_deep;
namespace {

constexpr std::size_t kMegabyte = std::size_t{1} << 20;

std::string temp_path(const char* name) { return "/tmp/lensfx-test-deep-" + std::to_string(::getpid()) + "-" + name; }

void append_attribute(std::string& out, const std::string& name, const std::string& type, const std::string& value) {
    const auto size = static_cast<std::uint32_t>(value.size());
    out += name + '\0' + type + '\0';
    for (int b = 0; b < 4; ++b) out += static_cast<char>((size >> (8 * b)) & 0xffu);
    out += value;
}

std::string le32(std::int64_t v) {
    std::string s;
    for (int b = 0; b < 4; ++b) s += static_cast<char>((static_cast<std::uint64_t>(v) >> (8 * b)) & 0xffu);
    return s;
}

// A deep scanline header of a few KB that declares a width x height data window (and display window), with
// a line offset table of `height` entries and no pixel data.
std::string hostile_deep_header(int width, int height) {
    std::string out = le32(20000630) + le32(2 | 0x800);  // version 2, non-image (deep) data
    std::string channels;
    for (const char* c : {"A", "B", "G", "R", "Z"}) channels += std::string(c) + '\0' + le32(2) + std::string(4, '\0') + le32(1) + le32(1);
    channels += '\0';
    const std::string box = le32(0) + le32(0) + le32(width - 1) + le32(height - 1);
    append_attribute(out, "channels", "chlist", channels);
    append_attribute(out, "compression", "compression", std::string(1, '\0'));
    append_attribute(out, "dataWindow", "box2i", box);
    append_attribute(out, "displayWindow", "box2i", box);
    append_attribute(out, "lineOrder", "lineOrder", std::string(1, '\0'));
    append_attribute(out, "pixelAspectRatio", "float", le32(0x3f800000));
    append_attribute(out, "screenWindowCenter", "v2f", std::string(8, '\0'));
    append_attribute(out, "screenWindowWidth", "float", le32(0x3f800000));
    append_attribute(out, "type", "string", "deepscanline");
    append_attribute(out, "version", "int", le32(1));
    append_attribute(out, "chunkCount", "int", le32(height));
    append_attribute(out, "maxSamplesPerPixel", "int", le32(4));
    out += '\0';
    const std::size_t table_end = out.size() + 8 * static_cast<std::size_t>(height);
    for (int y = 0; y < height; ++y) out += le32(static_cast<std::int64_t>(table_end)) + le32(0);
    return out + std::string(64, '\0');
}

TEST(DeepExr, ReadsEverySampleOfASmallFile) {
    const std::string path = temp_path("small.exr");
    write_small_deep(path);
    const DeepImage image = read_deep_exr(path, MemoryBudget{64 * kMegabyte});
    std::remove(path.c_str());
    ASSERT_EQ(image.width, 3);
    ASSERT_EQ(image.height, 2);
    ASSERT_EQ(image.offsets.size(), 7u);
    for (std::size_t i = 0; i < 6; ++i) {
        ASSERT_EQ(image.offsets[i + 1] - image.offsets[i], i % 3) << "pixel " << i;
        for (std::uint32_t s = 0; s < i % 3; ++s) {
            const DeepSample& d = image.samples[image.offsets[i] + s];
            EXPECT_EQ(d.r, static_cast<float>(10 * i + s));
            EXPECT_EQ(d.z, 1.0f + static_cast<float>(s));
            EXPECT_EQ(d.zback, d.z);  // no ZBack channel
        }
    }
}

TEST(DeepExr, HugeDeclaredWindowIsRefusedBeforeItsTablesAreMade) {
    const std::string path = temp_path("hostile.exr");
    std::ofstream(path, std::ios::binary) << hostile_deep_header(1 << 20, 400);
    try {
        read_deep_exr(path, MemoryBudget{256 * kMegabyte});
        FAIL() << "a 1048576 x 400 deep window was read under a 256 MB budget";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("1048576x400 deep data window"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
    std::remove(path.c_str());
}

TEST(DeepExr, MergeOverAHugeDisplayWindowIsRefused) {
    DeepImage small;
    small.width = small.height = 1;
    small.full_width = small.full_height = 1 << 20;  // a display window of 10^12 pixels
    small.offsets = {0, 0};
    EXPECT_THROW(merge_deep({small, small}, MemoryBudget{256 * kMegabyte}), MemoryLimitError);
}

}  // namespace
}  // namespace lensfx::dof
