// The dense CPU reference of the lens blur: many lens rays per pixel, each walked through every pixel cell
// it crosses (exact DDA, no hierarchy) and intersected with every layer there. For tests and the benchmark.
#pragma once
#include <vector>

#include <dof/layers.h>
#include <dof/lens_rays.h>

namespace lensfx::dof {

// Colour a lens ray gathers: c + a w from the nearest surface to the farthest, every crossed cell's layers
// composited front to back ("over"); what is left when it runs out is the farthest surface under its end.
// The inverse depths a ray is traced between: just before the nearest surface, the farthest back.
struct DepthSpan {
    float w_near = 0.0f, w_far = 0.0f;
};
DepthSpan depth_span(const LayerStack& layers);
float trace_exact(const LayerStack& layers, const DepthSpan& span, const ScreenRay& ray, int channel);

// The blurred raster (RGB interleaved): per pixel, band and channel the mean over the table's valid rays (all
// `table.samples`, or the first `rays` of them), the bands mixed into R, G, B by their weights, so an
// in-focus plane keeps its values (energy conserved). With `alpha`: the blurred alpha too (one per pixel,
// through the achromatic band's rays), gathered as the colour is.
std::vector<float> render_reference(const LayerStack& layers, const RayTable& table, int rays = 0, int threads = 0,
                                    std::vector<float>* alpha = nullptr);

}  // namespace lensfx::dof
