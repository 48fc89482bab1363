// The GPU path of a colour transform: OCIO's GLSL (gpu_shader) in a compute shader over packed RGB.
#include <filter/colour/transform.h>

#include <algorithm>
#include <stdexcept>

#include <epoxy/gl.h>
#include <fmt/core.h>

#include <gpu/gl.h>

namespace lensfx::colour {

struct GpuColourTransform::State {
    gpu::Program program;
    std::vector<gpu::GlObject> textures;
    std::vector<GLenum> targets;
    gpu::GlObject buffer = gpu::GlObject::buffer();
    std::size_t capacity = 0;  // floats in `buffer`
    std::vector<float> packed;
};

namespace {

std::string compute_source(const GpuShader& shader) {
    return "#version 430\n" + shader.source + R"(
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
}

}  // namespace

GpuColourTransform::GpuColourTransform(const ColourTransform& transform) {
    if (transform.is_identity()) return;
    const GpuShader shader = gpu_shader(transform);
    state_ = std::make_unique<State>(State{gpu::Program("ocio-colour.comp", {{gpu::ShaderStage::Type::Compute, compute_source(shader)}}),
                                           {}, {}, gpu::GlObject::buffer(), 0, {}});
    glUseProgram(state_->program.get());
    for (std::size_t k = 0; k < shader.textures.size(); ++k) {
        const GpuShader::Texture& t = shader.textures[k];
        state_->textures.push_back(gpu::GlObject::texture());
        const GLenum target = t.dimensions == 3 ? GL_TEXTURE_3D : t.dimensions == 2 ? GL_TEXTURE_2D : GL_TEXTURE_1D;
        state_->targets.push_back(target);
        glBindTexture(target, state_->textures.back().get());
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
        for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R}) glTexParameteri(target, wrap, GL_CLAMP_TO_EDGE);
        glUniform1i(state_->program.uniform(t.sampler.c_str()), static_cast<GLint>(k));
    }
    glUseProgram(0);
    gpu::check_gl("uploading the OCIO shader's LUTs");
}

GpuColourTransform::~GpuColourTransform() = default;
GpuColourTransform::GpuColourTransform(GpuColourTransform&&) noexcept = default;
GpuColourTransform& GpuColourTransform::operator=(GpuColourTransform&&) noexcept = default;

// Pixels sent to the GPU at a time: the buffer stays at 48 MB whatever the frame (an 8K frame whole
// would hold 0.8 GB in the driver for the rest of the run).
constexpr std::size_t kChunkPixels = std::size_t{1} << 22;

void GpuColourTransform::apply_rgb(float* rgb, std::size_t count) {
    if (!state_ || count == 0) return;
    State& s = *state_;
    glUseProgram(s.program.get());
    for (std::size_t k = 0; k < s.textures.size(); ++k) {
        glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(k));
        glBindTexture(s.targets[k], s.textures[k].get());
    }
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, s.buffer.get());
    const std::size_t capacity = std::min(count, kChunkPixels) * 3;
    if (capacity > s.capacity) {
        glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(capacity * sizeof(float)), nullptr, GL_DYNAMIC_COPY);
        s.capacity = capacity;
    }
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, s.buffer.get());
    for (std::size_t first = 0; first < count; first += kChunkPixels) {
        const std::size_t n = std::min(kChunkPixels, count - first);
        const auto bytes = static_cast<GLsizeiptr>(n * 3 * sizeof(float));
        glBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, bytes, rgb + first * 3);
        glUniform1ui(s.program.uniform("count"), static_cast<GLuint>(n));
        glDispatchCompute(static_cast<GLuint>((n + 63) / 64), 1, 1);
        glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
        glGetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, bytes, rgb + first * 3);
    }
    gpu::check_gl("the GPU colour transform");
    glUseProgram(0);
}

void GpuColourTransform::apply(PixelSpan p) {
    if (!state_) return;
    const std::size_t stride = p.row_stride ? p.row_stride : p.width * static_cast<std::size_t>(p.channels);
    const auto channels = static_cast<std::size_t>(p.channels);
    if (channels == 3 && stride == p.width * 3) {
        apply_rgb(p.data, p.width * p.height);
        return;
    }
    std::vector<float>& packed = state_->packed;
    packed.resize(p.width * p.height * 3);
    for (std::size_t y = 0; y < p.height; ++y)
        for (std::size_t x = 0; x < p.width; ++x)
            for (std::size_t c = 0; c < 3; ++c) packed[(y * p.width + x) * 3 + c] = p.data[y * stride + x * channels + c];
    apply_rgb(packed.data(), p.width * p.height);
    for (std::size_t y = 0; y < p.height; ++y)
        for (std::size_t x = 0; x < p.width; ++x)
            for (std::size_t c = 0; c < 3; ++c) p.data[y * stride + x * channels + c] = packed[(y * p.width + x) * 3 + c];
}

}  // namespace lensfx::colour
