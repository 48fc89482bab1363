// The lens blur on the GPU (OpenGL 4.3 compute through the caller's EGL context, gpu/context.h): per pixel,
// lens rays from the ray table traced through the layers with a min-max depth hierarchy (the paper's
// min/max skipping as a Hi-Z pyramid) and the Stingray notes' fixes: the crossing offset applied on the
// axis whose cell plane was hit, so a cell is always left; floating cells with a thickness (a ray may pass
// behind a surface, and a miss at the finest level climbs one level only); rays skip to a cell's nearest
// surface before descending (the paper's clamping of a ray to a cell's depth range).
#pragma once
#include <array>
#include <memory>
#include <vector>

#include <dof/layers.h>
#include <dof/lens_rays.h>

namespace lensfx::dof {

struct TraceSettings {
    int rays = 32;           // lens rays per pixel and channel (taken from the table, per-pixel offset)
    // More rays where the blur is wide: up to max_rays (at most the table's samples; rays or less: rays
    // everywhere), as many as land ray_spacing_px apart over the widest blur disc near the pixel's tile.
    int max_rays = 0;
    double ray_spacing_px = 2.5;
    bool chromatic = true;   // each channel through its own wavelength's rays; false: green's for all
    int start_level = 2;     // hierarchy level a ray starts at
    int max_iterations = 2048;
    bool uniform_skip = true;  // pixels whose every reachable surface has one colour take it untraced
    // Chromatic blur only where it shows: between grid points of the table whose every band ray stays
    // within this many pixels of the achromatic band's ray of the same sample, over the scene's depth
    // range, the achromatic band's rays serve every band (0: only where they are equal).
    double chroma_tolerance_px = 0.1;
    // Rays of one band traced per dispatch (renderer.cpp, "Loop budget": llvmpipe's shared loop limit);
    // a chunk that still runs out at some pixels is traced again there one ray per dispatch.
    int rays_per_dispatch = 32;
    // Where the layers' pixel (0, 0) lies in the table's raster (the layers may be a crop of it).
    int origin_x = 0, origin_y = 0;
};

// Needs a current gpu::Context on the calling thread, for its whole life.
class Renderer {
public:
    Renderer();
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    // The blurred raster, RGB interleaved, rows top first (as the layers); with `alpha`, the blurred alpha
    // (one per pixel, gathered with green's rays as the reference does). Throws std::runtime_error when the
    // GL driver fails.
    std::vector<float> render(const LayerStack& layers, const RayTable& table, const TraceSettings& settings,
                              std::vector<float>* alpha = nullptr);
    double last_ms() const { return last_ms_; }  // upload + trace + read back of the last render
    // Pixel chunks of the last render that ran out of the driver's loop budget and were traced again.
    std::size_t last_retried() const { return last_retried_; }
    double last_rays() const { return last_rays_; }  // mean lens rays per pixel and band of the last render

private:
    struct State;
    std::unique_ptr<State> state_;
    double last_ms_ = 0.0;
    std::size_t last_retried_ = 0;
    double last_rays_ = 0.0;
};

// The min-max pyramid the trace skips with: level L holds, per cell of 2^L x 2^L pixels (the raster padded
// to powers of two), (lowest, highest) inverse depth 1/back .. 1/front over every layer; empty cells
// (1e30, -1e30). Level 0 first.
std::vector<std::vector<float>> minmax_pyramid(const LayerStack& layers, int& padded_w, int& padded_h);
// How far from where a pixel's first ray crosses focus_w any of its rays can meet a surface: the widest
// blur of the layers' depth range, plus twice the table's focus spread (the first ray's own offset, and
// the others').
double uniform_reach_px(const LayerStack& layers, const RayTable& table);
// Lens rays per pixel for each 8 x 8-pixel tile (the trace's work group; row-major, ceil(width / 8) by
// ceil(height / 8)): the widest blur disc of any surface within reach_px of the tile (the pyramid's depth
// range there), over the area of a disc of spacing_px, between min_rays and max_rays.
std::vector<float> tile_ray_counts(const std::vector<std::vector<float>>& pyramid, int padded_w, int padded_h, int width, int height,
                                   const RayTable& table, double reach_px, int min_rays, int max_rays, double spacing_px);
// Per cell between the table's grid points (grid_x - 1 by grid_y - 1), 1 where at all four corners every
// band's ray of every sample passes exactly where the achromatic band's does and stays within
// tolerance_px of it for inverse depths w_far .. w_near; else 0.
std::vector<float> achromatic_cells(const RayTable& table, double w_near, double w_far, double tolerance_px);

// Per cell of 2^level x 2^level pixels, the minimum ([0]) and maximum ([1]) RGBA of every layer (an empty
// pixel gives -1e30 .. 1e30, never uniform; cells past the raster's edge 1e30 .. -1e30): the one level of
// the pyramid the uniform-colour test reads.
std::array<std::vector<float>, 2> colour_level(const LayerStack& layers, int level);

}  // namespace lensfx::dof
