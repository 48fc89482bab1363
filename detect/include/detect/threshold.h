// The brightness a pixel needs to belong to a light source: absolute ("20") or relative to the frame's
// median luminance in stops ("+6ev"), as given on the command line.
#pragma once

#include <string>
#include <string_view>

namespace lensfx::detect {

struct Threshold {
    enum class Kind { Absolute, RelativeEv };
    Kind kind = Kind::Absolute;
    double value = 20.0;  // luminance (Absolute) or stops above the median (RelativeEv)

    // "20", "2.5e3" -> absolute; "+6ev", "6EV", "-1.5ev" -> relative. Throws std::invalid_argument naming
    // the text when it is neither, or an absolute value is not a positive finite number.
    static Threshold parse(std::string_view text);

    // The luminance this threshold means in a frame with the given median; a relative threshold is never
    // below `floor` (so a black frame does not turn its noise into lights).
    [[nodiscard]] double resolve(double median_luminance, double floor) const;

    [[nodiscard]] std::string to_string() const;

    friend bool operator==(const Threshold&, const Threshold&) = default;
};

}  // namespace lensfx::detect
