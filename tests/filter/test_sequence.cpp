// Frame-number patterns, frame lists and directory scans.
#include <filter/sequence.h>

#include <filesystem>
#include <fstream>
#include <limits>

#include <gtest/gtest.h>
#include <unistd.h>

namespace fs = std::filesystem;
using lensfx::filter::FramePattern;
using lensfx::filter::parse_frame_list;
using lensfx::filter::parse_pattern;
using lensfx::filter::scan_frames;

TEST(Pattern, TokensAndPadding) {
    EXPECT_EQ(parse_pattern("a/shot.#.exr").path(7), "a/shot.0007.exr");
    EXPECT_EQ(parse_pattern("a/shot.####.exr").path(7), "a/shot.0007.exr");
    EXPECT_EQ(parse_pattern("a/shot.######.exr").path(7), "a/shot.000007.exr");
    EXPECT_EQ(parse_pattern("shot.@.exr").path(7), "shot.7.exr");
    EXPECT_EQ(parse_pattern("shot.@@@.exr").path(7), "shot.007.exr");
    EXPECT_EQ(parse_pattern("shot.%04d.exr").path(12345), "shot.12345.exr");
    EXPECT_EQ(parse_pattern("shot.%d.exr").path(12), "shot.12.exr");
    EXPECT_EQ(parse_pattern("shot.#.exr").path(-3), "shot.-0003.exr");
    const FramePattern single = parse_pattern("take#2/plate.exr");
    EXPECT_FALSE(single.is_sequence);  // a '#' in a directory is not a token
    EXPECT_EQ(single.path(5), "take#2/plate.exr");
    EXPECT_THROW(parse_pattern("a.#.#.exr"), std::invalid_argument);
    EXPECT_THROW(parse_pattern("a.%4d.exr"), std::invalid_argument);
}

TEST(Pattern, MatchesOnlyItsOwnPadding) {
    const FramePattern p = parse_pattern("d/s.####.exr");
    EXPECT_EQ(p.match("d/s.0012.exr"), 12);
    EXPECT_EQ(p.match("d/s.12345.exr"), 12345);
    EXPECT_EQ(p.match("d/s.-0002.exr"), -2);
    EXPECT_FALSE(p.match("d/s.012.exr"));
    EXPECT_FALSE(p.match("d/s.00012.exr"));
    EXPECT_FALSE(p.match("d/s.0012.tif"));
    EXPECT_FALSE(p.match("d/s.00a2.exr"));
    const FramePattern u = parse_pattern("s.@.exr");
    EXPECT_EQ(u.match("s.0.exr"), 0);
    EXPECT_EQ(u.match("s.120.exr"), 120);
    EXPECT_FALSE(u.match("s.07.exr"));
}

TEST(FrameList, RangesStepsAndLists) {
    EXPECT_EQ(parse_frame_list("1-5").listed(), (std::vector<std::int64_t>{1, 2, 3, 4, 5}));
    EXPECT_EQ(parse_frame_list("1-10x3").listed(), (std::vector<std::int64_t>{1, 4, 7, 10}));
    EXPECT_EQ(parse_frame_list("3,7,10-12").listed(), (std::vector<std::int64_t>{3, 7, 10, 11, 12}));
    EXPECT_EQ(parse_frame_list("-2-1").listed(), (std::vector<std::int64_t>{-2, -1, 0, 1}));
    EXPECT_EQ(parse_frame_list("42").listed(), (std::vector<std::int64_t>{42}));
    EXPECT_THROW(parse_frame_list("1-5x0"), std::invalid_argument);
    EXPECT_THROW(parse_frame_list("1,,2"), std::invalid_argument);
    EXPECT_THROW(parse_frame_list("1-3,2"), std::invalid_argument);
    EXPECT_THROW(parse_frame_list("a-3"), std::invalid_argument);
    EXPECT_THROW(parse_frame_list(""), std::invalid_argument);
}

// Issue 14, class 3: ranges are kept as runs and read lazily, at any 64-bit frame number, without
// overflow; duplicates between runs are found arithmetically.
TEST(FrameList, HugeRangesAreLazyAndExact) {
    constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max(), kMin = std::numeric_limits<std::int64_t>::min();
    const auto big = parse_frame_list("1-2147483647");
    EXPECT_EQ(big.size(), 2147483647u);
    EXPECT_EQ(big[2147483646], 2147483647);
    EXPECT_TRUE(big.contains(1000000));
    const auto top = parse_frame_list("9223372036854775800-9223372036854775807");
    EXPECT_EQ(top.size(), 8u);
    EXPECT_EQ(top[7], kMax);
    EXPECT_EQ(top.listed().size(), 8u);
    const auto stepped = parse_frame_list("9223372036854775800-9223372036854775807x5");  // ends on the run
    EXPECT_EQ(stepped.listed(), (std::vector<std::int64_t>{kMax - 7, kMax - 2}));
    const auto bottom = parse_frame_list("-9223372036854775808--9223372036854775807");
    EXPECT_EQ(bottom.listed(), (std::vector<std::int64_t>{kMin, kMin + 1}));
    EXPECT_EQ(parse_pattern("s.####.exr").path(kMin), "s.-9223372036854775808.exr");
    EXPECT_THROW(parse_frame_list("-9223372036854775808-9223372036854775807"), std::invalid_argument);  // 2^64 frames
    EXPECT_EQ(big.listed(10).size(), 10u);
    // Duplicates between runs with steps: 1-100x6 and 13-100x4 share 13; 2-100x6 and 3-100x4 share none.
    EXPECT_THROW(parse_frame_list("1-100x6,13-100x4"), std::invalid_argument);
    EXPECT_NO_THROW(parse_frame_list("2-100x6,3-100x4"));
    try {
        parse_frame_list("1-1000000000x7,500000000-2000000000x11");
        FAIL() << "duplicate not found";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("names frame 500000033 twice"), std::string::npos) << e.what();
    }
    EXPECT_NO_THROW(parse_frame_list("1-9223372036854775807x4,2-9223372036854775806x4"));  // 2^62 frames in all
}

// oiiotool's syntax: "y" takes the frames an "x" step skips; a range that ends before it starts counts down.
TEST(FrameList, ComplementStepsAndReverseRanges) {
    EXPECT_EQ(parse_frame_list("1-10y3").listed(), (std::vector<std::int64_t>{2, 3, 5, 6, 8, 9}));
    EXPECT_EQ(parse_frame_list("1-6y2").listed(), (std::vector<std::int64_t>{2, 4, 6}));
    EXPECT_EQ(parse_frame_list("5-1").listed(), (std::vector<std::int64_t>{5, 4, 3, 2, 1}));
    EXPECT_EQ(parse_frame_list("10-1x3").listed(), (std::vector<std::int64_t>{10, 7, 4, 1}));
    EXPECT_EQ(parse_frame_list("1-4y1").listed(), (std::vector<std::int64_t>{}));
    EXPECT_EQ(parse_frame_list("1-3,9-7").listed(), (std::vector<std::int64_t>{1, 2, 3, 9, 8, 7}));
    EXPECT_THROW(parse_frame_list("1-10y0"), std::invalid_argument);
    EXPECT_THROW(parse_frame_list("4y2"), std::invalid_argument);
}

// A frame list written in the pattern before its token ("pan.1-5#.exr") is taken out of the name.
TEST(Pattern, FramesWrittenInThePattern) {
    const FramePattern p = parse_pattern("d/pan.1-5#.exr");
    EXPECT_EQ(p.frames, "1-5");
    EXPECT_EQ(p.path(3), "d/pan.0003.exr");
    EXPECT_EQ(parse_pattern("pan.10-1x2@@.exr").frames, "10-1x2");
    EXPECT_EQ(parse_pattern("pan.1-10x2#.exr").path(7), "pan.0007.exr");
    EXPECT_EQ(parse_pattern("pan_3,7,9-11%04d.exr").frames, "3,7,9-11");
    EXPECT_EQ(parse_pattern("pan.1-5#.exr").prefix, "pan.");
    // Not frame lists: a version number or a plain digit before the token.
    EXPECT_EQ(parse_pattern("render_v2-10#.exr").frames, "");
    EXPECT_EQ(parse_pattern("render_v2-10#.exr").prefix, "render_v2-10");
    EXPECT_EQ(parse_pattern("take2#.exr").frames, "");
    EXPECT_EQ(parse_pattern("shot.#.exr").frames, "");
    EXPECT_EQ(parse_pattern("proxy1-5#.exr").frames, "");
}

TEST(FrameList, ScanFindsExistingFramesInOrder) {
    const fs::path dir = fs::temp_directory_path() / ("lensfx-scan-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    for (const char* name : {"s.0010.exr", "s.0002.exr", "s.0003.exr", "s.003.exr", "t.0001.exr", "s.0004.exr.tmp"})
        std::ofstream(dir / name) << "x";
    EXPECT_EQ(scan_frames(parse_pattern((dir / "s.####.exr").string())), (std::vector<std::int64_t>{2, 3, 10}));
    EXPECT_TRUE(scan_frames(parse_pattern((dir / "u.####.exr").string())).empty());
    fs::remove_all(dir);
}
