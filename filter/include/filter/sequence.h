// Frame sequences on disk: file-name patterns ("shot.####.exr", "shot.@.exr", "shot.%04d.exr"), frame
// lists ("1-100", "1-100x2", "3,7,10-20") and the scan of a directory for the frames that exist.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lensfx::filter {

// A path with at most one frame-number token. Tokens: a run of N '#' is N digits zero padded, except a
// lone '#' which is 4; a run of N '@' is N digits ('@' alone: unpadded); printf's %d and %0Nd.
struct FramePattern {
    std::string prefix;  // everything before the token (directory included)
    std::string suffix;  // everything after it
    int padding = 0;     // minimum number of digits; 0 when the path holds no token
    bool is_sequence = false;
    std::string frames;  // a frame list written before the token ("pan.1-5#.exr": "1-5"), else ""

    // The path of frame `frame` (the path itself when it holds no token). Negative frames keep their
    // sign in front of the padded digits, as "-0001".
    std::string path(std::int64_t frame) const;
    // The frame number of a file name in the pattern's directory (prefix and suffix matched exactly,
    // digits padded as the pattern says), or nothing.
    std::optional<std::int64_t> match(std::string_view path) const;
};

// Parses a path; throws std::invalid_argument on two tokens or a malformed %d. A frame list just before
// the token ("pan.1-5#.exr", as oiiotool writes it) goes to `frames`, out of the prefix.
FramePattern parse_pattern(std::string_view path);

// An arithmetic run of frames, first..last (inclusive) by step >= 1; both ends are on the run; listed
// from last down to first when `descending`. count() is for runs of a FrameList (at most 2^62 frames).
struct FrameRange {
    std::int64_t first = 0, last = 0, step = 1;
    bool descending = false;
    std::uint64_t count() const { return (static_cast<std::uint64_t>(last) - static_cast<std::uint64_t>(first)) / static_cast<std::uint64_t>(step) + 1; }
};

// Frame numbers kept as runs, read lazily: "1-2147483647" is three numbers, not two billion.
class FrameList {
public:
    FrameList() = default;
    // Runs in the order they are listed; at most 2^62 frames in all.
    explicit FrameList(std::vector<FrameRange> ranges);
    // Sorted numbers (a directory scan), kept as runs of consecutive frames.
    static FrameList of_numbers(const std::vector<std::int64_t>& sorted);

    std::uint64_t size() const { return ends_.empty() ? 0 : ends_.back(); }
    bool empty() const { return size() == 0; }
    // The i-th frame (i < size()), in O(log runs).
    std::int64_t operator[](std::uint64_t i) const;
    bool contains(std::int64_t frame) const;
    // At most `limit` frames from the start.
    std::vector<std::int64_t> listed(std::uint64_t limit = 1u << 20) const;
    const std::vector<FrameRange>& ranges() const { return ranges_; }

private:
    std::vector<FrameRange> ranges_;
    std::vector<std::uint64_t> ends_;  // frames up to and including run k
};

// Parses "1-100", "1-100x2", "3,7,10-20" (ranges inclusive), oiiotool's "1-10y3" (the frames "x3" skips)
// and reverse ranges "10-1", "10-1x2" (counting down). Frames keep the order written; duplicates are an
// error. Any 64-bit frame numbers; nothing is listed, so a range of any length costs the same.
FrameList parse_frame_list(std::string_view list);

// The frames of `pattern` that exist on disk, ascending. Empty when the directory has none.
std::vector<std::int64_t> scan_frames(const FramePattern& pattern);

// The frames to read of an input path: `frames` (--frames) of a pattern, else those on disk (a gap in
// them is warned about on stderr unless `quiet`), else frame 1 of a single file. Throws
// std::runtime_error naming the input when no frame matches or --frames is given without a pattern.
FrameList frames_to_read(const std::string& input, const std::string& frames, bool quiet);
// The warning frames_to_read gives for a gap in the frames found on disk (none when `frames` chose them), for a
// caller that reads them quietly and warns once the run's other checks have passed: a failure stays one line.
void warn_of_gaps(const std::string& input, const std::string& frames, const FrameList& list);

}  // namespace lensfx::filter
