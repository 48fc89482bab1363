// `lensfx gpu`: opens the headless EGL context and prints the EGL and OpenGL vendor, renderer and version.
#include <memory>
#include <string>

#include <fmt/core.h>
#include <gpu/context.h>

#include "commands.h"

namespace lensfx::filter {

void register_gpu_command(CLI::App& app) {
    auto* cmd = app.add_subcommand("gpu", "Print the EGL platform and the OpenGL vendor, renderer and version");
    auto platform = std::make_shared<std::string>("auto");
    cmd->add_option("--gpu", *platform, "EGL platform: auto (a hardware device if any, else surfaceless), "
                                        "device or surfaceless")
        ->check(CLI::IsMember({"auto", "device", "surfaceless"}));
    cmd->callback([platform] {
        const gpu::Context context(gpu::parse_platform(*platform));
        const gpu::ContextInfo& info = context.info();
        fmt::print("EGL platform:  {}{}\n", gpu::platform_name(info.platform),
                   info.device.empty() ? "" : fmt::format(" ({})", info.device));
        fmt::print("EGL vendor:    {}\n", info.egl_vendor);
        fmt::print("EGL version:   {}\n", info.egl_version);
        fmt::print("GL vendor:     {}\n", info.gl_vendor);
        fmt::print("GL renderer:   {}{}\n", info.gl_renderer, info.software ? " (software)" : "");
        fmt::print("GL version:    {}\n", info.gl_version);
        fmt::print("GLSL version:  {}\n", info.glsl_version);
    });
}

}  // namespace lensfx::filter
