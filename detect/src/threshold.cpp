// Parsing and resolving detection thresholds.
#include <detect/threshold.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <fmt/core.h>

namespace lensfx::detect {

namespace {

constexpr double kMaxStops = 64.0;  // a relative threshold's reach from the median

std::string lower(std::string_view s) {
    std::string out(s);
    std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return out;
}

double parse_number(std::string_view text, std::string_view whole) {
    if (!text.empty() && text.front() == '+') text.remove_prefix(1);
    double v = 0.0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(v))
        throw std::invalid_argument(fmt::format("threshold '{}': expected a luminance (20) or stops above the median (+6ev)", whole));
    return v;
}

}  // namespace

Threshold Threshold::parse(std::string_view text) {
    std::string s = lower(text);
    s.erase(std::remove_if(s.begin(), s.end(), [](unsigned char c) { return std::isspace(c) != 0; }), s.end());
    Threshold t;
    if (s.size() > 2 && s.ends_with("ev")) {
        t.kind = Kind::RelativeEv;
        t.value = parse_number(std::string_view(s).substr(0, s.size() - 2), text);
        if (std::abs(t.value) > kMaxStops)  // as --exposure: beyond, every pixel or none
            throw std::invalid_argument(fmt::format("threshold '{}': more than {} stops from the median", text, kMaxStops));
    } else {
        t.kind = Kind::Absolute;
        t.value = parse_number(s, text);
        if (!(t.value > 0.0))
            throw std::invalid_argument(fmt::format("threshold '{}': an absolute threshold must be positive", text));
        // A pixel's luminance is a float: below its smallest normal value every lit pixel is a light, above
        // its largest none ever is.
        constexpr auto lowest = static_cast<double>(std::numeric_limits<float>::min());
        constexpr auto highest = static_cast<double>(std::numeric_limits<float>::max());
        if (t.value < lowest || t.value > highest)
            throw std::invalid_argument(fmt::format("threshold '{}': outside the luminances a float pixel holds ({:g} to {:g})", text, lowest, highest));
    }
    return t;
}

double Threshold::resolve(double median_luminance, double floor) const {
    if (kind == Kind::Absolute) return value;
    return std::max(median_luminance * std::exp2(value), floor);
}

std::string Threshold::to_string() const {
    if (kind == Kind::Absolute) return fmt::format("{}", value);
    return fmt::format("{:+}ev", value);
}

}  // namespace lensfx::detect
