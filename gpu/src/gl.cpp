// GL object owners, named shader programs and the float render target.
#include <gpu/gl.h>

#include <algorithm>
#include <stdexcept>
#include <utility>

#include <epoxy/gl.h>
#include <fmt/core.h>

namespace lensfx::gpu {

void check_gl([[maybe_unused]] std::string_view what) {
#ifndef NDEBUG
    const GLenum err = glGetError();
    if (err != GL_NO_ERROR) {
        while (glGetError() != GL_NO_ERROR) {
        }
        throw std::runtime_error(fmt::format("GL error 0x{:04x} after {}", err, what));
    }
#endif
}

GlObject::~GlObject() { reset(); }

GlObject::GlObject(GlObject&& other) noexcept
    : kind_(other.kind_), name_(std::exchange(other.name_, 0u)) {}

GlObject& GlObject::operator=(GlObject&& other) noexcept {
    if (this != &other) {
        reset();
        kind_ = other.kind_;
        name_ = std::exchange(other.name_, 0u);
    }
    return *this;
}

void GlObject::reset() {
    if (name_ == 0) return;
    switch (kind_) {
        case Kind::Buffer: glDeleteBuffers(1, &name_); break;
        case Kind::Texture: glDeleteTextures(1, &name_); break;
        case Kind::Framebuffer: glDeleteFramebuffers(1, &name_); break;
        case Kind::VertexArray: glDeleteVertexArrays(1, &name_); break;
        case Kind::Program: glDeleteProgram(name_); break;
    }
    name_ = 0;
}

GlObject GlObject::buffer() {
    GLuint n = 0;
    glCreateBuffers(1, &n);
    return {Kind::Buffer, n};
}
GlObject GlObject::texture() {
    GLuint n = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &n);
    return {Kind::Texture, n};
}
GlObject GlObject::buffer_texture() {
    GLuint n = 0;
    glCreateTextures(GL_TEXTURE_BUFFER, 1, &n);
    return {Kind::Texture, n};
}
GlObject GlObject::framebuffer() {
    GLuint n = 0;
    glCreateFramebuffers(1, &n);
    return {Kind::Framebuffer, n};
}
GlObject GlObject::vertex_array() {
    GLuint n = 0;
    glCreateVertexArrays(1, &n);
    return {Kind::VertexArray, n};
}

void view_buffer_texels(const GlObject& texture, unsigned format, const GlObject& buffer, std::size_t texels, std::string_view what) {
    GLint most = 0;
    glGetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &most);
    if (texels > static_cast<std::size_t>(std::max(most, 0)))
        throw std::runtime_error(fmt::format("{}: {} texels, over the GL's largest buffer texture ({} texels)", what, texels, most));
    glTextureBuffer(texture.get(), format, buffer.get());
}

namespace {

std::string_view stage_name(ShaderStage::Type type) {
    switch (type) {
        case ShaderStage::Type::Vertex: return "vertex";
        case ShaderStage::Type::Fragment: return "fragment";
        case ShaderStage::Type::Compute: return "compute";
    }
    return "?";
}

GLenum stage_enum(ShaderStage::Type type) {
    switch (type) {
        case ShaderStage::Type::Vertex: return GL_VERTEX_SHADER;
        case ShaderStage::Type::Fragment: return GL_FRAGMENT_SHADER;
        case ShaderStage::Type::Compute: return GL_COMPUTE_SHADER;
    }
    return GL_VERTEX_SHADER;
}

std::string trimmed(std::string log) {
    while (!log.empty() && (log.back() == '\n' || log.back() == '\0' || log.back() == ' ')) log.pop_back();
    return log;
}

}  // namespace

Program::Program(std::string name, const std::vector<ShaderStage>& stages)
    : name_(std::move(name)), program_(GlObject::Kind::Program, glCreateProgram()) {
    std::vector<GLuint> shaders;
    auto delete_shaders = [&] {
        for (GLuint s : shaders) glDeleteShader(s);
    };
    for (const ShaderStage& stage : stages) {
        const GLuint shader = glCreateShader(stage_enum(stage.type));
        shaders.push_back(shader);
        const char* src = stage.source.c_str();
        glShaderSource(shader, 1, &src, nullptr);
        glCompileShader(shader);
        GLint ok = GL_FALSE;
        glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
        if (!ok) {
            GLint len = 0;
            glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &len);
            std::string log(static_cast<std::size_t>(len > 0 ? len : 1), '\0');
            glGetShaderInfoLog(shader, len, nullptr, log.data());
            delete_shaders();
            throw std::runtime_error(fmt::format("shader '{}' ({} stage) failed to compile: {}", name_,
                                                 stage_name(stage.type), trimmed(log)));
        }
        glAttachShader(program_.get(), shader);
    }
    glLinkProgram(program_.get());
    delete_shaders();
    GLint ok = GL_FALSE;
    glGetProgramiv(program_.get(), GL_LINK_STATUS, &ok);
    if (!ok) {
        GLint len = 0;
        glGetProgramiv(program_.get(), GL_INFO_LOG_LENGTH, &len);
        std::string log(static_cast<std::size_t>(len > 0 ? len : 1), '\0');
        glGetProgramInfoLog(program_.get(), len, nullptr, log.data());
        throw std::runtime_error(fmt::format("shader '{}' failed to link: {}", name_, trimmed(log)));
    }
    check_gl(fmt::format("building shader '{}'", name_));
}

int Program::uniform(const char* uniform_name) const { return glGetUniformLocation(program_.get(), uniform_name); }

FloatTarget::FloatTarget(int width, int height)
    : width_(width), height_(height), texture_(GlObject::texture()), framebuffer_(GlObject::framebuffer()) {
    if (width <= 0 || height <= 0) {
        throw std::invalid_argument(fmt::format("render target size {}x{} is not positive", width, height));
    }
    GLint max_size = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
    if (width > max_size || height > max_size) {
        throw std::invalid_argument(
            fmt::format("render target size {}x{} exceeds GL_MAX_TEXTURE_SIZE {}", width, height, max_size));
    }
    glTextureStorage2D(texture_.get(), 1, GL_RGBA32F, width, height);
    glNamedFramebufferTexture(framebuffer_.get(), GL_COLOR_ATTACHMENT0, texture_.get(), 0);
    if (glCheckNamedFramebufferStatus(framebuffer_.get(), GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        throw std::runtime_error(fmt::format("RGBA32F framebuffer {}x{} is incomplete", width, height));
    }
    check_gl("creating the RGBA32F render target");
}

void FloatTarget::bind() const {
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, framebuffer_.get());
    glViewport(0, 0, width_, height_);
}

void FloatTarget::clear(float alpha) const {
    const float value[4] = {0.f, 0.f, 0.f, alpha};
    glClearTexImage(texture_.get(), 0, GL_RGBA, GL_FLOAT, value);
}

void FloatTarget::clear(const TexelRect& rect) const {
    if (rect.empty()) return;
    const float value[4] = {0.f, 0.f, 0.f, 0.f};
    glClearTexSubImage(texture_.get(), 0, rect.x0, rect.y0, 0, rect.x1 - rect.x0, rect.y1 - rect.y0, 1, GL_RGBA, GL_FLOAT, value);
}

std::vector<float> FloatTarget::read_rgba() const {
    std::vector<float> pixels(static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_) * 4);
    read_rgba_rows(0, height_, pixels.data());
    return pixels;
}

void FloatTarget::read_rgba_rows(int first_row, int rows, float* out) const {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer_.get());
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, first_row, width_, rows, GL_RGBA, GL_FLOAT, out);
    check_gl("reading back the float render target");
}

void FloatTarget::read_rgba_rect(const TexelRect& rect, float* out) const {
    if (rect.empty()) return;
    glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer_.get());
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glPixelStorei(GL_PACK_ROW_LENGTH, width_);
    glReadPixels(rect.x0, rect.y0, rect.x1 - rect.x0, rect.y1 - rect.y0, GL_RGBA, GL_FLOAT,
                 out + static_cast<std::size_t>(rect.x0) * 4);
    glPixelStorei(GL_PACK_ROW_LENGTH, 0);
    check_gl("reading back part of the float render target");
}

}  // namespace lensfx::gpu
