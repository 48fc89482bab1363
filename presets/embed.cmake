# Writes a C++ source holding every presets/lenses/*.toml as a string, so that the presets load from any
# directory. Run at build time: cmake -DPRESET_DIR=... -DOUTPUT=... -P embed.cmake
file(GLOB files "${PRESET_DIR}/*.toml")
list(SORT files)
set(body "")
foreach(f ${files})
  get_filename_component(name "${f}" NAME_WE)
  file(READ "${f}" text)
  string(APPEND body "    {\"${name}\", R\"lensfx_preset(${text})lensfx_preset\"},\n")
endforeach()
list(LENGTH files count)
set(content "// Generated from presets/lenses/*.toml by presets/embed.cmake; do not edit.
#include <array>
#include <string_view>
#include <utility>

namespace lensfx::optics::detail {
extern const std::array<std::pair<std::string_view, std::string_view>, ${count}> kPresets;
const std::array<std::pair<std::string_view, std::string_view>, ${count}> kPresets{{
${body}}};
std::size_t preset_count() { return kPresets.size(); }
const std::pair<std::string_view, std::string_view>* preset_table() { return kPresets.data(); }
}  // namespace lensfx::optics::detail
")
file(WRITE "${OUTPUT}.tmp" "${content}")
file(COPY_FILE "${OUTPUT}.tmp" "${OUTPUT}" ONLY_IF_DIFFERENT)
