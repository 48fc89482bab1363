// What a frame's pixels are, independent of the file library that read them: windows, channels and their
// types, and the metadata lensfx reads or adds. An EXR input also keeps its whole header, so an EXR output
// carries every attribute of its input (timecode, owner, custom ones) unchanged.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lensfx::filter {

enum class PixelType : std::uint8_t { uint8, uint16, uint32, half, float32 };

constexpr std::size_t pixel_type_bytes(PixelType t) {
    switch (t) {
    case PixelType::uint8: return 1;
    case PixelType::uint16:
    case PixelType::half: return 2;
    case PixelType::uint32:
    case PixelType::float32: return 4;
    }
    return 0;
}

constexpr std::string_view to_string(PixelType t) {
    switch (t) {
    case PixelType::uint8: return "uint8";
    case PixelType::uint16: return "uint16";
    case PixelType::uint32: return "uint32";
    case PixelType::half: return "half";
    case PixelType::float32: return "float";
    }
    return "?";
}

class ExrHeader;  // an EXR input's full header (filter/src/exr_io.h); opaque to everything else

struct ImageSpec {
    int x = 0, y = 0, width = 0, height = 0;                      // data window
    int full_x = 0, full_y = 0, full_width = 0, full_height = 0;  // display window
    std::vector<std::string> channelnames;
    std::vector<PixelType> channeltypes;  // one per channel

    // The input's EXR compression ("piz", "zip", "dwaa"...; empty when it was not an EXR).
    std::string compression;
    // CIE xy of the red, green, blue primaries and the white point, when the input names them.
    std::optional<std::array<float, 8>> chromaticities;
    float pixel_aspect = 1.0f;
    // Text attributes lensfx adds ("lensfx:colourTransformOn", "oiio:ColorSpace"), written where a format can.
    std::map<std::string, std::string> text;
    // Every other attribute of an EXR input, for EXR outputs; null for other inputs.
    std::shared_ptr<const ExrHeader> exr;
    // Every other attribute of an input read through OpenImageIO (its ParamValueList, opaque outside
    // liblensfx_oiio), for outputs written through it; null for EXR, PFM and raw inputs.
    std::shared_ptr<const void> oiio_attributes;

    ImageSpec() = default;
    // Data and display window at the origin; channels R, G, B, A, then channel4... of one type.
    ImageSpec(int w, int h, int channels, PixelType type) : width(w), height(h), full_width(w), full_height(h) {
        static constexpr const char* kNames[] = {"R", "G", "B", "A"};
        for (int c = 0; c < channels; ++c) {
            channelnames.push_back(c < 4 ? kNames[c] : "channel" + std::to_string(c));
            channeltypes.push_back(type);
        }
    }

    int nchannels() const { return static_cast<int>(channelnames.size()); }
    const std::string& channel_name(int c) const { return channelnames[static_cast<std::size_t>(c)]; }
    PixelType channel_type(int c) const { return channeltypes[static_cast<std::size_t>(c)]; }
    // The channel's index, or -1.
    int channel_index(std::string_view name) const {
        for (std::size_t c = 0; c < channelnames.size(); ++c)
            if (channelnames[c] == name) return static_cast<int>(c);
        return -1;
    }
    std::size_t pixel_bytes() const {
        std::size_t n = 0;
        for (PixelType t : channeltypes) n += pixel_type_bytes(t);
        return n;
    }
    std::size_t pixel_count() const { return static_cast<std::size_t>(width) * static_cast<std::size_t>(height); }
    std::size_t image_bytes() const { return pixel_count() * pixel_bytes(); }
    bool data_is_display() const {
        return x == full_x && y == full_y && width == full_width && height == full_height;
    }
};

}  // namespace lensfx::filter
