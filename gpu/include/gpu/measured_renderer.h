// The GPU renderer of measured lenses (measured/model.h): one compute pass evaluates every ghost's Bezier
// shape and distance-based intensity per pixel, turned to the light's roll. Same image as
// measured::render_add (its CPU reference), in float.
#pragma once

#include <array>
#include <memory>

#include <gpu/context.h>
#include <measured/model.h>

namespace lensfx::gpu {

class MeasuredRenderer {
public:
    // Compiles the program; needs `context` current on this thread.
    explicit MeasuredRenderer(const Context& context);
    ~MeasuredRenderer();
    MeasuredRenderer(const MeasuredRenderer&) = delete;
    MeasuredRenderer& operator=(const MeasuredRenderer&) = delete;

    // Adds scale[c] x the lens's ghosts for the view's light into `rgb` (view.width x view.height x 3).
    void render_add(const measured::MeasuredLens& lens, const measured::MeasuredView& view, std::array<double, 3> scale, float* rgb);

private:
    struct State;
    std::unique_ptr<State> state_;
};

}  // namespace lensfx::gpu
