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

// Parses "1-100", "1-100x2", "3,7,10-20" (ranges inclusive), oiiotool's "1-10y3" (the frames "x3" skips)
// and reverse ranges "10-1", "10-1x2" (counting down). Frames keep the order written; duplicates are an error.
std::vector<std::int64_t> parse_frame_list(std::string_view list);

// The frames of `pattern` that exist on disk, ascending. Empty when the directory has none.
std::vector<std::int64_t> scan_frames(const FramePattern& pattern);

}  // namespace lensfx::filter
