// Small RAII owners for GL objects, a named shader program whose compile/link errors name the shader,
// and GL error checks that are active in debug builds only. Needs a current gpu::Context.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace lensfx::gpu {

// Throws std::runtime_error("GL error ... after <what>") when glGetError reports one (debug builds);
// a no-op in release builds (NDEBUG).
void check_gl(std::string_view what);

// Owns one GL name; the deleter is chosen by Kind.
class GlObject {
public:
    enum class Kind { Buffer, Texture, Framebuffer, VertexArray, Program };
    GlObject() = default;
    GlObject(Kind kind, unsigned name) : kind_(kind), name_(name) {}
    ~GlObject();
    GlObject(GlObject&& other) noexcept;
    GlObject& operator=(GlObject&& other) noexcept;
    GlObject(const GlObject&) = delete;
    GlObject& operator=(const GlObject&) = delete;
    unsigned get() const { return name_; }

    static GlObject buffer();
    static GlObject texture();
    static GlObject buffer_texture();  // a GL_TEXTURE_BUFFER: a buffer read by texelFetch
    static GlObject framebuffer();
    static GlObject vertex_array();

private:
    void reset();
    Kind kind_ = Kind::Buffer;
    unsigned name_ = 0;
};

// `texture` (a buffer_texture) made a view of the whole of `buffer`, `texels` texels of `format` (GL_RGBA32F,
// GL_R32UI, ...). Throws std::runtime_error naming `what` where the GL's largest buffer texture holds fewer (GL 4.3
// promises only 65,536 texels; past it what a texel fetch reads is undefined).
void view_buffer_texels(const GlObject& texture, unsigned format, const GlObject& buffer, std::size_t texels, std::string_view what);

struct ShaderStage {
    enum class Type { Vertex, Fragment, Compute };
    Type type;
    std::string source;
};

// A linked program. `name` appears in every compile or link error ("shader 'ghost.vert': 0:12: ...").
class Program {
public:
    Program(std::string name, const std::vector<ShaderStage>& stages);
    unsigned get() const { return program_.get(); }
    const std::string& name() const { return name_; }
    int uniform(const char* uniform_name) const;  // -1 when absent (optimised away)

private:
    std::string name_;
    GlObject program_;
};

// A rectangle of a target's texels: columns [x0, x1), rows [y0, y1) (GL's order: row 0 is the bottom).
struct TexelRect {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    bool empty() const { return x1 <= x0 || y1 <= y0; }
};

// A float RGBA render target (RGBA32F colour attachment) with readback.
class FloatTarget {
public:
    FloatTarget(int width, int height);
    int width() const { return width_; }
    int height() const { return height_; }
    unsigned texture() const { return texture_.get(); }
    void bind() const;    // as the draw framebuffer, viewport set
    void clear(float alpha = 0.0f) const;   // RGB to zero, alpha to `alpha`, whatever the colour mask
    void clear(const TexelRect& rect) const;  // RGBA to zero within `rect` only
    std::vector<float> read_rgba() const;  // rows bottom to top as GL stores them, 4 floats per pixel
    // Rows [first_row, first_row + rows) (GL's order: 0 is the bottom) into `out`, 4 floats per pixel.
    void read_rgba_rows(int first_row, int rows, float* out) const;
    // The texels of `rect` into `out`, which holds rows rect.y0, rect.y0 + 1, ... of width() texels each, every
    // texel at its own column: what `out` holds beyond the rect's columns is left as it was.
    void read_rgba_rect(const TexelRect& rect, float* out) const;

private:
    int width_;
    int height_;
    GlObject texture_;
    GlObject framebuffer_;
};

}  // namespace lensfx::gpu
