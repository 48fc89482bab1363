// The one headless GL context of a filter run, shared by the flare renderer and the GPU colour transform:
// made by the first stage that needs it (the flare stage at its first light, or the colour output stage at
// the first frame when --gpu was given), on the pipeline's effect thread, where it stays current.
#pragma once

#include <memory>
#include <string>

#include <gpu/context.h>

namespace lensfx::filter {

struct GpuSession {
    std::string platform = "auto";  // --gpu: auto, device, surfaceless
    bool requested = false;         // --gpu was given: the colour transforms run on the GPU from the start
    std::unique_ptr<gpu::Context> context;

    // The GPU path is active: a context exists (or is to be made because the user asked for it).
    bool active() const { return context != nullptr || requested; }
    gpu::Context& get() {
        if (!context) context = std::make_unique<gpu::Context>(gpu::parse_platform(platform));
        return *context;
    }
};

}  // namespace lensfx::filter
