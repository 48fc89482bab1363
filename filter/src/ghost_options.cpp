#include <filter/ghost_options.h>

#include <CLI/CLI.hpp>

#include <filter/option_checks.h>

namespace lensfx::filter {

gpu::Acceleration AccelerationSettings::acceleration() const {
    gpu::Acceleration a;
    a.bounding = gpu::parse_bounding(bounding);
    a.adaptive = !no_adaptive;
    a.lod = !no_lod;
    a.ghost_threshold = ghost_threshold;
    a.max_ghosts = max_ghosts;
    a.reduced = !no_reduced;
    a.aperture_culling = aperture_culling;
    a.cache_dir = cache_dir;
    return a;
}

void add_acceleration_options(CLI::App& app, AccelerationSettings& s, const std::string& group) {
    app.add_option("--bounding", s.bounding,
                   "Each ghost's pupil rectangle from the cached per-lens table, a coarse pass per frame, or none")
        ->check(CLI::IsMember({"table", "coarse", "none"}))->capture_default_str()->group(group);
    app.add_flag("--no-adaptive", s.no_adaptive, "The base grid for every ghost, whatever its distortion")->group(group);
    app.add_flag("--no-lod", s.no_lod, "Draw every ghost at the full grid, however dim")->group(group);
    app.add_option("--ghost-threshold", s.ghost_threshold, "Skip ghosts below this fraction of the estimated total power")
        ->capture_default_str()->check(CLI::Range(0.0, 1.0))->check(finite_number())->group(group);
    app.add_option("--max-ghosts", s.max_ghosts, "Draw only the N brightest ghosts (0 = all)")
        ->capture_default_str()->check(CLI::NonNegativeNumber)->group(group);
    app.add_flag("--no-reduced", s.no_reduced, "Draw every ghost at full resolution")->group(group);
    app.add_flag("--aperture-culling", s.aperture_culling,
                 "Leave out the ghosts that cross the stop three times (for small iris openings)")->group(group);
    app.add_option("--cache-dir", s.cache_dir,
                   "Folder of every disk cache: ghost bounds, ghost imaging, direct-power tables, starburst textures, lens-blur ray tables (default $LENSFX_CACHE_DIR, $XDG_CACHE_HOME/lensfx or ~/.cache/lensfx; none = memory only)")
        ->group(group);
}

}  // namespace lensfx::filter
