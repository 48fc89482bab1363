// The check every numeric option gets (see filter/option_checks.h: check_every_number).
#include <filter/option_checks.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <type_traits>

#include <CLI/CLI.hpp>

namespace lensfx::filter {

namespace {

// CLI11's name of an option's value type ("FLOAT", "INT", "UINT", "TEXT"), without its checks' descriptions.
std::string value_type(const CLI::Option& option) {
    const std::string type = option.get_type_name();
    return type.substr(0, type.find(':'));
}

// A real number written whole, finite and held by a double without underflow (1e-310 is a subnormal:
// a typo, and slow arithmetic).
std::string check_real(const std::string& text) {
    if (text.empty()) return "needs a number, not an empty value";
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end != text.c_str() + text.size() || std::isspace(static_cast<unsigned char>(text.front())))
        return "must be a number, not \"" + text + "\"";
    if (!std::isfinite(v) || (errno == ERANGE && std::fabs(v) > 1.0)) return "must be a finite number, not " + text;
    if (errno == ERANGE && v != 0.0) return "must be 0 or at least 1e-300 in size, not " + text;
    return {};
}

// A whole number in decimal digits ('-' first for a signed one) within 64 bits; rewritten without leading
// zeros, which CLI11's conversion (base 0) would read as octal.
template <typename Int>
std::string check_integer(std::string& text) {
    const bool negative = !text.empty() && text.front() == '-';
    const std::size_t digits = negative ? 1 : 0;
    const bool plain = text.size() > digits && text.find_first_not_of("0123456789", digits) == std::string::npos;
    if (!plain || (negative && std::is_unsigned_v<Int>))
        return std::string(std::is_unsigned_v<Int> ? "must be a whole number >= 0" : "must be a whole number") + ", not \"" + text + "\"";
    Int value = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec == std::errc::result_out_of_range) return "is too large: " + text;
    text = std::to_string(value);
    return {};
}

}  // namespace

void check_every_number(CLI::App& app) {
    // As transforms: they run before the option's own checks (a clearer message first) and may rewrite the text.
    for (CLI::Option* option : app.get_options()) {
        const std::string type = value_type(*option);
        if (type == "FLOAT") {
            option->transform(CLI::Validator([](std::string& text) { return check_real(text); }, ""));
        } else if (type == "INT") {
            option->transform(CLI::Validator([](std::string& text) { return check_integer<std::int64_t>(text); }, ""));
        } else if (type == "UINT") {
            option->transform(CLI::Validator([](std::string& text) { return check_integer<std::uint64_t>(text); }, ""));
        }
    }
    for (CLI::App* sub : app.get_subcommands({})) check_every_number(*sub);
}

}  // namespace lensfx::filter
