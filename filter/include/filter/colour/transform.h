// Colour transforms: OCIO's CPU processor over pixel spans, and the same transform as GLSL and as a
// compute shader on the run's GL context.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <filter/colour/config.h>
#include <filter/colour/pixel_span.h>

namespace lensfx::colour {

// One colour transform on the CPU (OCIO's optimised float processor), applied over rows on several threads.
// Non-finite input values are replaced before the transform (NaN and -Inf by 0, +Inf by the largest half
// float), so NaN/Inf never reach the output; display transforms also clamp the result to [0, 1].
class ColourTransform {
public:
    ColourTransform() = default;  // identity
    bool is_identity() const { return !processor_; }
    bool clamps() const { return clamp_; }
    void apply(PixelSpan pixels) const;
    void apply_rgb(float* rgb, std::size_t count) const;  // packed RGB triples, single thread
    const OCIO::ConstProcessorRcPtr& processor() const { return processor_; }  // null for identity
    std::string description() const;  // the OCIO transforms, for logs

    // `clamp`: clamp the result to [0, 1] (display transforms).
    ColourTransform(OCIO::ConstProcessorRcPtr processor, bool clamp);

private:
    OCIO::ConstProcessorRcPtr processor_;
    OCIO::ConstCPUProcessorRcPtr cpu_;
    bool clamp_ = false;
};

// The same transform as GLSL (4.x) for the GPU path, from OCIO's shader generator. `source` declares the
// LUT samplers and defines `vec4 <function>(vec4 rgba)`, which sanitises, applies the transform and clamps
// (display transforms) exactly as ColourTransform::apply does; alpha passes through. Each texture is to be
// uploaded as given (GL order, x fastest; R32F or RGB32F) and bound to the sampler uniform of its name.
struct GpuShader {
    struct Texture {
        std::string sampler;        // the sampler uniform in `source`
        int dimensions = 1;         // 1, 2 (a long 1D LUT folded into rows) or 3
        unsigned width = 0, height = 1, depth = 1;
        int channels = 3;           // 1 (red only) or 3
        bool linear = true;         // linear filtering, else nearest
        std::vector<float> values;  // width * height * depth * channels
    };
    std::string function;
    std::string source;
    std::vector<Texture> textures;
};
// Throws when the transform needs uniforms (dynamic properties), which this path does not feed.
GpuShader gpu_shader(const ColourTransform& transform, const std::string& function = "lensfx_colour");

// A transform compiled for the GPU: gpu_shader() in a compute shader on the current GL context (a
// gpu::Context made current on this thread, which must outlive this). apply() gives what
// ColourTransform::apply gives within 1e-4, NaN/Inf sanitised the same way; the identity does nothing.
class GpuColourTransform {
public:
    explicit GpuColourTransform(const ColourTransform& transform);
    ~GpuColourTransform();
    GpuColourTransform(GpuColourTransform&&) noexcept;
    GpuColourTransform& operator=(GpuColourTransform&&) noexcept;
    void apply(PixelSpan pixels);
    void apply_rgb(float* rgb, std::size_t count);  // packed RGB triples

private:
    struct State;
    std::unique_ptr<State> state_;
};

// Colour space to colour space (names or roles of the config).
ColourTransform make_transform(const ColourConfig& config, const std::string& src, const std::string& dst);

}  // namespace lensfx::colour
