// File-name patterns and frame lists (see filter/sequence.h).
#include <filter/sequence.h>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <set>
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
    const std::string digits = fmt::format("{:0{}}", frame < 0 ? -frame : frame, padding);
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

std::vector<std::int64_t> parse_frame_list(std::string_view list) {
    std::vector<std::int64_t> frames;
    std::set<std::int64_t> seen;
    auto add = [&](std::int64_t f) {
        if (!seen.insert(f).second) throw std::invalid_argument(fmt::format("frame list \"{}\" names frame {} twice", list, f));
        frames.push_back(f);
    };
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
            add(parse_int(item, list));
        } else {
            const std::int64_t first = parse_int(item.substr(0, dash), list);
            const std::int64_t last = parse_int(item.substr(dash + 1), list);
            // A range that ends before it starts counts down ("10-1", "10-1x2").
            const std::int64_t direction = last < first ? -1 : 1;
            for (std::int64_t f = first, k = 0; direction > 0 ? f <= last : f >= last; f += direction, ++k)
                if ((k % step == 0) != complement) add(f);
        }
        pos = comma + 1;
    }
    return frames;
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

}  // namespace lensfx::filter
