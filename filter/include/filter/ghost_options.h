// The ghost renderer's switches as the command line states them (the accelerations of
// gpu/acceleration.h and the high-quality ringing), shared by `lensfx` and `lensfx flare`.
#pragma once

#include <string>


#include <gpu/acceleration.h>

namespace CLI {
class App;
}

namespace lensfx::filter {

struct AccelerationSettings {
    std::string bounding = "table";
    bool no_adaptive = false;
    bool no_lod = false;
    double ghost_threshold = gpu::Acceleration{}.ghost_threshold;
    int max_ghosts = 0;
    bool no_reduced = false;
    bool aperture_culling = false;
    std::string cache_dir;  // every disk cache's folder: empty = flare::default_cache_dir(), "none" = no disk cache

    gpu::Acceleration acceleration() const;
};

// Adds --bounding, --no-adaptive, --no-lod, --ghost-threshold, --max-ghosts, --no-reduced,
// --aperture-culling and --cache-dir to `app`, in `group`.
void add_acceleration_options(CLI::App& app, AccelerationSettings& settings, const std::string& group);

}  // namespace lensfx::filter
