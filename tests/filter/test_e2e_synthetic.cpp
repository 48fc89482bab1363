// End-to-end runs of `lensfx -i IN -o OUT` on images made here (no shared data needed): pass-through of
// per-channel types, windows and metadata; sequences and frame lists; streams through ffmpeg; failures.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <OpenImageIO/imageio.h>
#include <fmt/core.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "filter_test_util.h"
#include <filter/colour/quantise.h>

namespace fs = std::filesystem;
using namespace lensfx::test;

namespace {

// An EXR with per-channel types (half RGBA, float Z, uint id), a data window inside a larger display
// window, and metadata a pipeline must keep. `seed` varies the pixels; `width` the display width.
// `finite`: no half Inf/NaN bit patterns (ffmpeg need not keep NaN payloads).
void make_exr(const fs::path& path, int seed, int display_width = 64, bool finite = false) {
    OIIO::ImageSpec spec(40, 30, 6, OIIO::TypeHalf);
    spec.x = 5 + seed;
    spec.y = 3;
    spec.full_width = display_width;
    spec.full_height = 48;
    spec.channelnames = {"R", "G", "B", "A", "Z", "id"};
    spec.channelformats = {OIIO::TypeHalf, OIIO::TypeHalf, OIIO::TypeHalf, OIIO::TypeHalf, OIIO::TypeFloat, OIIO::TypeUInt32};
    spec.alpha_channel = 3;
    spec.z_channel = 4;
    spec.attribute("compression", "zip");
    spec.attribute("FramesPerSecond", OIIO::TypeRational, std::array<int, 2>{24, 1}.data());
    const float chroma[8] = {0.64f, 0.33f, 0.3f, 0.6f, 0.15f, 0.06f, 0.3127f, 0.329f};
    spec.attribute("chromaticities", OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, 8), chroma);
    const float m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 2, 3, 4, 1};
    spec.attribute("worldToCamera", OIIO::TypeMatrix, m);
    spec.attribute("PixelAspectRatio", 1.5f);
    std::vector<unsigned char> data(spec.image_bytes(true));
    for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<unsigned char>((i * 131 + static_cast<std::size_t>(seed) * 7) % 251);
    // Half bit patterns 0x7c00-0x7fff are Inf/NaN: kept unless `finite`; they must pass through too.
    // A pixel is 4 halfs, a float and a uint32 (16 bytes); a half's high byte is the odd one.
    for (std::size_t i = 0; finite && i < data.size(); ++i) {
        if (i % 16 < 8 && i % 2 == 1) data[i] &= 0xbf;
    }
    auto out = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(out && out->open(path.string(), spec));
    ASSERT_TRUE(out->write_image(OIIO::TypeUnknown, data.data()));
    ASSERT_TRUE(out->close());
}

}  // namespace

TEST(FilterEndToEnd, NoArgumentsPrintsHelp) {
    const auto r = run(lensfx_cmd() + " > /dev/null");
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_EQ(run(lensfx_cmd() + " -i x.exr").exit_code, 2);  // a usage error: no -o
}

TEST(FilterEndToEnd, PassThroughKeepsTypesWindowsAndMetadata) {
    const auto dir = scratch_dir("synthetic");
    make_exr(dir / "in.exr", 0);
    const auto r = run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/out.exr", dir.string()));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(compare_images((dir / "in.exr").string(), (dir / "out.exr").string()), "");
    EXPECT_EQ(file_count(dir), 2u);  // no temporary left
    // Said, not silent: a run without --lens (a forgotten one) writes no flare; -q keeps it quiet.
    EXPECT_EQ(r.stderr_text, "lensfx: 1 frame written without a flare: no --lens was given (lensfx lens list names the presets)\n");
    EXPECT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/out.exr -q", dir.string())).stderr_text, "");
    // --compression changes the compression only.
    ASSERT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/piz.exr --compression piz", dir.string())).exit_code, 0);
    auto in = OIIO::ImageInput::open((dir / "piz.exr").string());
    ASSERT_TRUE(in);
    EXPECT_EQ(in->spec().get_string_attribute("compression"), "piz");
    EXPECT_EQ(compare_images((dir / "in.exr").string(), (dir / "piz.exr").string(), false), "");
    fs::remove_all(dir);
}

TEST(FilterEndToEnd, CompressionLevelsAndUnknownNames) {
    const auto dir = scratch_dir("compression");
    make_exr(dir / "in.exr", 0);
    ASSERT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/dwa.exr --compression dwaa:45", dir.string())).exit_code, 0);
    auto in = OIIO::ImageInput::open((dir / "dwa.exr").string());
    ASSERT_TRUE(in);
    EXPECT_EQ(in->spec().get_string_attribute("compression"), "dwaa");
    EXPECT_EQ(in->spec().get_float_attribute("openexr:dwaCompressionLevel"), 45.0f);
    const auto r = run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/bad.exr --compression lzw", dir.string()));
    EXPECT_EQ(r.exit_code, 2);  // a usage error
    EXPECT_NE(r.stderr_text.find("unknown EXR compression \"lzw\""), std::string::npos) << r.stderr_text;
    EXPECT_FALSE(fs::exists(dir / "bad.exr"));
    for (const char* level : {"zip:42", "dwaa:-5", "dwaa:nan", "piz:3", "dwaa:1e9"}) {  // refused before the frame is read
        const auto bad = run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/bad.exr --compression {1}", dir.string(), level));
        EXPECT_EQ(bad.exit_code, 2) << level;
        EXPECT_NE(bad.stderr_text.find("bad level"), std::string::npos) << level << ": " << bad.stderr_text;
    }
    EXPECT_FALSE(fs::exists(dir / "bad.exr"));
    fs::remove_all(dir);
}

// EXR in, EXR out must not load OpenImageIO (its plug-in libraries cost a quarter second per start);
// another format loads it through liblensfx_oiio.
TEST(FilterEndToEnd, ExrJobsLoadNoOpenImageIO) {
    const auto dir = scratch_dir("startup");
    make_exr(dir / "in.exr", 0);
    auto r = run("LD_DEBUG=files " + lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/out.exr", dir.string()));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(r.stderr_text.find("libOpenImageIO"), std::string::npos);
    r = run("LD_DEBUG=files " + lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/out.tif", dir.string()));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find("liblensfx_oiio"), std::string::npos);
    EXPECT_NE(r.stderr_text.find("libOpenImageIO"), std::string::npos);
    fs::remove_all(dir);
}

TEST(FilterEndToEnd, SequencesFrameListsAndReport) {
    const auto dir = scratch_dir("sequence");
    fs::create_directories(dir / "in");
    for (int f : {1, 2, 3, 4, 5, 6, 8}) make_exr(dir / "in" / fmt::format("s.{:04}.exr", f), f);
    const std::string in = (dir / "in" / "s.####.exr").string();
    auto outputs = [&](const std::string& sub) {
        std::vector<std::string> names;
        for (const auto& e : fs::directory_iterator(dir / sub)) names.push_back(e.path().filename().string());
        std::sort(names.begin(), names.end());
        return names;
    };
    fs::create_directories(dir / "a");
    auto r = run(lensfx_cmd() + fmt::format(" -i {} -o {}/a/o.%04d.exr --report {}/a.json", in, dir.string(), dir.string()));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(outputs("a"), (std::vector<std::string>{"o.0001.exr", "o.0002.exr", "o.0003.exr", "o.0004.exr", "o.0005.exr", "o.0006.exr", "o.0008.exr"}));
    EXPECT_EQ(compare_images((dir / "in/s.0008.exr").string(), (dir / "a/o.0008.exr").string()), "");
    std::ifstream report_file(dir / "a.json");
    const auto report = nlohmann::json::parse(report_file);
    EXPECT_EQ(report["frames_written"], 7);
    ASSERT_EQ(report["frames"].size(), 7u);
    EXPECT_EQ(report["frames"][6]["number"], 8);
    EXPECT_GT(report["frames"][0]["read_ms"].get<double>(), 0.0);
    EXPECT_GT(report["frames"][0]["write_ms"].get<double>(), 0.0);

    fs::create_directories(dir / "b");
    r = run(lensfx_cmd() + fmt::format(" -i {} -o {}/b/o.@.exr --frames 1-6x2,8 -q", in, dir.string()));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(outputs("b"), (std::vector<std::string>{"o.1.exr", "o.3.exr", "o.5.exr", "o.8.exr"}));

    // Frame 7 is missing: a one-line error naming it, before anything is written (frame 6's output, had it existed,
    // is left as it was); with --skip-bad-frames the rest.
    fs::create_directories(dir / "c");
    r = run(lensfx_cmd() + fmt::format(" -i {} -o {}/c/o.#.exr --frames 6-8", in, dir.string()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("s.0007.exr: frame 7:"), std::string::npos) << r.stderr_text;
    EXPECT_EQ(std::count(r.stderr_text.begin(), r.stderr_text.end(), '\n'), 1);
    EXPECT_EQ(outputs("c"), (std::vector<std::string>{}));
    r = run(lensfx_cmd() + fmt::format(" -i {} -o {}/c/o.#.exr --frames 6-8 --skip-bad-frames", in, dir.string()));
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find("skipped (frames 7)"), std::string::npos) << r.stderr_text;
    EXPECT_EQ(outputs("c"), (std::vector<std::string>{"o.0006.exr", "o.0008.exr"}));

    // A frame whose size differs from the first.
    make_exr(dir / "in" / "s.0004.exr", 4, 80);
    fs::create_directories(dir / "d");
    r = run(lensfx_cmd() + fmt::format(" -i {} -o {}/d/o.#.exr --frames 1-5", in, dir.string()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("s.0004.exr: frame 4: frame size 80x48 differs"), std::string::npos) << r.stderr_text;
    EXPECT_FALSE(fs::exists(dir / "d/o.0004.exr"));
    EXPECT_FALSE(fs::exists(dir / "d/o.0005.exr"));
    fs::remove_all(dir);
}

TEST(FilterEndToEnd, RefusesBadOutputsAndNeverOverwritesInputs) {
    const auto dir = scratch_dir("outputs");
    make_exr(dir / "in.exr", 1);
    fs::create_hard_link(dir / "in.exr", dir / "link.exr");
    const std::string in = (dir / "in.exr").string();
    auto r = run(lensfx_cmd() + fmt::format(" -i {} -o {}", in, in));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("refusing to overwrite"), std::string::npos) << r.stderr_text;
    r = run(lensfx_cmd() + fmt::format(" -i {} -o {}/link.exr", in, dir.string()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("refusing to overwrite"), std::string::npos) << r.stderr_text;
    r = run(lensfx_cmd() + fmt::format(" -i {} -o {}/missing/out.exr", in, dir.string()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("does not exist"), std::string::npos) << r.stderr_text;
    r = run(lensfx_cmd() + fmt::format(" -i {} -o {}/out.xyz", in, dir.string()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("unknown output format"), std::string::npos) << r.stderr_text;
    // OpenImageIO's writers that make no picture file: refused before any frame is read. -o x.term printed the frame
    // on stdout as escape codes, then failed.
    for (const char* ext : {"term", "null", "zfile"}) {
        r = run(lensfx_cmd() + fmt::format(" -i {0} -o {1}/out.{2} > {1}/stdout.txt", in, dir.string(), ext));
        EXPECT_EQ(r.exit_code, 1) << ext;
        EXPECT_EQ(fs::file_size(dir / "stdout.txt"), 0u) << ext;
        fs::remove(dir / "stdout.txt");
        EXPECT_NE(r.stderr_text.find("writer makes no image file"), std::string::npos) << r.stderr_text;
    }
    // An unknown input format.
    std::ofstream(dir / "notes.exr") << "not an image";
    r = run(lensfx_cmd() + fmt::format(" -i {0}/notes.exr -o {0}/out.exr", dir.string()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("notes.exr: frame 1:"), std::string::npos) << r.stderr_text;
    EXPECT_EQ(file_count(dir), 3u);  // in, link, notes: nothing written
    // The output path is a directory: the write fails, leaving no temporary.
    fs::create_directories(dir / "taken.exr");
    r = run(lensfx_cmd() + fmt::format(" -i {0} -o {1}/taken.exr", in, dir.string()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_EQ(file_count(dir), 3u);
    fs::remove_all(dir);
}

TEST(FilterEndToEnd, FormatsHdrTiffPfm) {
    const auto dir = scratch_dir("formats");
    make_exr(dir / "in.exr", 2);
    for (const char* ext : {"tif", "hdr", "pfm"}) {
        const auto r = run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/out.{1}", dir.string(), ext));
        ASSERT_EQ(r.exit_code, 0) << ext << ": " << r.stderr_text;
        // Back to EXR: R, G, B must survive (exactly for TIFF and PFM, within RGBE's 8-bit mantissa for HDR).
        const auto back = run(lensfx_cmd() + fmt::format(" -i {0}/out.{1} -o {0}/back.{1}.exr", dir.string(), ext));
        ASSERT_EQ(back.exit_code, 0) << ext << ": " << back.stderr_text;
    }
    EXPECT_EQ(compare_images((dir / "in.exr").string(), (dir / "back.tif.exr").string(), false), "channel names differ");
    // A TIFF's own metadata passes through a TIFF output.
    {
        OIIO::ImageSpec spec(8, 4, 3, OIIO::TypeFloat);
        spec.attribute("ImageDescription", "plate 12, take 3");
        spec.attribute("Artist", "lensfx test");
        const std::vector<float> px(8 * 4 * 3, 0.25f);
        auto out = OIIO::ImageOutput::create((dir / "meta.tif").string());
        ASSERT_TRUE(out && out->open((dir / "meta.tif").string(), spec) && out->write_image(OIIO::TypeFloat, px.data()) && out->close());
    }
    ASSERT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/meta.tif -o {0}/meta.out.tif", dir.string())).exit_code, 0);
    auto in = OIIO::ImageInput::open((dir / "meta.out.tif").string());
    ASSERT_TRUE(in);
    EXPECT_EQ(in->spec().get_string_attribute("ImageDescription"), "plate 12, take 3");
    EXPECT_EQ(in->spec().get_string_attribute("Artist"), "lensfx test");
    fs::remove_all(dir);
}

// lensfx's output `ext` of `input` (in `dir`) read back by OpenImageIO: its pixel count, or -1 when unreadable.
long written_pixels(const fs::path& dir, const std::string& input, const std::string& ext) {
    const fs::path out = dir / fmt::format("out.{}", ext);
    const auto r = run(lensfx_cmd() + fmt::format(" -i {}/{} -o {} -q", dir.string(), input, out.string()));
    EXPECT_EQ(r.exit_code, 0) << ext << ": " << r.stderr_text;
    auto in = OIIO::ImageInput::open(out.string());
    if (!in) {
        ADD_FAILURE() << ext << ": " << OIIO::geterror();
        return -1;
    }
    std::vector<float> pixels(static_cast<std::size_t>(in->spec().image_pixels()) * static_cast<std::size_t>(in->spec().nchannels));
    if (!in->read_image(0, 0, 0, in->spec().nchannels, OIIO::TypeFloat, pixels.data())) return -1;
    return static_cast<long>(in->spec().image_pixels());
}

// Whether this OpenImageIO writes files of extension `ext`.
bool oiio_writes(const std::string& ext) {
    if (OIIO::ImageOutput::create("x." + ext)) return true;
    (void)OIIO::geterror();
    return false;
}

// Every format OpenImageIO writes here comes out whole under its own name. The output is written unnamed (as
// /proc/self/fd/N), so the writer is opened under the file's name, whose extension some writers read: JPEG 2000
// once wrote a header alone without an error. A data window off the origin (x 5, y 3) goes to the formats that cannot
// place it at 0,0: BMP refused it, FITS wrote too few rows and WebP crashed (a double free) before.
TEST(FilterEndToEnd, EveryOpenImageIOFormatReadsBack) {
    const auto dir = scratch_dir("oiio-formats");
    make_exr(dir / "in.exr", 0, 64, true);
    for (const char* ext : {"png", "jpg", "tif", "hdr", "dpx", "tga", "bmp", "sgi", "webp", "fits", "rla"}) {
        if (oiio_writes(ext)) {
            EXPECT_EQ(written_pixels(dir, "in.exr", ext), 40 * 30) << ext;
        }
    }
    // JPEG 2000 at 64 x 64 (OpenJPEG's six resolution levels want 32 pixels a side; below that OpenImageIO writes a
    // header alone, oiiotool too).
    {
        OIIO::ImageSpec spec(64, 64, 3, OIIO::TypeFloat);
        const std::vector<float> px(64 * 64 * 3, 0.5f);
        auto out = OIIO::ImageOutput::create((dir / "big.exr").string());
        ASSERT_TRUE(out && out->open((dir / "big.exr").string(), spec) && out->write_image(OIIO::TypeFloat, px.data()) && out->close());
    }
    for (const char* ext : {"jp2", "j2k"}) {
        if (!oiio_writes(ext)) continue;
        EXPECT_EQ(written_pixels(dir, "big.exr", ext), 64 * 64) << ext;
        // 40 x 30 is refused in one line, no file written.
        const auto r = run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/small.{1} -q", dir.string(), ext));
        EXPECT_EQ(r.exit_code, 1) << ext;
        EXPECT_NE(r.stderr_text.find("JPEG 2000 needs at least 32 pixels a side"), std::string::npos) << r.stderr_text;
        EXPECT_FALSE(fs::exists(dir / fmt::format("small.{}", ext)));
    }
    for (const auto& e : fs::directory_iterator(dir)) EXPECT_NE(e.path().filename().string()[0], '.') << "a temporary: " << e.path();
    fs::remove_all(dir);
}

// R, G, B of an image file as float, or empty (with a failure) when it cannot be read.
std::vector<float> rgb_of(const fs::path& file) {
    auto in = OIIO::ImageInput::open(file.string());
    if (!in) {
        ADD_FAILURE() << file << ": " << OIIO::geterror();
        return {};
    }
    std::vector<float> rgb(static_cast<std::size_t>(in->spec().image_pixels()) * 3);
    EXPECT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeFloat, rgb.data())) << file << ": " << in->geterror();
    return rgb;
}

// Every file lensfx writes as 8- or 16-bit integers shows the display view, as PNG does: the lossless ones hold the
// PNG's very pixels. IFF failed to write at all (its writer makes the file tiled and refuses scanlines, silently),
// and IFF, SGI, RLA and FITS held the scene-linear values clipped and quantised, with no view transform.
TEST(FilterEndToEnd, IntegerFormatsHoldThePngsPixels) {
    const auto dir = scratch_dir("integer-formats");
    {
        OIIO::ImageSpec spec(96, 70, 3, OIIO::TypeHalf);  // over a 64 x 64 IFF tile both ways
        std::vector<float> px(96 * 70 * 3);
        for (std::size_t i = 0; i < px.size(); ++i) px[i] = 4.0f * static_cast<float>((i * 37) % 1000) / 1000.0f;
        auto out = OIIO::ImageOutput::create((dir / "in.exr").string());
        ASSERT_TRUE(out && out->open((dir / "in.exr").string(), spec) && out->write_image(OIIO::TypeFloat, px.data()) && out->close());
    }
    auto write = [&](const std::string& ext) {
        const auto r = run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/out.{1} -q", dir.string(), ext));
        EXPECT_EQ(r.exit_code, 0) << ext << ": " << r.stderr_text;
        return rgb_of(dir / ("out." + ext));
    };
    const std::vector<float> png = write("png");
    ASSERT_EQ(png.size(), 96u * 70u * 3u);
    for (const char* ext : {"iff", "sgi", "rla", "fits", "bmp", "tga", "ppm", "dpx"}) {
        if (!oiio_writes(ext)) continue;
        const std::vector<float> got = write(ext);
        ASSERT_EQ(got.size(), png.size()) << ext;
        std::size_t differ = 0;
        for (std::size_t i = 0; i < png.size(); ++i) differ += got[i] != png[i];
        EXPECT_EQ(differ, 0u) << ext << ": values unlike the PNG's";
    }
    fs::remove_all(dir);
}

// A movie OpenImageIO reads (an animated GIF here; a video through its ffmpeg reader alike) is refused, naming the
// ffmpeg pipe: its first frame alone was read before, and the run looked whole. A still GIF is read as before.
TEST(FilterEndToEnd, MoviesAreRefusedWithThePipeToUse) {
    if (!oiio_writes("gif")) GTEST_SKIP() << "no GIF writer";
    const auto dir = scratch_dir("movies");
    OIIO::ImageSpec spec(32, 24, 3, OIIO::TypeUInt8);
    const std::vector<unsigned char> px(32 * 24 * 3, 128);
    auto write_gif = [&](const fs::path& path, int frames) {
        auto out = OIIO::ImageOutput::create(path.string());
        ASSERT_TRUE(out);
        std::vector<OIIO::ImageSpec> specs(static_cast<std::size_t>(frames), spec);
        ASSERT_TRUE(out->open(path.string(), frames, specs.data())) << out->geterror();
        for (int f = 0; f < frames; ++f) {
            if (f > 0) {
                ASSERT_TRUE(out->open(path.string(), spec, OIIO::ImageOutput::AppendSubimage)) << out->geterror();
            }
            ASSERT_TRUE(out->write_image(OIIO::TypeUInt8, px.data())) << out->geterror();
        }
        ASSERT_TRUE(out->close());
    };
    write_gif(dir / "anim.gif", 3);
    write_gif(dir / "still.gif", 1);
    auto r = run(lensfx_cmd() + fmt::format(" -i {0}/anim.gif -o {0}/anim.exr", dir.string()));
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.stderr_text.find("anim.gif: frame 1: a movie of"), std::string::npos) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find("-f image2pipe -c:v exr - | lensfx -i -"), std::string::npos) << r.stderr_text;
    EXPECT_FALSE(fs::exists(dir / "anim.exr"));
    r = run(lensfx_cmd() + fmt::format(" -i {0}/still.gif -o {0}/still.exr -q", dir.string()));
    EXPECT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_TRUE(fs::exists(dir / "still.exr"));
    fs::remove_all(dir);
}

// The display view goes to exactly the formats image_io writes as integers: every extension OpenImageIO gives a
// format it writes, but OpenEXR's, TIFF's and Radiance HDR's (scene-linear) and PFM (lensfx's own, float).
TEST(FilterEndToEnd, DisplayViewGoesToEveryIntegerFormat) {
    std::set<std::string> outputs;
    std::stringstream output_list{std::string(OIIO::get_string_attribute("output_format_list"))};
    for (std::string format; std::getline(output_list, format, ',');) outputs.insert(format);
    std::stringstream list{std::string(OIIO::get_string_attribute("extension_list"))};
    int checked = 0;
    for (std::string entry; std::getline(list, entry, ';');) {
        const auto colon = entry.find(':');
        const std::string format = entry.substr(0, colon);
        if (colon == std::string::npos || !outputs.count(format)) continue;  // read only
        if (format == "null" || format == "term" || format == "zfile") continue;  // no picture, or one channel
        const bool linear = format == "openexr" || format == "tiff" || format == "hdr";
        std::stringstream extensions(entry.substr(colon + 1));
        for (std::string ext; std::getline(extensions, ext, ',');) {
            if (ext == "pfm") continue;
            EXPECT_EQ(lensfx::colour::is_display_referred_format("out." + ext), !linear) << format << " ." << ext;
            ++checked;
        }
    }
    EXPECT_GT(checked, 30);
}

TEST(FilterEndToEnd, FfmpegPfmAndRawRoundTrips) {
    if (run("command -v ffmpeg > /dev/null").exit_code != 0) GTEST_SKIP() << "ffmpeg is not installed";
    const auto dir = scratch_dir("ffmpeg");
    const std::string d = dir.string();
    make_exr(dir / "in.exr", 3, 64, true);
    // Reference RGB as float over the display window, written by lensfx to a PFM in ffmpeg's row order.
    ASSERT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/ref.pfm --pfm-order top", d)).exit_code, 0);
    // ffmpeg -> lensfx -> ffmpeg through pipes, two frames.
    auto r = run(fmt::format("cat {0}/ref.pfm {0}/ref.pfm | ffmpeg -v error -f pfm_pipe -i - -f image2pipe -c:v pfm - | "
                             "{1} -i - -o - | ffmpeg -v error -y -f pfm_pipe -i - -c:v pfm -f image2 {0}/back.%d.pfm", d, lensfx_cmd()));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    for (int i : {1, 2}) {
        const auto back = run(lensfx_cmd() + fmt::format(" -i {0}/back.{1}.pfm --pfm-order top -o {0}/back.{1}.exr", d, i));
        ASSERT_EQ(back.exit_code, 0) << back.stderr_text;
    }
    ASSERT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/ref.pfm --pfm-order top -o {0}/ref.exr", d)).exit_code, 0);
    EXPECT_EQ(compare_images(d + "/ref.exr", d + "/back.1.exr", false), "");
    EXPECT_EQ(compare_images(d + "/ref.exr", d + "/back.2.exr", false), "");

    // rawvideo gbrpf32le: lensfx -> ffmpeg (decode, re-encode) -> lensfx.
    r = run(fmt::format("{1} -i {0}/in.exr -o - --pix-fmt gbrpf32le | ffmpeg -v error -f rawvideo -pix_fmt gbrpf32le -s 64x48 -i - "
                        "-f rawvideo -pix_fmt gbrpf32le - | {1} -i - --pix-fmt gbrpf32le --size 64x48 -o {0}/raw.exr", d, lensfx_cmd()));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(compare_images(d + "/ref.exr", d + "/raw.exr", false), "");
    // A truncated raw stream is an error naming stdin and the frame.
    r = run(fmt::format("head -c 20000 {0}/ref.pfm | {1} -i - --pix-fmt gbrpf32le --size 64x48 -o {0}/t.exr", d, lensfx_cmd()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("stdin: frame 1:"), std::string::npos) << r.stderr_text;
    EXPECT_FALSE(fs::exists(dir / "t.exr"));
    fs::remove_all(dir);
}

namespace {

// Standard output of a shell command (bash), stderr dropped.
std::string stdout_of(const std::string& command) {
    std::string out;
    if (std::FILE* p = ::popen(command.c_str(), "r")) {
        char buf[4096];
        for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
        ::pclose(p);
    }
    return out;
}

}  // namespace

// EXR images on the pipes: every channel (alpha, Z, a uint id), type, window and attribute pass a stream
// in and out unchanged; the output stream follows the input's (PFM stays PFM) unless --stream-format.
// --pfm-order auto: a PFM file redirected to stdin (or stdout redirected to a file) is a file, bottom row first,
// as lensfx writes PFM files; only a pipe carries ffmpeg's top-first order.
TEST(FilterEndToEnd, RedirectedPfmFilesKeepTheFileOrder) {
    const auto dir = scratch_dir("pfm-redirect");
    const std::string d = dir.string();
    make_exr(dir / "in.exr", 3, 64, true);
    ASSERT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o {0}/a.pfm", d)).exit_code, 0);
    ASSERT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/a.pfm -o {0}/file.exr", d)).exit_code, 0);
    const auto r = run(lensfx_cmd() + fmt::format(" -i - -o {0}/redirected.exr < {0}/a.pfm", d));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(compare_images(d + "/file.exr", d + "/redirected.exr", false), "");
    ASSERT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/in.exr -o - --stream-format pfm > {0}/b.pfm", d)).exit_code, 0);
    EXPECT_EQ(run(fmt::format("cmp {0}/a.pfm {0}/b.pfm", d)).exit_code, 0);
    fs::remove_all(dir);
}

TEST(FilterEndToEnd, ExrStreamsKeepEverything) {
    const auto dir = scratch_dir("exrstream");
    const std::string d = dir.string();
    make_exr(dir / "a.exr", 0);
    make_exr(dir / "b.exr", 1);
    auto r = run(fmt::format("cat {0}/a.exr {0}/b.exr | {1} -i - -o {0}/out.#.exr", d, lensfx_cmd()));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(compare_images(d + "/a.exr", d + "/out.0001.exr"), "");
    EXPECT_EQ(compare_images(d + "/b.exr", d + "/out.0002.exr"), "");
    // Files -> EXR stream -> lensfx -> EXR stream -> files.
    r = run(fmt::format("{1} -i {0}/a.exr -o - | {1} -i - -o - | {1} -i - -o {0}/back.exr", d, lensfx_cmd()));
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_EQ(compare_images(d + "/a.exr", d + "/back.exr"), "");
    EXPECT_EQ(stdout_of(fmt::format("cat {0}/a.exr | {1} -i - -o - | head -c 4 | od -An -tx1", d, lensfx_cmd())), " 76 2f 31 01\n");
    // A PFM stream stays PFM; --stream-format chooses.
    ASSERT_EQ(run(lensfx_cmd() + fmt::format(" -i {0}/a.exr -o {0}/a.pfm", d)).exit_code, 0);
    EXPECT_EQ(stdout_of(fmt::format("cat {0}/a.pfm | {1} -i - -o - | head -c 2", d, lensfx_cmd())), "PF");
    EXPECT_EQ(stdout_of(fmt::format("cat {0}/a.pfm | {1} -i - -o - --stream-format exr | head -c 1 | od -An -tx1", d, lensfx_cmd())), " 76\n");
    // Truncated streams and options that do not apply fail with one line naming what is wrong.
    r = run(fmt::format("head -c $(( $(stat -c %s {0}/a.exr) - 100 )) {0}/a.exr | {1} -i - -o {0}/t.exr", d, lensfx_cmd()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.stderr_text.find("stdin: frame 1: stream ended inside an EXR image"), std::string::npos) << r.stderr_text;
    r = run(fmt::format("{1} -i {0}/a.exr -o {0}/x.exr --stream-format pfm", d, lensfx_cmd()));
    EXPECT_NE(r.stderr_text.find("--stream-format says what - carries"), std::string::npos) << r.stderr_text;
    r = run(fmt::format("{1} -i {0}/a.exr -o - --stream-format raw > /dev/null", d, lensfx_cmd()));
    EXPECT_NE(r.stderr_text.find("--stream-format raw needs --pix-fmt"), std::string::npos) << r.stderr_text;
    r = run(fmt::format("echo hello | {1} -i - -o {0}/x.exr", d, lensfx_cmd()));
    EXPECT_NE(r.stderr_text.find("not an EXR or PFM stream"), std::string::npos) << r.stderr_text;
    fs::remove_all(dir);
}
