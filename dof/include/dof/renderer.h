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
    bool chromatic = true;   // each channel through its own wavelength's rays; false: green's for all
    int start_level = 2;     // hierarchy level a ray starts at
    int max_iterations = 2048;
    bool uniform_skip = true;  // pixels whose every reachable surface has one colour take it untraced
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

private:
    struct State;
    std::unique_ptr<State> state_;
    double last_ms_ = 0.0;
};

// The min-max pyramid the trace skips with: level L holds, per cell of 2^L x 2^L pixels (the raster padded
// to powers of two), (lowest, highest) inverse depth 1/back .. 1/front over every layer; empty cells
// (1e30, -1e30). Level 0 first.
std::vector<std::vector<float>> minmax_pyramid(const LayerStack& layers, int& padded_w, int& padded_h);
// Per cell of the same pyramid, the minimum ([0]) and maximum ([1]) RGBA of every layer (an empty pixel
// gives -1e30 .. 1e30, never uniform).
std::array<std::vector<std::vector<float>>, 2> colour_pyramid(const LayerStack& layers, int padded_w, int padded_h);

}  // namespace lensfx::dof
