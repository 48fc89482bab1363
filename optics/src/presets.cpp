// Lookup of the embedded lens presets (the table is generated from presets/lenses/*.toml at build time).
#include <optics/presets.h>

#include <algorithm>

#include <fmt/core.h>

#include <optics/lens_file.h>

namespace lensfx::optics {
namespace detail {
std::size_t preset_count();
const std::pair<std::string_view, std::string_view>* preset_table();
}  // namespace detail

std::vector<std::string> preset_names() {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < detail::preset_count(); ++i) out.emplace_back(detail::preset_table()[i].first);
    std::sort(out.begin(), out.end());
    return out;
}

std::optional<std::string_view> preset_text(std::string_view name) {
    for (std::size_t i = 0; i < detail::preset_count(); ++i)
        if (detail::preset_table()[i].first == name) return detail::preset_table()[i].second;
    return std::nullopt;
}

Lens load_preset(std::string_view name) {
    const auto text = preset_text(name);
    if (!text) throw LensFileError(fmt::format("no lens preset named '{}'", name));
    return parse_lens_toml(*text, fmt::format("preset:{} (presets/lenses/{}.toml)", name, name));
}

}  // namespace lensfx::optics
