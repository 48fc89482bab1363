// The measured-lens renderer: a compute shader over the image, the ghosts' parameters in a buffer.
#include <gpu/measured_renderer.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <epoxy/gl.h>
#include <fmt/core.h>

#include <gpu/gl.h>

namespace lensfx::gpu {

namespace {

constexpr std::size_t kStride = 28;     // floats per ghost in the shader's table (7 vec4)
constexpr std::size_t kMaxGhosts = 64;  // per draw: the uniform block holds 64 x 112 bytes

// The shader twin of measured/src/model.cpp (DistanceTable::at, level_weights), float precision: each
// ghost's signed distance looked up bilinearly in its table (measured::distance_table).
constexpr const char* kMeasuredShader = R"(layout(local_size_x = 16, local_size_y = 16) in;
// 7 vec4 each: 16 parameters, pixel box (x0, y0, x1, y1), table (u0, du, dv, nu, nv, offset), 2 unused.
// A uniform block: the same ghost for every invocation, loaded once rather than gathered per pixel.
layout(std140, binding = 0) uniform Ghosts { vec4 ghost4[MAX_GHOSTS * 7]; };
layout(std430, binding = 1) buffer Image { float rgb[]; };
layout(std430, binding = 3) readonly buffer Tables { float table[]; };
uniform int ghost_count;
uniform ivec2 size;     // of the grid drawn: pixels of the image, or a reduced grid of samples
uniform vec2 centre;    // the image's centre, pixels
uniform vec2 origin;    // the image's pixel coordinate of sample (0, 0) ...
uniform float spacing;  // ... and between samples (1: the image's pixels)
uniform vec2 pixel_mm;
uniform vec2 roll;  // cos, sin

float P(int g, int k) { return ghost4[g * 7 + k / 4][k % 4]; }

// Ghost g's signed distance at (u, |v|) of its frame; its fall-off outside (dark) beyond its table.
float distance_at(int g, float u, float v) {
    int nu = int(P(g, 23)), nv = int(P(g, 24)), offset = int(P(g, 25));
    vec2 x = vec2((u - P(g, 20)) / P(g, 21), v / P(g, 22));
    if (x.x < 0.0 || x.y < 0.0 || x.x > float(nu - 1) || x.y > float(nv - 1)) return P(g, 8);
    ivec2 ij = min(ivec2(x), ivec2(nu - 2, nv - 2));
    vec2 t = x - vec2(ij);
    int k = offset + ij.y * nu + ij.x;
    float top = mix(table[k], table[k + 1], t.x), bottom = mix(table[k + nu], table[k + nu + 1], t.x);
    return mix(top, bottom, t.y);
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= size.x || px.y >= size.y) return;
    vec2 at = origin + vec2(px) * spacing;
    float margin = spacing > 1.0 ? spacing : 0.0;  // a reduced grid's samples just outside a box interpolate into it
    float xs = (at.x + 0.5 - centre.x) * pixel_mm.x;
    float ys = (centre.y - (at.y + 0.5)) * pixel_mm.y;
    float u0 = xs * roll.x + ys * roll.y;
    float v = abs(-xs * roll.y + ys * roll.x);
    vec3 sum = vec3(0.0);
    for (int g = 0; g < ghost_count; ++g) {
        vec4 box = ghost4[g * 7 + 4];
        if (at.x < box.x - margin || at.y < box.y - margin || at.x >= box.z + margin || at.y >= box.w + margin) continue;
        float d = distance_at(g, u0 - P(g, 0), v);
        if (d >= P(g, 8)) continue;  // beyond the fall-off outside: nothing
        vec2 w;
        if (d <= 0.0) {
            float t = min(1.0, -d / P(g, 6));
            float a = pow(1.0 - t, P(g, 7));
            w = vec2(a, 1.0 - a);
        } else {
            float t = min(1.0, d / P(g, 8));
            w = vec2(pow(1.0 - t, P(g, 9)), 0.0);
        }
        sum += vec3(P(g, 10), P(g, 11), P(g, 12)) * w.x + vec3(P(g, 13), P(g, 14), P(g, 15)) * w.y;
    }
    int i = (px.y * size.x + px.x) * 3;
    rgb[i] += sum.r;
    rgb[i + 1] += sum.g;
    rgb[i + 2] += sum.b;
}
)";

// The ghost table of the shader: 16 parameters, the pixel box and the distance table per ghost, the
// distance table's samples appended to `distances`.
void append_ghost(std::vector<float>& table, std::vector<float>& distances, const measured::GhostParams& p, const std::array<int, 4>& box,
                  const measured::DistanceTable& d) {
    for (double v : p) table.push_back(static_cast<float>(v));
    for (int b : box) table.push_back(static_cast<float>(b));
    for (double v : {d.u0, d.du, d.dv}) table.push_back(static_cast<float>(v));
    for (std::size_t v : {static_cast<std::size_t>(d.nu), static_cast<std::size_t>(d.nv), distances.size()}) table.push_back(static_cast<float>(v));
    table.insert(table.end(), {0.0f, 0.0f});
    distances.insert(distances.end(), d.d.begin(), d.d.end());
}

}  // namespace

// A pixel box [x0, x1) x [y0, y1) of the image.
using Box = std::array<int, 4>;
int box_width(const Box& b) { return b[2] - b[0]; }
int box_height(const Box& b) { return b[3] - b[1]; }
Box joined(const Box& a, const Box& b) {
    if (box_width(a) <= 0) return b;
    return {std::min(a[0], b[0]), std::min(a[1], b[1]), std::max(a[2], b[2]), std::max(a[3], b[3])};
}
// The ghosts of one view in the shader's tables, and the boxes they light.
struct GhostTables {
    std::array<std::vector<float>, 4> by_reduction;  // 1, 2, 4, 8 (measured::reduction_for)
    std::vector<float> distances;
    Box full_size{0, 0, 0, 0};  // of the ghosts drawn at full size
};

GhostTables ghost_tables(const measured::MeasuredLens& lens, const measured::MeasuredView& view, double field, double roll, std::array<double, 3> scale) {
    GhostTables t;
    const double pixel = std::min(view.sensor_width_mm / view.width, view.sensor_height_mm / view.height);
    for (const measured::GhostParams& p : measured::ghosts_at(lens, field, scale)) {
        const Box box = measured::ghost_box(p, roll, view);
        if (box_width(box) <= 0 || box_height(box) <= 0) continue;
        const int reduction = measured::reduction_for(p, view);
        append_ghost(t.by_reduction[static_cast<std::size_t>(std::countr_zero(static_cast<unsigned>(reduction)))], t.distances, p, box,
                     measured::distance_table(p, reduction * pixel));
        if (reduction == 1) t.full_size = joined(t.full_size, box);
    }
    return t;
}

struct MeasuredRenderer::State {
    Program program{"measured.comp", {{ShaderStage::Type::Compute, fmt::format("#version 430\n#define MAX_GHOSTS {}\n{}", kMaxGhosts, kMeasuredShader)}}};
    GlObject ghosts = GlObject::buffer();
    GlObject image = GlObject::buffer();
    GlObject samples = GlObject::buffer();
    GlObject distances = GlObject::buffer();

    // Draws the table's ghosts into `target`: a grid of width x height samples at image pixel origin + i x
    // spacing.
    void draw(const std::vector<float>& table, const measured::MeasuredView& view, double roll, GLuint target, std::array<int, 2> size,
              std::array<double, 2> origin, double spacing) {
        glUseProgram(program.get());
        glUniform2i(program.uniform("size"), size[0], size[1]);
        glUniform2f(program.uniform("centre"), static_cast<float>(0.5 * view.width), static_cast<float>(0.5 * view.height));
        glUniform2f(program.uniform("origin"), static_cast<float>(origin[0]), static_cast<float>(origin[1]));
        glUniform1f(program.uniform("spacing"), static_cast<float>(spacing));
        glUniform2f(program.uniform("pixel_mm"), static_cast<float>(view.sensor_width_mm / view.width), static_cast<float>(view.sensor_height_mm / view.height));
        glUniform2f(program.uniform("roll"), static_cast<float>(std::cos(roll)), static_cast<float>(std::sin(roll)));
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, target);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, distances.get());
        for (std::size_t first = 0; first < table.size(); first += kMaxGhosts * kStride) {  // kMaxGhosts at a time
            const std::size_t floats = std::min(table.size() - first, kMaxGhosts * kStride);
            std::vector<float> block(kMaxGhosts * kStride, 0.0f);
            std::copy_n(table.begin() + static_cast<std::ptrdiff_t>(first), floats, block.begin());
            glBindBuffer(GL_UNIFORM_BUFFER, ghosts.get());
            glBufferData(GL_UNIFORM_BUFFER, static_cast<GLsizeiptr>(block.size() * sizeof(float)), block.data(), GL_STREAM_DRAW);
            glBindBufferBase(GL_UNIFORM_BUFFER, 0, ghosts.get());
            glUniform1i(program.uniform("ghost_count"), static_cast<GLint>(floats / kStride));
            glDispatchCompute(static_cast<GLuint>((size[0] + 15) / 16), static_cast<GLuint>((size[1] + 15) / 16), 1);
            glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
        }
    }

    // A buffer of `floats` zeros bound as the shader storage buffer.
    static void clear(const GlObject& buffer, std::size_t floats) {
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, buffer.get());
        glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(floats * sizeof(float)), nullptr, GL_STREAM_READ);
        glClearBufferData(GL_SHADER_STORAGE_BUFFER, GL_R32F, GL_RED, GL_FLOAT, nullptr);
    }

    static std::vector<float> read_back(const GlObject& buffer, std::size_t floats) {
        std::vector<float> out(floats);
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, buffer.get());
        glGetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(floats * sizeof(float)), out.data());
        return out;
    }

    // The full-size ghosts drawn over their box, read back (that box only) and added into rgb.
    void add_full_size(const GhostTables& t, const measured::MeasuredView& view, double roll, float* rgb) {
        const Box& f = t.full_size;
        const auto bw = static_cast<std::size_t>(box_width(f)), bh = static_cast<std::size_t>(box_height(f));
        clear(image, bw * bh * 3);
        draw(t.by_reduction[0], view, roll, image.get(), {box_width(f), box_height(f)}, {static_cast<double>(f[0]), static_cast<double>(f[1])}, 1.0);
        const std::vector<float> lit = read_back(image, bw * bh * 3);
        for (std::size_t y = 0; y < bh; ++y) {
            float* out = rgb + ((static_cast<std::size_t>(f[1]) + y) * static_cast<std::size_t>(view.width) + static_cast<std::size_t>(f[0])) * 3;
            const float* in = lit.data() + y * bw * 3;
            for (std::size_t k = 0; k < bw * 3; ++k) out[k] += in[k];
        }
    }

    // Smooth ghosts at a reduction: drawn on the reduced grid, which alone is read back and added
    // upsampled into rgb (measured::add_upsampled; no full-size image crosses to or from the GPU).
    void add_reduced(const std::vector<float>& table, const measured::MeasuredView& view, double roll, const measured::ReducedGrid& grid, float* rgb) {
        const std::size_t floats = static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height) * 3;
        clear(samples, floats);
        draw(table, view, roll, samples.get(), {grid.width, grid.height}, {grid.pixel_of(0), grid.pixel_of(0)}, grid.reduction);
        measured::add_upsampled(grid, read_back(samples, floats).data(), view, rgb);
    }
};

MeasuredRenderer::MeasuredRenderer(const Context& context) {
    context.make_current();
    state_ = std::make_unique<State>();
}

MeasuredRenderer::~MeasuredRenderer() = default;

void MeasuredRenderer::render_add(const measured::MeasuredLens& lens, const measured::MeasuredView& view, std::array<double, 3> scale, float* rgb) {
    const auto [field, roll] = measured::field_and_roll(view.angle_x_deg, view.angle_y_deg);
    const GhostTables t = ghost_tables(lens, view, field, roll, scale);
    if (t.distances.empty()) return;
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, state_->distances.get());
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(t.distances.size() * sizeof(float)), t.distances.data(), GL_STREAM_DRAW);
    if (!t.by_reduction[0].empty()) state_->add_full_size(t, view, roll, rgb);
    for (std::size_t k = 1; k < t.by_reduction.size(); ++k)
        if (!t.by_reduction[k].empty()) state_->add_reduced(t.by_reduction[k], view, roll, measured::reduced_grid(view, 1 << k), rgb);
    check_gl("measured ghosts");
}

}  // namespace lensfx::gpu
