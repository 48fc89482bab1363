// Track files: exact round trip, lights of a frame as a pure function of the file, hand-authored keys, errors.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <limits>

#include <gtest/gtest.h>

#include <detect/track_file.h>
#include <detect/tracker.h>

using namespace lensfx::detect;

namespace {

Detection frame_with(std::vector<Source> s) {
    Detection d;
    d.sources = std::move(s);
    d.stats.threshold = 20.0;
    d.stats.low_threshold = 10.0;
    d.stats.histogram.assign(33, 0.0f);
    d.stats.histogram[10] = 1.0f;
    return d;
}

Source src(double x, double y, double flux, bool with_shape) {
    Source s;
    s.x = x;
    s.y = y;
    s.flux = {flux, 0.7 * flux, 0.3 * flux};
    s.luminous_flux = 0.2126 * flux + 0.7152 * 0.7 * flux + 0.0722 * 0.3 * flux;
    s.peak = 100.0;
    s.extent = {3.0 + 0.01 * x, 2.0, std::fmod(170.0 + 0.5 * x, 180.0)};
    if (with_shape) s.shape = Shape{2, 2, 4.0, -4.0, -4.0, {0.1f, 0.2f, 0.3f, 0.4f}};
    return s;
}

// A shot recorded through the tracker: two lights, one with a shape, one dying half way.
TrackFile recorded_shot(std::vector<std::vector<Light>>* per_frame = nullptr) {
    Tracker tr;
    TrackFile file;
    file.width = 640;
    file.height = 480;
    for (int f = 1; f <= 40; ++f) {
        std::vector<Source> s{src(100.0 + 1.1 * f, 50.0 + 0.3 * f, 900.0 + f, true)};
        if (f < 20) s.push_back(src(400.0 - 0.7 * f, 300.0, 300.0, false));
        const auto lights = tr.update(frame_with(s));
        file.append(f, lights);
        if (per_frame) per_frame->push_back(lights);
    }
    return file;
}

}  // namespace

TEST(TrackFile, RoundTripIsExactAndLightsArePureFunctionsOfTheFrame) {
    std::vector<std::vector<Light>> live;
    const TrackFile file = recorded_shot(&live);
    const TrackFile back = parse_track_json(to_json_text(file), "mem.json");
    EXPECT_EQ(back, file);
    EXPECT_EQ(back.frame_range(), (std::pair<std::int64_t, std::int64_t>{1, 40}));
    for (int f = 1; f <= 40; ++f) EXPECT_EQ(back.lights_at(f), live[static_cast<std::size_t>(f - 1)]) << "frame " << f;
    // A farm chunk that reads only frames 25-30, in any order, sees the same lights.
    for (int f = 30; f >= 25; --f) EXPECT_EQ(parse_track_json(to_json_text(file), "chunk").lights_at(f), back.lights_at(f));
    EXPECT_TRUE(back.lights_at(0).empty());
    EXPECT_TRUE(back.lights_at(41).empty());
}

TEST(TrackFile, AnUnchangedShapeIsStoredOnce) {
    const std::string text = to_json_text(recorded_shot());
    std::size_t n = 0;
    for (auto p = text.find("\"weights\""); p != std::string::npos; p = text.find("\"weights\"", p + 1)) ++n;
    EXPECT_EQ(n, 1u);
}

TEST(TrackFile, FilesOnDisk) {
    const auto path = std::filesystem::temp_directory_path() / "lensfx_detect_test_tracks.json";
    const TrackFile file = recorded_shot();
    write_track_file(path, file);
    EXPECT_EQ(read_track_file(path), file);
    std::filesystem::remove(path);
    try {
        (void)read_track_file(path);
        ADD_FAILURE() << "read a missing file";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos);
    }
}

TEST(TrackFile, HandAuthoredKeysAreInterpolated) {
    const TrackFile file = parse_track_json(R"({
      "format": "lensfx-tracks", "version": 1, "width": 1920, "height": 1080,
      "tracks": [
        {"id": 7, "origin": "manual", "keys": [
          {"frame": 10, "position": [100, 200], "flux": [1000, 1000, 1000], "extent": [4, 2, 170], "weight": 0},
          {"frame": 20, "position": [300, 100], "flux": [3000, 2000, 1000], "extent": [8, 2, 10]},
          {"frame": 30, "position": [300, 100], "flux": [3000, 2000, 1000]}]},
        {"id": 3, "keys": [{"frame": 15, "position": [5, 5], "flux": [1, 2, 3]}]}
      ]})",
                                            "hand.json");
    ASSERT_EQ(file.tracks.size(), 2u);
    EXPECT_EQ(file.tracks[0].id, 3);  // sorted by id
    EXPECT_TRUE(file.lights_at(10).empty());  // weight 0 at the first key: fades in
    const auto mid = file.lights_at(15);
    ASSERT_EQ(mid.size(), 2u);
    EXPECT_EQ(mid[0].id, 3);
    const Light& l = mid[1];
    EXPECT_DOUBLE_EQ(l.x, 200.0);
    EXPECT_DOUBLE_EQ(l.y, 150.0);
    EXPECT_DOUBLE_EQ(l.flux[0], 2000.0);
    EXPECT_DOUBLE_EQ(l.weight, 0.5);
    EXPECT_DOUBLE_EQ(l.extent.major, 6.0);
    EXPECT_NEAR(l.extent.angle_deg, 0.0, 1e-9);  // 170 -> 10 the short way, through 180 = 0
    EXPECT_DOUBLE_EQ(file.lights_at(25)[0].x, 300.0);
    EXPECT_TRUE(file.lights_at(31).empty());
}

TEST(TrackFile, ErrorsNameTheFileTrackAndKey) {
    auto message = [](const std::string& text) {
        try {
            (void)parse_track_json(text, "shot.json");
        } catch (const std::runtime_error& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(message("{").find("shot.json: not valid JSON"), std::string::npos);
    EXPECT_NE(message(R"({"format": "other", "tracks": []})").find("format"), std::string::npos);
    EXPECT_NE(message(R"({"version": 9, "tracks": []})").find("version 9"), std::string::npos);
    const auto missing = message(R"({"tracks": [{"id": 4, "keys": [{"frame": 1, "flux": [1,1,1]}]}]})");
    EXPECT_NE(missing.find("track id 4 key 0"), std::string::npos) << missing;
    EXPECT_NE(missing.find("position"), std::string::npos) << missing;
    const auto order = message(R"({"tracks": [{"id": 4, "keys": [
        {"frame": 5, "position": [0,0], "flux": [1,1,1]}, {"frame": 5, "position": [0,0], "flux": [1,1,1]}]}]})");
    EXPECT_NE(order.find("key 1: frame 5 does not follow frame 5"), std::string::npos) << order;
    EXPECT_NE(message(R"({"tracks": [{"id": 1, "keys": [{"frame": 1, "position": [0,0], "flux": [1,1,1], "weight": 2}]}]})").find("weight"),
              std::string::npos);
    EXPECT_NE(message(R"({"tracks": [{"id": 1, "keys": [{"frame": 1, "position": [0,0], "flux": [-1,1,1]}]}]})").find("\"flux[0]\" -1 is outside"),
              std::string::npos);
    EXPECT_NE(message(R"({"tracks": [{"id": 1, "keys": [{"frame": 1, "position": [0,0], "flux": [1,1,1],
        "shape": {"size": [2, 2], "cell": 1, "origin": [0, 0], "weights": [1]}}]}]})").find("shape"),
              std::string::npos);
    EXPECT_NE(message(R"({"tracks": [{"id": 1, "keys": [{"frame": 1, "position": [0,0], "flux": [1,1,1]}]},
        {"id": 1, "keys": [{"frame": 1, "position": [0,0], "flux": [1,1,1]}]}]})").find("appears twice"),
              std::string::npos);
}

// Issue 14, class 1: every field is checked on load against bounds that keep later arithmetic in range,
// frames are whole 64-bit numbers (never truncated), and the errors name the file, track, key and field.
TEST(TrackFile, HostileFieldsAreRefusedByName) {
    auto message = [](const std::string& key) {
        try {
            (void)parse_track_json(R"({"width": 64, "height": 48, "tracks": [{"id": 9, "keys": [)" + key + "]}]}", "hostile.json");
        } catch (const std::runtime_error& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    const std::string ok = R"("position": [10, 10], "flux": [1, 1, 1])";
    const std::vector<std::pair<std::string, std::string>> cases = {
        {R"({"frame": 1, "position": [3e9, 10], "flux": [1, 1, 1]})", "hostile.json: track id 9 key 0: \"position[0]\" 3e+09 is outside"},
        {R"({"frame": 1, "position": [10, -1e300], "flux": [1, 1, 1]})", "\"position[1]\""},
        {R"({"frame": 1, "position": [10, 10], "flux": [1, 1e300, 1]})", "\"flux[1]\" 1e+300 is outside"},
        {R"({"frame": 1, "position": [10, 10], "flux": [1, 1, 1], "extent": [1e300, 1, 0]})", "\"extent[0]\""},
        {R"({"frame": 1.5, )" + ok + "}", "\"frame\" 1.5 is not a whole number"},
        {R"({"frame": 18446744073709551615, )" + ok + "}", "beyond 64-bit frame numbers"},
        {R"({"frame": "1", )" + ok + "}", "\"frame\" \"1\" is not a whole number"},
        {R"({"frame": 1, )" + ok + R"(, "shape": {"size": [1, 1], "cell": 1e30, "origin": [0, 0], "weights": [1]}})", "key 0 shape: \"cell\" 1e+30 is outside"},
        {R"({"frame": 1, )" + ok + R"(, "shape": {"size": [100000, 1], "cell": 1, "origin": [0, 0], "weights": [1]}})", "\"size[0]\" 100000 is outside"},
        {R"({"frame": 1, )" + ok + R"(, "shape": {"size": [1, 1], "cell": 1, "origin": [0, 0], "weights": [-1]}})", "\"weights\""},
    };
    for (const auto& [key, expected] : cases) {
        const std::string m = message(key);
        EXPECT_NE(m.find(expected), std::string::npos) << key << " gave: " << m;
    }
    EXPECT_NE(message("{" + ok + "}").find("missing \"frame\""), std::string::npos);
    try {
        (void)parse_track_json(R"({"width": 4294967297, "tracks": []})", "w.json");
        ADD_FAILURE() << "width beyond int accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("w.json: \"width\""), std::string::npos) << e.what();
    }
    // 2^32 + 1 stays itself: frame 1 has no light, frame 2^32 + 1 has it; keys beyond 2^62 round-trip.
    const TrackFile file = parse_track_json(R"({"tracks": [{"id": 1, "keys": [{"frame": 4294967297, )" + ok + R"(},
        {"frame": 9223372036854775807, )" + ok + "}]}]}", "big.json");
    EXPECT_TRUE(file.lights_at(1).empty());
    EXPECT_EQ(file.lights_at(4294967297).size(), 1u);
    EXPECT_EQ(file.lights_at(std::numeric_limits<std::int64_t>::max()).size(), 1u);
    EXPECT_EQ(file.frame_range(), (std::pair<std::int64_t, std::int64_t>{4294967297, std::numeric_limits<std::int64_t>::max()}));
    EXPECT_EQ(parse_track_json(to_json_text(file), "again.json"), file);
}

TEST(TrackFile, AppendRejectsFramesOutOfOrder) {
    TrackFile f;
    Light l;
    l.id = 1;
    f.append(5, {l});
    EXPECT_THROW(f.append(5, {l}), std::invalid_argument);
}
