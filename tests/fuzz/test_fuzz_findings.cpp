// What the fuzz targets found (docs/fuzzing.md), each reproducer's bytes inline: the fixed behaviour is
// a one-line refusal, never a crash, undefined behaviour, a file that does not read back or an
// allocation of what a header merely declared.
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include <detect/track_file.h>
#include <filter/image_io.h>
#include <filter/stream.h>
#include <optics/importers.h>
#include <optics/lens_file.h>

using namespace lensfx;

namespace {

// The message of the LensFileError `parse` throws ("" when it throws none).
template <typename Parse>
std::string lens_error(Parse parse) {
    try {
        parse();
    } catch (const optics::LensFileError& e) {
        return e.what();
    }
    return "";
}

// What the fuzz targets check of every lens a parser accepts: the project's own format reads it back.
void expect_round_trip(const optics::Lens& lens) {
    EXPECT_NO_THROW((void)optics::parse_lens_toml(optics::write_lens_toml(lens), "round-trip.toml"));
}

}  // namespace

// fuzz_lens_pbrt: an eta of 51.6 was imported, and `lens convert` wrote a TOML file its own reader refuses
// ("nd: 51.603 is not a refractive index of glass (1 to 3)"). Every parser now keeps the TOML's range.
TEST(FuzzFindings, PbrtIndexOutsideTheLensFormatsRangeIsRefused) {
    const std::string rows = "0\t67.4125\t0\t40.5\n-32.13\t3.755\t1.613\t31.5\n49.123\t5522.\t{}\t33.5\n-50.945\t0\t1\t37\n";
    auto with_eta = [&](const std::string& eta) { return std::string(rows).replace(rows.find("{}"), 2, eta); };
    const std::string error = lens_error([&] { optics::parse_pbrt_dat(with_eta("51.603"), "tele.dat"); });
    EXPECT_NE(error.find("tele.dat:3: surface 3: nd: refractive index 51.603"), std::string::npos) << error;
    expect_round_trip(optics::parse_pbrt_dat(with_eta("1.603"), "tele.dat"));
}

// fuzz_lens_pbrt: a nearly afocal lens whose paraxial focus lies 116 m behind its last surface was imported
// with that back focal distance as its last thickness, which the TOML reader refuses (no lens is 10 m long).
// The importer now checks the thickness it sets as the reader would.
TEST(FuzzFindings, PbrtBackFocalDistanceBeyondAnyLensIsRefused) {
    const std::string rows = "# SIGLE152\t1.529\t47.5\r\t18\t3.755\t1.599\t44.5\r\n271.7625\t2.8175\t1.599\t44.5\r\n"
                             "271.7625\t2.8175\t1\t41.5\r\n0\t65\t0\t40.37\r\n";
    const std::string error = lens_error([&] { optics::parse_pbrt_dat(rows, "afocal.dat"); });
    EXPECT_NE(error.find("afocal.dat:4: surface 3: t: 116361.5"), std::string::npos) << error;
    EXPECT_NE(error.find("mm is beyond any lens"), std::string::npos) << error;
}

// fuzz_lens_lentil: an Abbe number of 319 was imported (the TOML reader takes (0, 150]).
TEST(FuzzFindings, LentilAbbeNumberOutsideTheLensFormatsRangeIsRefused) {
    const std::string rows = "# x\n40.82 2.0 abbe 1.883 40.81 22\n12.969 12.306 air 12.7\n100000 1.1 iris 6\n"
                             "-21.82 1.0 abbe 2.0 {} 10\n-29.68 30 air 10\n";
    auto with_vd = [&](const std::string& vd) { return std::string(rows).replace(rows.find("{}"), 2, vd); };
    const std::string error = lens_error([&] { optics::parse_lentil_fx(with_vd("319.32"), "eye.fx"); });
    EXPECT_NE(error.find("eye.fx:5: surface 4: vd: Abbe number 319.32 outside (0, 150]"), std::string::npos) << error;
    expect_round_trip(optics::parse_lentil_fx(with_vd("31.93"), "eye.fx"));
}

// fuzz_track_file: a "version" of 1e30 was converted to int before the comparison (undefined behaviour;
// UBSan: "1e+30 is outside the range of representable values of type 'int'").
TEST(FuzzFindings, TrackFileVersionBeyondIntIsRefused) {
    try {
        (void)detect::parse_track_json(R"({"version": 1e30, "tracks": []})", "shot.json");
        FAIL() << "accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_STREQ(e.what(), "shot.json: track file version 1e+30 (this program reads 1)");
    }
    EXPECT_NO_THROW((void)detect::parse_track_json(R"({"version": 1, "tracks": []})", "shot.json"));
}

// fuzz_track_file: a number beyond double ("11e310") made nlohmann::json throw out_of_range, which escaped
// the parser's catch of parse_error (the program would have printed JSON's message without the file).
TEST(FuzzFindings, TrackFileNumberBeyondDoubleIsRefusedNamingTheFile) {
    try {
        (void)detect::parse_track_json(R"({"tracks": [], "width": 11e310})", "shot.json");
        FAIL() << "accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()).rfind("shot.json: not valid JSON: ", 0), 0u) << e.what();
    }
}

namespace {

// The exit status of `body` run in a child process whose address space is limited to what it has now
// plus `headroom` bytes: 0 when it returned normally, 1 when it threw std::bad_alloc.
template <typename Body>
int status_with_address_space_headroom(std::size_t headroom, Body body) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        std::size_t vm_kb = 0;
        std::ifstream status("/proc/self/status");
        for (std::string line; std::getline(status, line);)
            if (line.rfind("VmSize:", 0) == 0) vm_kb = std::stoul(line.substr(7));
        const rlim_t limit = vm_kb * 1024 + headroom;
        const rlimit r{limit, limit};
        ::setrlimit(RLIMIT_AS, &r);
        try {
            body();
        } catch (const std::bad_alloc&) {
            ::_exit(1);
        }
        ::_exit(0);
    }
    int status = -1;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

}  // namespace

// fuzz_pfm_reader: a 20-byte header declaring 65536 x 65536 RGB allocated the 48 GiB it declared before
// reading a pixel. Now the frame is allocated only once its first 64 MiB of pixels have arrived, so a
// short stream fails on its own data ("stream ended inside ...") within a small address space.
TEST(FuzzFindings, PfmHeaderAloneDoesNotAllocateTheImageItDeclares) {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "AddressSanitizer reserves more address space than the limit this test sets";
#else
    const std::string bytes = "PF\n65536 65536\n-1.0\n" + std::string(12, '\0');
    std::string message;
    const int status = status_with_address_space_headroom(std::size_t{1} << 30, [&] {
        std::FILE* in = fmemopen(const_cast<char*>(bytes.data()), bytes.size(), "rb");
        try {
            (void)filter::read_pfm(in, true);
        } catch (const std::runtime_error& e) {
            message = e.what();
        }
        std::fclose(in);
        if (message.find("stream ended inside a PFM image's pixels (12 of 51539607552 bytes)") == std::string::npos) ::_exit(2);
    });
    EXPECT_EQ(status, 0) << "1: std::bad_alloc (the declared size was allocated); 2: another outcome";
#endif
}

// fuzz_exr_reader: an 800-byte EXR whose header declared a string attribute of about 2 GB made OpenEXR
// allocate and clear it before finding the file too short (over 10 s under the sanitizers). Each
// attribute's declared size is now checked against the bytes the file has before OpenEXR reads it.
// (fuzz/corpus/exr_reader/finding-*.exr hold the fuzzer's two inputs, the second a channel list that
// runs past its declared size, after which OpenEXR read garbage as a 1.7 GB attribute.)
TEST(FuzzFindings, ExrAttributeLargerThanTheFileIsRefusedBeforeOpenExrAllocatesIt) {
    const std::string path = ::testing::TempDir() + "fuzz_attribute_size.exr";
    const float rgb[3] = {1.0f, 2.0f, 3.0f};
    filter::write_image(filter::image_frame(1, 1, 3, filter::PixelType::float32, rgb), path);
    EXPECT_EQ(filter::read_image(path).spec.width, 1);  // the check passes a good file
    std::ostringstream read;
    read << std::ifstream(path, std::ios::binary).rdbuf();
    std::string bytes = read.str();
    // The first attribute: name, type, then its 4-byte little-endian size.
    const std::size_t name_end = bytes.find('\0', 8), type_end = bytes.find('\0', name_end + 1);
    const std::string name = bytes.substr(8, name_end - 8), type = bytes.substr(name_end + 1, type_end - name_end - 1);
    bytes.replace(type_end + 1, 4, std::string("\x00\xff\xff\x7f", 4));  // 0x7fffff00
    std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    try {
        (void)filter::read_image(path);
        FAIL() << "accepted";
    } catch (const std::runtime_error& e) {
        const std::string expected = "header attribute \"" + name + "\" of type " + type + " declares 2147483392 bytes";
        EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
    std::remove(path.c_str());
}

// fuzz_exr_reader's two inputs as found (kept in the seed corpus): each is refused by the header check.
TEST(FuzzFindings, ExrFuzzerInputsAreRefusedByTheHeaderCheck) {
    for (const char* name : {"finding-attribute-size.exr", "finding-chlist-overrun.exr"}) {
        const std::string path = std::string(LENSFX_SOURCE_DIR) + "/fuzz/corpus/exr_reader/" + name;
        try {
            (void)filter::read_image(path);
            ADD_FAILURE() << name << " accepted";
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("header attribute"), std::string::npos) << name << ": " << e.what();
        }
    }
}

// fuzz_exr_reader (open until this fix): a header declaring a data window 2^30 pixels wide made OpenEXR
// allocate its per-line tables and line buffers when the file was opened (seconds and gigabytes under the
// sanitizers), before any check of ours. The header walk now refuses windows beyond 2^20 pixels a side.
TEST(FuzzFindings, ExrDataWindowBeyondWhatLensfxReadsIsRefusedBeforeOpenExrOpensIt) {
    const std::string path = ::testing::TempDir() + "fuzz_wide_window.exr";
    const float rgb[3] = {1.0f, 2.0f, 3.0f};
    filter::write_image(filter::image_frame(1, 1, 3, filter::PixelType::float32, rgb), path);
    std::ostringstream read;
    read << std::ifstream(path, std::ios::binary).rdbuf();
    std::string bytes = read.str();
    // dataWindow's value: name, type "box2i", size 16, then xmin, ymin, xmax, ymax; xmax becomes 2^30.
    const std::string key = std::string("dataWindow") + '\0' + "box2i" + '\0';
    const std::size_t at = bytes.find(key);
    ASSERT_NE(at, std::string::npos);
    bytes.replace(at + key.size() + 4 + 8, 4, std::string("\x00\x00\x00\x40", 4));
    std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    try {
        (void)filter::read_image(path);
        FAIL() << "accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("data window 1073741825x1 is beyond"), std::string::npos) << e.what();
    }
    std::remove(path.c_str());
}

// fuzz_exr_reader (CI, stop 17's run): a deep EXR whose chunkCount attribute was negative (0xfff70003).
// OpenEXR sized its offset table by it and threw std::length_error out of its constructor, which escaped
// every catch of Iex and std::runtime_error (the target aborted; lensfx printed "vector::_M_default_append").
// The header walk now refuses a chunk count the file cannot hold, and whatever else OpenEXR's reader
// throws becomes a std::runtime_error.
TEST(FuzzFindings, ExrChunkCountBeyondTheFileIsRefusedBeforeOpenExrSizesItsTable) {
    const std::string path = std::string(LENSFX_SOURCE_DIR) + "/fuzz/corpus/exr_reader/finding-chunk-count.exr";
    try {
        (void)filter::read_image(path);
        FAIL() << "accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("\"chunkCount\" declares -589821 chunks"), std::string::npos) << e.what();
    }
}

// Every EXR finding read from a stream (stdin), which lensfx's own header parser (stream.cpp) reads before
// OpenEXR: a std::runtime_error (one lensfx line), never another exception or a crash.
TEST(FuzzFindings, ExrFindingsOnAStreamAreRefusedAsErrors) {
    for (const char* name : {"finding-chunk-count.exr", "finding-attribute-size.exr", "finding-chlist-overrun.exr", "finding-deep-window.exr"}) {
        std::ostringstream read;
        read << std::ifstream(std::string(LENSFX_SOURCE_DIR) + "/fuzz/corpus/exr_reader/" + name, std::ios::binary).rdbuf();
        std::string bytes = read.str();
        ASSERT_FALSE(bytes.empty()) << name;
        std::FILE* in = ::fmemopen(bytes.data(), bytes.size(), "rb");
        ASSERT_NE(in, nullptr);
        EXPECT_THROW((void)filter::read_exr_stream(in), std::runtime_error) << name;
        std::fclose(in);
    }
}
