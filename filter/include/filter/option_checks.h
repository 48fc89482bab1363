// Validators shared by the commands' numeric options.
#pragma once

#include <cmath>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>

namespace lensfx::filter {

// Refuses NaN and infinities, which CLI11's range checks let through (every comparison with NaN is false).
inline CLI::Validator finite_number() {
    return CLI::Validator(
        [](std::string& text) -> std::string {
            try {
                std::size_t used = 0;
                const double v = std::stod(text, &used);
                if (std::isfinite(v)) return {};
            } catch (const std::out_of_range&) {  // beyond double: as infinite
            } catch (const std::exception&) {
                return {};  // not a number at all: the option's own conversion says so
            }
            return "must be a finite number, not " + text;
        },
        "FINITE");
}

// A finite number >= 0 (CLI::NonNegativeNumber lets "inf" through).
inline const CLI::Validator& finite_non_negative() {
    static const CLI::Validator check(
        [](std::string& text) -> std::string {
            double v = 0.0;
            if (!CLI::detail::lexical_cast(text, v) || !std::isfinite(v) || v < 0.0) return "must be a finite number >= 0, not " + text;
            return {};
        },
        "FINITE>=0");
    return check;
}

// A check that runs `parse` (which throws with a message starting with the option's name, maybe and a colon) on the option's
// text: a value it refuses is a usage error (exit 2, one line), named once, by CLI11.
template <class Parse>
CLI::Validator parsed_by(Parse parse, const std::string& option, const char* description) {
    return CLI::Validator(
        [parse, option](std::string& text) -> std::string {
            try {
                parse(text);
            } catch (const std::exception& e) {
                const std::string message = e.what();
                for (const std::string& prefix : {option + ": ", option + " "})
                    if (message.rfind(prefix, 0) == 0) return message.substr(prefix.size());
                return message;
            }
            return {};
        },
        description);
}

// The checks of --sensor (parse_sensor), --threshold (detect::Threshold::parse) and --zoom (a plain number
// in 0..1; a label such as 135mm is checked against the lens): a bad value is a usage error (exit 2).
// Defined in flare_settings.cpp.
CLI::Validator sensor_check();
CLI::Validator threshold_check();
CLI::Validator zoom_check();
// --bands: 0 (RGB) or flare::kMinBands..kMaxBands, as flare::spectral_passes takes them.
CLI::Validator bands_check();

// The largest --fstop: past any pinhole camera's (f/1e308 once ran and said every light lay outside the field).
inline constexpr double kMaxFNumber = 1000.0;

// Gives every option of `app` and of its subcommands, at any depth, whose value is a number (CLI11's FLOAT,
// INT, UINT) the check of what CLI11's own conversion lets through: an empty value (read as 0), NaN and
// infinities (its range checks pass NaN), subnormals, a value beyond 64 bits (strtoull saturates:
// 99999999999999999999), a negative unsigned one ("-1" wraps to the largest) and octal ("010" is 8).
// Each is a usage error naming the option. Called once the app is built (build_app).
void check_every_number(CLI::App& app);

}  // namespace lensfx::filter
