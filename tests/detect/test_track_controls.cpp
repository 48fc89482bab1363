// Per-track controls in track files: "gain" scales a track's lights, "exclude" leaves the track out; both
// survive a round trip, are written only when set, and bad values are refused naming file, track and field.
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include <detect/track_file.h>

using namespace lensfx::detect;

namespace {

// Two tracks over frames 1-10, each with two keys; the first track's controls are spliced in.
std::string two_tracks(const std::string& first_controls) {
    return R"({"width": 320, "height": 200, "tracks": [
 {"id": 1, )" + first_controls + R"("keys": [{"frame": 1, "position": [10, 20], "flux": [100, 100, 100]},
                                     {"frame": 10, "position": [30, 20], "flux": [300, 300, 300]}]},
 {"id": 2, "keys": [{"frame": 1, "position": [200, 100], "flux": [50, 50, 50]},
                    {"frame": 10, "position": [200, 100], "flux": [50, 50, 50]}]}
]})";
}

std::string error_of(const std::string& text) {
    try {
        (void)parse_track_json(text, "shot.json");
    } catch (const std::runtime_error& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(TrackControls, GainScalesATracksLightsAndDefaultsToOne) {
    const TrackFile file = parse_track_json(two_tracks(R"("gain": 0.25, )"), "shot.json");
    EXPECT_EQ(file.tracks[0].gain, 0.25);
    EXPECT_EQ(file.tracks[1].gain, 1.0);
    const auto lights = file.lights_at(4);
    ASSERT_EQ(lights.size(), 2u);
    EXPECT_EQ(lights[0].gain, 0.25);
    EXPECT_EQ(lights[1].gain, 1.0);
    EXPECT_DOUBLE_EQ(lights[0].flux[0], 100.0 + 200.0 * 3.0 / 9.0) << "the gain leaves the recorded flux alone";
}

TEST(TrackControls, ExcludedTrackGivesNoLight) {
    const TrackFile file = parse_track_json(two_tracks(R"("exclude": true, )"), "shot.json");
    EXPECT_TRUE(file.tracks[0].exclude);
    for (int f = 1; f <= 10; ++f) {
        const auto lights = file.lights_at(f);
        ASSERT_EQ(lights.size(), 1u) << "frame " << f;
        EXPECT_EQ(lights[0].id, 2);
    }
}

TEST(TrackControls, RoundTripKeepsThemAndWritesOnlyWhatIsSet) {
    TrackFile file = parse_track_json(two_tracks(R"("gain": 3.5, "exclude": true, )"), "shot.json");
    const std::string text = to_json_text(file);
    EXPECT_EQ(parse_track_json(text, "again.json"), file);
    EXPECT_NE(text.find(R"("gain": 3.5)"), std::string::npos) << text;
    file.tracks[0].gain = 1.0;
    file.tracks[0].exclude = false;
    const std::string plain = to_json_text(file);
    EXPECT_EQ(plain.find("gain"), std::string::npos) << plain;
    EXPECT_EQ(plain.find("exclude"), std::string::npos) << plain;
}

TEST(TrackControls, BadValuesNameTheFileTrackAndField) {
    for (const std::string bad : {R"("gain": -1, )", R"("gain": 1e305, )", R"("gain": null, )", R"("gain": "loud", )", R"("exclude": 1, )"}) {
        const std::string message = error_of(two_tracks(bad));
        EXPECT_NE(message.find("shot.json: track id 1"), std::string::npos) << bad << " -> " << message;
        const std::string field = bad.find("gain") != std::string::npos ? "\"gain\"" : "\"exclude\"";
        EXPECT_NE(message.find(field), std::string::npos) << bad << " -> " << message;
    }
    EXPECT_EQ(error_of(two_tracks(R"("gain": 0, )")), "") << "a gain of 0 is allowed (it silences the track)";
}
