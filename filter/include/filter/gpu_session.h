// The one headless GL context of a filter run, shared by the flare renderer and the GPU colour transform:
// taken by the first stage that needs it (the flare stage at its first ghost render, or the colour output stage at
// the first frame when --gpu was given) on the pipeline's effect thread, where it stays current. The flare
// stage has it made ahead on a worker thread, so EGL's start-up overlaps reading the first frame.
#pragma once

#include <functional>
#include <future>
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
    // Starts making the context on a worker thread, where `ahead` then runs with it current (GL work a stage
    // wants done before its first frame: the flare stage makes and warms up its renderer; it catches its own
    // errors); get() takes it over (and throws what making it threw).
    void prepare(std::function<void(gpu::Context&)> ahead = {}) {
        if (context || pending.valid()) return;
        pending = std::async(std::launch::async, [p = gpu::parse_platform(platform), ahead = std::move(ahead)] {
            auto made = std::make_unique<gpu::Context>(p);
            if (ahead) ahead(*made);
            made->release();
            return made;
        });
    }
    // The context is still being made (prepare), perhaps with a stage's GL work.
    bool preparing() const { return pending.valid(); }
    // The context prepare() made was lost (its making, its release on the worker or its taking here failed):
    // whatever GL objects a stage made there ahead are gone with it, and are not to be used or deleted.
    bool lost_ahead() const { return ahead_lost; }
    gpu::Context& get() {
        if (!context && pending.valid()) {
            try {
                auto made = pending.get();
                made->make_current();  // kept only once current here: a failure leaves nothing half taken
                context = std::move(made);
            } catch (...) {
                ahead_lost = true;
                throw;
            }
        }
        if (!context) context = std::make_unique<gpu::Context>(gpu::parse_platform(platform));
        return *context;
    }

private:
    std::future<std::unique_ptr<gpu::Context>> pending;  // a context being made by prepare()
    bool ahead_lost = false;
};

}  // namespace lensfx::filter
