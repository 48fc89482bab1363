// File-name patterns and frame lists (see filter/sequence.h).
#include <filter/sequence.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <stdexcept>

#include <fmt/core.h>

namespace lensfx::filter {

namespace fs = std::filesystem;

namespace {

std::int64_t parse_int(std::string_view text, std::string_view whole) {
    std::int64_t value = 0;
    const auto* end = text.data() + text.size();
    auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (text.empty() || ec != std::errc{} || ptr != end) {
        throw std::invalid_argument(fmt::format("frame list \"{}\": \"{}\" is not a whole number", whole, text));
    }
    return value;
}

bool all_digits(std::string_view text) {
    return !text.empty() && std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// A frame list written just before the frame-number token ("pan.1-5#.exr", "pan.1-10x2#.exr"; oiiotool's
// syntax): digits, ',', 'x', 'y' and a '-' between numbers, holding a range or a list, after the start of
// the name or a '.', '_' or '-'. "" when there is none ("shot.#.exr", "take2#.exr").
std::string_view embedded_frames(std::string_view before_token) {
    std::size_t begin = before_token.size();
    while (begin > 0 && std::string_view("0123456789,xy-").find(before_token[begin - 1]) != std::string_view::npos) --begin;
    // Not a separator of the name in front: "v2-10#" is version 2, frame 10.
    while (begin < before_token.size() && (before_token[begin] < '0' || before_token[begin] > '9')) ++begin;
    const std::string_view list = before_token.substr(begin);
    if (list.find_first_of(",-") == std::string_view::npos) return {};
    if (begin > 0 && std::string_view("._-").find(before_token[begin - 1]) == std::string_view::npos) return {};
    if (!all_digits(list.substr(list.size() - 1))) return {};
    return list;
}

}  // namespace

std::string FramePattern::path(std::int64_t frame) const {
    if (!is_sequence) return prefix;
    const std::uint64_t magnitude = frame < 0 ? 0 - static_cast<std::uint64_t>(frame) : static_cast<std::uint64_t>(frame);
    const std::string digits = fmt::format("{:0{}}", magnitude, padding);
    return prefix + (frame < 0 ? "-" : "") + digits + suffix;
}

std::optional<std::int64_t> FramePattern::match(std::string_view p) const {
    if (!is_sequence || p.size() <= prefix.size() + suffix.size()) return std::nullopt;
    if (p.substr(0, prefix.size()) != prefix || p.substr(p.size() - suffix.size()) != suffix) return std::nullopt;
    std::string_view number = p.substr(prefix.size(), p.size() - prefix.size() - suffix.size());
    const bool negative = !number.empty() && number.front() == '-';
    if (negative) number.remove_prefix(1);
    if (!all_digits(number)) return std::nullopt;
    const auto width = static_cast<int>(number.size());
    // Exactly the pattern's padding, or longer without a leading zero (frame 10000 of "####").
    if (width < padding || (width > padding && number.front() == '0' && number.size() > 1)) return std::nullopt;
    std::int64_t value = 0;
    std::from_chars(number.data(), number.data() + number.size(), value);
    return negative ? -value : value;
}

FramePattern parse_pattern(std::string_view p) {
    FramePattern pattern;
    // The token is searched in the file name only, so a directory called "take#2" is not a token.
    const auto slash = p.find_last_of('/');
    const std::size_t name_start = slash == std::string_view::npos ? 0 : slash + 1;
    std::size_t token_begin = std::string_view::npos, token_end = 0;
    for (std::size_t i = name_start; i < p.size(); ++i) {
        std::size_t begin = i, end = i;
        int padding = 0;
        if (p[i] == '#' || p[i] == '@') {
            while (end < p.size() && p[end] == p[i]) ++end;
            const auto run = static_cast<int>(end - begin);
            padding = p[i] == '#' ? (run == 1 ? 4 : run) : run;
        } else if (p[i] == '%') {
            end = i + 1;
            std::size_t digits_begin = end;
            while (end < p.size() && p[end] >= '0' && p[end] <= '9') ++end;
            if (end >= p.size() || p[end] != 'd') continue;
            const std::string_view width = p.substr(digits_begin, end - digits_begin);
            if (width.empty()) {
                padding = 1;
            } else if (width.size() >= 2 && width.front() == '0') {
                padding = static_cast<int>(parse_int(width.substr(1), p));
            } else {
                throw std::invalid_argument(fmt::format("pattern \"{}\": use %d or %0Nd for frame numbers", p));
            }
            ++end;
        } else {
            continue;
        }
        if (token_begin != std::string_view::npos) {
            throw std::invalid_argument(fmt::format("pattern \"{}\" has more than one frame-number token", p));
        }
        token_begin = begin;
        token_end = end;
        pattern.padding = padding;
        i = end - 1;
    }
    if (token_begin == std::string_view::npos) {
        pattern.prefix = std::string(p);
        return pattern;
    }
    pattern.is_sequence = true;
    pattern.frames = std::string(embedded_frames(p.substr(name_start, token_begin - name_start)));
    token_begin -= pattern.frames.size();
    pattern.prefix = std::string(p.substr(0, token_begin));
    pattern.suffix = std::string(p.substr(token_end));
    return pattern;
}

namespace {

__extension__ typedef __int128 Wide;

// x, y with a*x + b*y = gcd(a, b), for a, b > 0.
Wide extended_gcd(Wide a, Wide b, Wide& x, Wide& y) {
    if (b == 0) {
        x = 1;
        y = 0;
        return a;
    }
    Wide x1 = 0, y1 = 0;
    const Wide g = extended_gcd(b, a % b, x1, y1);
    x = y1;
    y = x1 - (a / b) * y1;
    return g;
}

// The smallest frame on both runs, or nothing (the two progressions solved together, in 128 bits).
std::optional<std::int64_t> common_frame(const FrameRange& a, const FrameRange& b) {
    const Wide lo = std::max(a.first, b.first), hi = std::min(a.last, b.last);
    if (lo > hi) return std::nullopt;
    Wide p = 0, q = 0;
    const Wide g = extended_gcd(a.step, b.step, p, q);
    const Wide diff = Wide(b.first) - Wide(a.first);
    if (diff % g != 0) return std::nullopt;
    const Wide period = Wide(a.step) / g * b.step;
    const Wide mod = Wide(b.step) / g;
    Wide k = (diff / g % mod) * (p % mod) % mod;
    if (k < 0) k += mod;
    Wide x = Wide(a.first) + Wide(a.step) * k;  // on both runs
    if (x < lo) x += (lo - x + period - 1) / period * period;
    if (x > hi) return std::nullopt;
    return static_cast<std::int64_t>(x);
}

// Throws naming a frame that two runs share. Runs are swept by their first frame, each compared with
// the earlier ones it may overlap, so a long list of single frames costs n log n.
void refuse_duplicates(std::vector<FrameRange> runs, std::string_view list) {
    std::sort(runs.begin(), runs.end(), [](const FrameRange& a, const FrameRange& b) { return a.first < b.first; });
    std::vector<std::int64_t> reach(runs.size());  // the largest last frame of runs 0..k
    for (std::size_t i = 0; i < runs.size(); ++i) {
        reach[i] = i == 0 ? runs[i].last : std::max(reach[i - 1], runs[i].last);
        for (std::size_t j = i; j-- > 0 && reach[j] >= runs[i].first;) {
            if (const auto f = common_frame(runs[j], runs[i])) {
                throw std::invalid_argument(fmt::format("frame list \"{}\" names frame {} twice", list, *f));
            }
        }
    }
}

constexpr std::uint64_t kMaxFrames = std::uint64_t{1} << 62;

// Appends the run(s) of "FIRST-LAST" with an x (or, `complement`, y) step. A range that ends before it
// starts counts down. The frames a y step keeps are runs of consecutive frames between the skipped ones,
// at most 2^20 of them.
void add_range(std::vector<FrameRange>& runs, std::int64_t first, std::int64_t last, std::int64_t step, bool complement,
               std::string_view list) {
    const bool down = last < first;
    const std::int64_t lo = down ? last : first, hi = down ? first : last;
    const std::uint64_t span = static_cast<std::uint64_t>(hi) - static_cast<std::uint64_t>(lo);
    const auto ustep = static_cast<std::uint64_t>(step);
    if (!complement) {
        // The frames on the run, counted from the written start (the top one when counting down).
        const std::uint64_t on_run = span - span % ustep;
        if (down) runs.push_back({static_cast<std::int64_t>(static_cast<std::uint64_t>(hi) - on_run), hi, step, true});
        else runs.push_back({lo, static_cast<std::int64_t>(static_cast<std::uint64_t>(lo) + on_run), step, false});
        return;
    }
    if (step == 1) return;  // "y1" skips nothing of what x1 takes: no frames
    if (span / ustep >= (std::uint64_t{1} << 20))
        throw std::invalid_argument(fmt::format("frame list \"{}\": a y step over more than 2^20 runs", list));
    std::vector<FrameRange> kept;
    const std::int64_t start = down ? hi : lo;
    for (std::uint64_t k = 0; k * ustep < span; ++k) {
        // Between the skipped frames start +- k*step and start +- (k+1)*step.
        const std::uint64_t near = k * ustep + 1, far = std::min(k * ustep + ustep - 1, span);
        if (near > far) continue;
        if (down) kept.push_back({static_cast<std::int64_t>(static_cast<std::uint64_t>(start) - far),
                                  static_cast<std::int64_t>(static_cast<std::uint64_t>(start) - near), 1, true});
        else kept.push_back({static_cast<std::int64_t>(static_cast<std::uint64_t>(start) + near),
                             static_cast<std::int64_t>(static_cast<std::uint64_t>(start) + far), 1, false});
    }
    runs.insert(runs.end(), kept.begin(), kept.end());
}

}  // namespace

FrameList::FrameList(std::vector<FrameRange> ranges) : ranges_(std::move(ranges)) {
    std::uint64_t total = 0;
    for (const FrameRange& r : ranges_) {
        // The span in 64-bit unsigned arithmetic: last - first overflows a signed one for the widest runs.
        const std::uint64_t span = static_cast<std::uint64_t>(r.last) - static_cast<std::uint64_t>(r.first);
        if (r.step < 1 || r.last < r.first || span % static_cast<std::uint64_t>(r.step) != 0) throw std::invalid_argument("malformed frame range");
        // count() - 1 cannot overflow (count() itself does for the whole 64-bit range).
        const std::uint64_t after_first = span / static_cast<std::uint64_t>(r.step);
        if (after_first >= kMaxFrames - total) throw std::invalid_argument("a frame list of more than 2^62 frames");
        total += r.count();
        ends_.push_back(total);
    }
}

FrameList FrameList::of_numbers(const std::vector<std::int64_t>& sorted) {
    std::vector<FrameRange> runs;
    for (std::int64_t f : sorted) {
        if (!runs.empty() && runs.back().last != std::numeric_limits<std::int64_t>::max() && runs.back().last + 1 == f) {
            runs.back().last = f;
        } else {
            runs.push_back({f, f, 1});
        }
    }
    return FrameList(std::move(runs));
}

std::int64_t FrameList::operator[](std::uint64_t i) const {
    if (i >= size()) throw std::out_of_range(fmt::format("frame index {} of {}", i, size()));
    const auto k = static_cast<std::size_t>(std::upper_bound(ends_.begin(), ends_.end(), i) - ends_.begin());
    const std::uint64_t within = i - (k == 0 ? 0 : ends_[k - 1]);
    const FrameRange& r = ranges_[k];
    const std::uint64_t offset = within * static_cast<std::uint64_t>(r.step);
    return static_cast<std::int64_t>(r.descending ? static_cast<std::uint64_t>(r.last) - offset : static_cast<std::uint64_t>(r.first) + offset);
}

bool FrameList::contains(std::int64_t frame) const {
    return std::any_of(ranges_.begin(), ranges_.end(), [&](const FrameRange& r) {
        return frame >= r.first && frame <= r.last && (static_cast<std::uint64_t>(frame) - static_cast<std::uint64_t>(r.first)) % static_cast<std::uint64_t>(r.step) == 0;
    });
}

std::vector<std::int64_t> FrameList::listed(std::uint64_t limit) const {
    std::vector<std::int64_t> out;
    for (std::uint64_t i = 0; i < std::min(limit, size()); ++i) out.push_back((*this)[i]);
    return out;
}

FrameList parse_frame_list(std::string_view list) {
    std::vector<FrameRange> runs;
    std::size_t pos = 0;
    while (pos <= list.size()) {
        const std::size_t comma = std::min(list.find(',', pos), list.size());
        std::string_view item = list.substr(pos, comma - pos);
        if (item.empty()) throw std::invalid_argument(fmt::format("frame list \"{}\" has an empty item", list));
        std::int64_t step = 1;
        bool complement = false;  // "y": the frames an "x" step would skip (oiiotool's syntax)
        if (const auto x = item.find_first_of("xy"); x != std::string_view::npos) {
            complement = item[x] == 'y';
            step = parse_int(item.substr(x + 1), list);
            item = item.substr(0, x);
            if (step < 1) throw std::invalid_argument(fmt::format("frame list \"{}\": the step must be at least 1", list));
        }
        // A '-' after the first character separates a range ("1-10", "-5--1").
        const auto dash = item.find('-', 1);
        if (dash == std::string_view::npos) {
            if (step != 1) throw std::invalid_argument(fmt::format("frame list \"{}\": a step needs a range", list));
            const std::int64_t f = parse_int(item, list);
            runs.push_back({f, f, 1});
        } else {
            const std::int64_t first = parse_int(item.substr(0, dash), list);
            const std::int64_t last = parse_int(item.substr(dash + 1), list);
            // A range that ends before it starts counts down ("10-1", "10-1x2").
            add_range(runs, first, last, step, complement, list);
        }
        pos = comma + 1;
    }
    refuse_duplicates(runs, list);
    try {
        return FrameList(std::move(runs));
    } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(fmt::format("frame list \"{}\": {}", list, e.what()));
    }
}

std::vector<std::int64_t> scan_frames(const FramePattern& pattern) {
    std::vector<std::int64_t> frames;
    if (!pattern.is_sequence) return frames;
    const auto slash = pattern.prefix.find_last_of('/');
    const fs::path dir = slash == std::string::npos ? fs::path(".") : fs::path(pattern.prefix.substr(0, slash + 1));
    const std::string dir_prefix = slash == std::string::npos ? std::string() : pattern.prefix.substr(0, slash + 1);
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        if (const auto f = pattern.match(dir_prefix + it->path().filename().string())) frames.push_back(*f);
    }
    std::sort(frames.begin(), frames.end());
    return frames;
}

FrameList frames_to_read(const std::string& input, const std::string& frames, bool quiet) {
    const FramePattern pattern = parse_pattern(input);
    if (!pattern.is_sequence) {
        if (!frames.empty()) throw std::runtime_error(fmt::format("{}: --frames needs a pattern (#, @ or %0Nd) in the input", input));
        return FrameList({FrameRange{1, 1, 1}});
    }
    if (!frames.empty() && !pattern.frames.empty())
        throw std::runtime_error(fmt::format("{}: the pattern names frames {} and --frames names {}: give one", input, pattern.frames, frames));
    if (const std::string& list = frames.empty() ? pattern.frames : frames; !list.empty()) {
        FrameList listed = parse_frame_list(list);
        if (listed.empty()) throw std::runtime_error(fmt::format("{}: frame list \"{}\" names no frames", input, list));
        return listed;
    }
    const std::vector<std::int64_t> found = scan_frames(pattern);
    if (found.empty()) throw std::runtime_error(fmt::format("{}: no frames match the pattern", input));
    FrameList list = FrameList::of_numbers(found);
    if (!quiet) warn_of_gaps(input, frames, list);
    return list;
}

void warn_of_gaps(const std::string& input, const std::string& frames, const FrameList& list) {
    const FramePattern pattern = parse_pattern(input);
    if (!pattern.is_sequence || !frames.empty() || !pattern.frames.empty() || list.ranges().size() < 2) return;
    const FrameRange& a = list.ranges()[0];
    const FrameRange& b = list.ranges()[1];
    const std::string missing = a.last + 1 == b.first - 1 ? fmt::format("frame {} is", a.last + 1) : fmt::format("frames {}-{} are", a.last + 1, b.first - 1);
    fmt::print(stderr, "lensfx: warning: {}: {} missing; {} frames found in {} runs (use --frames to choose)\n", input, missing,
               list.size(), list.ranges().size());
}

}  // namespace lensfx::filter
