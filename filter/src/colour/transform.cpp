// Colour transforms on the CPU (OCIO's processor over rows, on threads) and as GLSL (filter/colour/transform.h).
#include <filter/colour/transform.h>

#include <algorithm>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <fmt/core.h>

#include "pixel_ops.h"

namespace lensfx::colour {

ColourTransform::ColourTransform(OCIO::ConstProcessorRcPtr processor, bool clamp)
    : processor_(std::move(processor)), clamp_(clamp) {
    if (processor_) {
        cpu_ = processor_->getOptimizedCPUProcessor(OCIO::BIT_DEPTH_F32, OCIO::BIT_DEPTH_F32,
                                                    OCIO::OPTIMIZATION_DEFAULT);
        if (cpu_->isNoOp() && !clamp_) {
            processor_.reset();
            cpu_.reset();
        }
    }
}

ColourTransform make_transform(const ColourConfig& config, const std::string& src, const std::string& dst) {
    config.check_colour_space(src);
    config.check_colour_space(dst);
    try {
        return ColourTransform(config.ocio()->getProcessor(src.c_str(), dst.c_str()), false);
    } catch (const OCIO::Exception& e) {
        throw std::runtime_error(fmt::format("OCIO config {}: no transform from '{}' to '{}': {}", config.source(),
                                             src, dst, e.what()));
    }
}

void ColourTransform::apply(PixelSpan px) const {
    if (!cpu_ || px.width == 0 || px.height == 0) return;
    if (px.channels < 3 || px.data == nullptr)
        throw std::invalid_argument(fmt::format("colour transform: need at least 3 channels, got {}", px.channels));
    const std::size_t nc = static_cast<std::size_t>(px.channels);
    const std::size_t stride = px.row_stride ? px.row_stride : px.width * nc;
    auto run_rows = [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y) {
            float* row = px.data + y * stride;
            for (std::size_t x = 0; x < px.width; ++x)
                for (std::size_t c = 0; c < 3; ++c) row[x * nc + c] = sanitise(row[x * nc + c]);
        }
        float* first = px.data + y0 * stride;
        const auto w = static_cast<long>(px.width), h = static_cast<long>(y1 - y0);
        const auto xs = static_cast<std::ptrdiff_t>(nc * sizeof(float));
        const auto ys = static_cast<std::ptrdiff_t>(stride * sizeof(float));
        // RGB ordering with the pixel stride, also for RGBA: OCIO's RGBA path rescales alpha in some ops, and
        // alpha and further channels must come back bit for bit.
        OCIO::PackedImageDesc desc(first, w, h, OCIO::CHANNEL_ORDERING_RGB, OCIO::BIT_DEPTH_F32, sizeof(float), xs, ys);
        cpu_->apply(desc);
        for (std::size_t y = y0; y < y1; ++y) {
            float* row = px.data + y * stride;
            for (std::size_t x = 0; x < px.width; ++x)
                for (std::size_t c = 0; c < 3; ++c) {
                    float& v = row[x * nc + c];
                    v = clamp_ ? clamp01(v) : sanitise(v);
                }
        }
    };
    // Threads only where the frame is large enough to pay for them (about 64k pixels per thread).
    const std::size_t hw = std::max(1u, std::thread::hardware_concurrency());
    const std::size_t threads = std::clamp<std::size_t>(px.width * px.height / 65536, 1, hw);
    if (threads == 1) {
        run_rows(0, px.height);
        return;
    }
    std::vector<std::jthread> pool;
    const std::size_t chunk = (px.height + threads - 1) / threads;
    for (std::size_t y = 0; y < px.height; y += chunk)
        pool.emplace_back(run_rows, y, std::min(px.height, y + chunk));
}

void ColourTransform::apply_rgb(float* rgb, std::size_t count) const {
    apply(PixelSpan{rgb, count, 1, 3, 0});
}

std::string ColourTransform::description() const {
    if (!processor_) return "identity";
    std::ostringstream os;
    os << *processor_->createGroupTransform();
    return os.str();
}

GpuShader gpu_shader(const ColourTransform& transform, const std::string& function) {
    GpuShader out;
    out.function = function;
    const std::string ocio_function = function + "_ocio";
    const std::string body = "    return " + ocio_function + "(c);\n";
    if (transform.processor()) {
        auto desc = OCIO::GpuShaderDesc::CreateShaderDesc();
        desc->setLanguage(OCIO::GPU_LANGUAGE_GLSL_4_0);
        desc->setFunctionName(ocio_function.c_str());
        desc->setResourcePrefix((function + "_").c_str());
        transform.processor()->getDefaultGPUProcessor()->extractGpuShaderInfo(desc);
        if (desc->getNumUniforms() > 0)
            throw std::runtime_error(fmt::format("colour: the GPU path does not feed uniforms, and this transform "
                                                 "needs {} (dynamic properties)", desc->getNumUniforms()));
        for (unsigned i = 0; i < desc->getNumTextures(); ++i) {
            const char *texture = nullptr, *sampler = nullptr;
            unsigned w = 0, h = 0;
            OCIO::GpuShaderDesc::TextureType type{};
            OCIO::Interpolation interp{};
            desc->getTexture(i, texture, sampler, w, h, type, interp);
            const float* values = nullptr;
            desc->getTextureValues(i, values);
            GpuShader::Texture t;
            t.sampler = sampler;
            t.dimensions = h > 1 ? 2 : 1;
            t.width = w;
            t.height = h;
            t.channels = type == OCIO::GpuShaderDesc::TEXTURE_RED_CHANNEL ? 1 : 3;
            t.linear = interp != OCIO::INTERP_NEAREST;
            t.values.assign(values, values + std::size_t{w} * h * static_cast<std::size_t>(t.channels));
            out.textures.push_back(std::move(t));
        }
        for (unsigned i = 0; i < desc->getNum3DTextures(); ++i) {
            const char *texture = nullptr, *sampler = nullptr;
            unsigned edge = 0;
            OCIO::Interpolation interp{};
            desc->get3DTexture(i, texture, sampler, edge, interp);
            const float* values = nullptr;
            desc->get3DTextureValues(i, values);
            GpuShader::Texture t;
            t.sampler = sampler;
            t.dimensions = 3;
            t.width = t.height = t.depth = edge;
            t.channels = 3;
            t.linear = interp != OCIO::INTERP_NEAREST;
            t.values.assign(values, values + std::size_t{edge} * edge * edge * 3);
            out.textures.push_back(std::move(t));
        }
        out.source = desc->getShaderText();
    } else {
        out.source = fmt::format("vec4 {}(vec4 c) {{ return c; }}\n", function);  // identity: untouched, as on the CPU
        return out;
    }
    const std::string end = transform.clamps() ? "clamp01" : "sanitise";
    out.source += fmt::format(R"(
float {0}_sanitise(float v) {{ return isnan(v) ? 0.0 : (isinf(v) ? (v > 0.0 ? {1:.1f} : 0.0) : v); }}
float {0}_clamp01(float v) {{ return v > 0.0 ? min(v, 1.0) : 0.0; }}
vec4 {0}_core(vec4 c) {{
{2}}}
vec4 {0}(vec4 c) {{
    c.rgb = vec3({0}_sanitise(c.r), {0}_sanitise(c.g), {0}_sanitise(c.b));
    vec4 o = {0}_core(c);
    return vec4({0}_{3}(o.r), {0}_{3}(o.g), {0}_{3}(o.b), c.a);
}}
)",
                              function, static_cast<double>(inf_replacement), body, end);
    return out;
}

}  // namespace lensfx::colour
