// Two numbers around a separator on the command line: "1920x1080" (sizes), "36x24" (mm), "8,5" (angles).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <type_traits>

namespace lensfx {

// The two numbers of "A<sep>B", each part read whole (std::stoi for int, std::stod for double: leading
// blanks allowed, nothing after the number); nullopt when the separator is missing or a part is not a number.
template <typename T>
std::optional<std::array<T, 2>> parse_pair_of(const std::string& text, char sep) {
    static_assert(std::is_same_v<T, int> || std::is_same_v<T, double>);
    const auto at = text.find(sep);
    if (at == std::string::npos) return std::nullopt;
    const auto read = [](const std::string& part, std::size_t& used) {
        if constexpr (std::is_same_v<T, int>) return std::stoi(part, &used);
        else return std::stod(part, &used);
    };
    try {
        std::size_t used_a = 0, used_b = 0;
        const T a = read(text.substr(0, at), used_a);
        const T b = read(text.substr(at + 1), used_b);
        if (used_a != at || used_b != text.size() - at - 1) return std::nullopt;
        return std::array<T, 2>{a, b};
    } catch (const std::exception&) {
        return std::nullopt;
    }
}

}  // namespace lensfx
