// Track files: the lights of a shot as JSON, written by `lensfx track` and read by the filter, editable
// by hand. The lights of frame f are a pure function of the file and f (see docs/detection.md).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <detect/source.h>

namespace lensfx::detect {

// One light's state at one frame; a track's keys are sorted by frame.
struct TrackKey {
    std::int64_t frame = 0;
    double x = 0.0, y = 0.0;
    std::array<double, 3> flux{};
    Extent extent;
    double weight = 1.0;
    bool clipped = false;
    std::optional<Shape> shape;  // in memory every key holds its shape (the file stores changes only)
    friend bool operator==(const TrackKey&, const TrackKey&) = default;
};

struct Track {
    int id = 0;
    std::string origin = "detected";  // "detected" or "manual"; informative
    double gain = 1.0;                // scales this track's flare (finite, >= 0); 1 = as detected
    bool exclude = false;             // the track gives no light (kept in the file, not rendered)
    std::vector<TrackKey> keys;
    friend bool operator==(const Track&, const Track&) = default;
};

// Bounds of what a track file may hold (pixels unless said): generous for any real shot, small enough
// that positions, sizes and products of fluxes and gains stay far inside float and int range.
inline constexpr double kMaxTrackCoordinate = 1e6;  // |x|, |y| (a light may sit well outside the frame)
inline constexpr double kMaxTrackFlux = 1e15;       // per channel: summed linear values
inline constexpr double kMaxTrackGain = 1e280;      // a track's gain: times the largest flux and the other gains still finite in double (1e305 overflowed to no light)
inline constexpr double kMaxTrackExtent = 1e5;      // major, minor axes
inline constexpr double kMaxShapeCell = 1e4;        // a footprint's cell size
inline constexpr int kMaxShapeSide = 4096;          // a footprint's cells per side
inline constexpr int kMaxFrameSide = 1 << 20;       // width, height

struct TrackFile {
    int width = 0;   // frame size the positions refer to
    int height = 0;
    std::vector<Track> tracks;  // by increasing id

    // Adds the lights of one frame (as returned by Tracker::update) as keys; frames must increase.
    void append(std::int64_t frame, const std::vector<Light>& lights);

    // The lights of frame f: every track whose keys span f, linearly interpolated between the two keys
    // around f (the shape is the one of the key at or before f), weight > 0 only, by increasing id;
    // excluded tracks give none, the others carry their gain.
    [[nodiscard]] std::vector<Light> lights_at(std::int64_t frame) const;

    // First and last frame with a key; {0, -1} when empty.
    [[nodiscard]] std::pair<std::int64_t, std::int64_t> frame_range() const;

    friend bool operator==(const TrackFile&, const TrackFile&) = default;
};

// JSON text <-> TrackFile. `name` (a path) is used in error messages. Errors throw std::runtime_error naming
// the file, the track id, key index and field at fault. Every field is checked on load: frames are whole
// 64-bit numbers, values finite and within the bounds below, so no later product overflows.
std::string to_json_text(const TrackFile& file);
TrackFile parse_track_json(std::string_view text, const std::string& name);

void write_track_file(const std::filesystem::path& path, const TrackFile& file);
TrackFile read_track_file(const std::filesystem::path& path);

}  // namespace lensfx::detect
