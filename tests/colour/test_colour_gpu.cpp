// The GPU path of the colour transforms (OCIO's GLSL, run here in a compute shader on the project's EGL
// context) against the CPU path: every display/view of the built-in config within 1e-4, NaN/Inf included.
#include <filter/colour.h>
#include <gpu/context.h>
#include <gpu/gl.h>

#include <epoxy/gl.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>

namespace {

using namespace lensfx::colour;
namespace gpu = lensfx::gpu;

std::unique_ptr<gpu::Context> make_context(std::string& why) {
    try {
        return std::make_unique<gpu::Context>();
    } catch (const std::exception& e) {
        why = e.what();
        return nullptr;
    }
}

// Runs `shader` over packed RGB pixels in a compute shader.
std::vector<float> run_on_gpu(const GpuShader& shader, const std::vector<float>& rgb) {
    const std::string source = "#version 430\n" + shader.source + R"(
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer Pixels { float px[]; };
uniform uint count;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    vec4 c = )" + shader.function + R"((vec4(px[3u * i], px[3u * i + 1u], px[3u * i + 2u], 1.0));
    px[3u * i] = c.r;
    px[3u * i + 1u] = c.g;
    px[3u * i + 2u] = c.b;
}
)";
    gpu::Program program("colour-test.comp", {{gpu::ShaderStage::Type::Compute, source}});
    glUseProgram(program.get());
    std::vector<gpu::GlObject> textures;
    for (std::size_t k = 0; k < shader.textures.size(); ++k) {
        const auto& t = shader.textures[k];
        textures.push_back(gpu::GlObject::texture());
        const GLenum target = t.dimensions == 3 ? GL_TEXTURE_3D : t.dimensions == 2 ? GL_TEXTURE_2D : GL_TEXTURE_1D;
        glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(k));
        glBindTexture(target, textures.back().get());
        const GLint internal = t.channels == 1 ? GL_R32F : GL_RGB32F;
        const GLenum format = t.channels == 1 ? GL_RED : GL_RGB;
        const auto w = static_cast<GLsizei>(t.width), h = static_cast<GLsizei>(t.height), d = static_cast<GLsizei>(t.depth);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
        if (t.dimensions == 3)
            glTexImage3D(target, 0, internal, w, h, d, 0, format, GL_FLOAT, t.values.data());
        else if (t.dimensions == 2)
            glTexImage2D(target, 0, internal, w, h, 0, format, GL_FLOAT, t.values.data());
        else
            glTexImage1D(target, 0, internal, w, 0, format, GL_FLOAT, t.values.data());
        const GLint filter = t.linear ? GL_LINEAR : GL_NEAREST;
        glTexParameteri(target, GL_TEXTURE_MIN_FILTER, filter);
        glTexParameteri(target, GL_TEXTURE_MAG_FILTER, filter);
        for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
            glTexParameteri(target, wrap, GL_CLAMP_TO_EDGE);
        glUniform1i(program.uniform(t.sampler.c_str()), static_cast<GLint>(k));
    }
    const auto count = static_cast<GLuint>(rgb.size() / 3);
    glUniform1ui(program.uniform("count"), count);
    auto buffer = gpu::GlObject::buffer();
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, buffer.get());
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(rgb.size() * sizeof(float)), rgb.data(), GL_DYNAMIC_COPY);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, buffer.get());
    glDispatchCompute((count + 63) / 64, 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    std::vector<float> out(rgb.size());
    glGetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(out.size() * sizeof(float)), out.data());
    gpu::check_gl("colour test dispatch");
    return out;
}

std::vector<float> test_pixels() {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> stops(-10.0f, 12.0f), mix(-0.05f, 1.0f);
    std::vector<float> v;
    for (int i = 0; i < 4000; ++i) {
        const float level = 0.18f * std::exp2(stops(rng));
        for (int c = 0; c < 3; ++c) v.push_back(level * mix(rng));
    }
    const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
    for (float x : {0.0f, 0.18f, 1.0f, 1e4f, nan, inf, -inf, -0.5f}) v.insert(v.end(), {x, x, x});
    v.insert(v.end(), {nan, inf, -inf, 0.18f, nan, 2.0f});
    return v;
}

TEST(ColourGpu, EveryDisplayViewMatchesTheCpuPath) {
    std::string why;
    auto context = make_context(why);
    if (!context) GTEST_SKIP() << "no EGL/OpenGL 4.3 context: " << why;
    const auto cfg = ColourConfig::builtin_config();
    const auto pixels = test_pixels();
    for (const auto& d : cfg.displays())
        for (const auto& v : cfg.views(d)) {
            ColourOptions o;
            o.display = d;
            o.view = v;
            o.exposure_ev = 0.5;
            ColourPipeline p(cfg, o, std::nullopt);
            auto cpu = pixels;
            p.to_display().apply_rgb(cpu.data(), cpu.size() / 3);
            const auto shader = gpu_shader(p.to_display());
            const auto gpu_out = run_on_gpu(shader, pixels);
            float worst = 0.0f;
            for (std::size_t i = 0; i < cpu.size(); ++i) {
                ASSERT_TRUE(std::isfinite(gpu_out[i])) << d << " / " << v << " value " << i;
                worst = std::max(worst, std::abs(cpu[i] - gpu_out[i]));
            }
            EXPECT_LT(worst, 1e-4f) << d << " / " << v << " (" << shader.textures.size() << " LUT textures)";
        }
}

TEST(ColourGpu, SceneConversionMatchesTheCpuPath) {
    std::string why;
    auto context = make_context(why);
    if (!context) GTEST_SKIP() << "no EGL/OpenGL 4.3 context: " << why;
    const auto cfg = ColourConfig::builtin_config();
    const auto t = make_transform(cfg, "Linear Rec.709 (sRGB)", "ACEScg");
    const auto pixels = test_pixels();
    auto cpu = pixels;
    t.apply_rgb(cpu.data(), cpu.size() / 3);
    const auto gpu_out = run_on_gpu(gpu_shader(t), pixels);
    for (std::size_t i = 0; i < cpu.size(); ++i)
        EXPECT_NEAR(gpu_out[i], cpu[i], 1e-4f * std::max(1.0f, std::abs(cpu[i]))) << i;
}

}  // namespace
