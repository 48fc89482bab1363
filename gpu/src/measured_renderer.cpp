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

constexpr std::size_t kStride = 26;  // floats per ghost in the shader's table

// The shader twin of measured/src/model.cpp (DistanceTable::at, level_weights), float precision: each
// ghost's signed distance looked up bilinearly in its table (measured::distance_table).
constexpr const char* kMeasuredShader = R"(#version 430
layout(local_size_x = 16, local_size_y = 16) in;
// 26 floats each: 16 parameters, pixel box (x0, y0, x1, y1), table (u0, du, dv, nu, nv, offset)
layout(std430, binding = 0) readonly buffer Ghosts { float ghost[]; };
layout(std430, binding = 1) buffer Image { float rgb[]; };
layout(std430, binding = 3) readonly buffer Tables { float table[]; };
uniform int ghost_count;
uniform ivec2 size;     // of the grid drawn: pixels of the image, or a reduced grid of samples
uniform vec2 centre;    // the image's centre, pixels
uniform vec2 origin;    // the image's pixel coordinate of sample (0, 0) ...
uniform float spacing;  // ... and between samples (1: the image's pixels)
uniform ivec2 write_at; // where sample (0, 0) goes in the target ...
uniform int row;        // ... of rows this wide
uniform vec2 pixel_mm;
uniform vec2 roll;  // cos, sin

const int STRIDE = 26;
float P(int g, int k) { return ghost[g * STRIDE + k]; }

// Ghost g's signed distance at (u, |v|) of its frame; its fall-off outside (dark) beyond its table.
float distance_at(int g, float u, float v) {
    int base = g * STRIDE;
    int nu = int(ghost[base + 23]), nv = int(ghost[base + 24]), offset = int(ghost[base + 25]);
    vec2 x = vec2((u - ghost[base + 20]) / ghost[base + 21], v / ghost[base + 22]);
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
        int base = g * STRIDE;
        if (at.x < ghost[base + 16] - margin || at.y < ghost[base + 17] - margin || at.x >= ghost[base + 18] + margin || at.y >= ghost[base + 19] + margin) continue;
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
    int i = ((px.y + write_at.y) * row + px.x + write_at.x) * 3;
    rgb[i] += sum.r;
    rgb[i + 1] += sum.g;
    rgb[i + 2] += sum.b;
}
)";

// Adds a reduced grid of samples, bilinearly interpolated, into a box of the image (measured::add_upsampled's twin).
constexpr const char* kUpsampleShader = R"(#version 430
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 1) buffer Image { float rgb[]; };
layout(std430, binding = 2) readonly buffer Samples { float samples[]; };
uniform ivec2 size;    // of the box
uniform ivec2 offset;  // the image pixel of the box's (0, 0)
uniform ivec2 grid;
uniform float reduction;

vec3 sample_at(ivec2 ij) {
    int i = (ij.y * grid.x + ij.x) * 3;
    return vec3(samples[i], samples[i + 1], samples[i + 2]);
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= size.x || px.y >= size.y) return;
    vec2 s = (vec2(px + offset) - 0.5 * (reduction - 1.0)) / reduction + 1.0;
    ivec2 ij = clamp(ivec2(floor(s)), ivec2(0), grid - 2);
    vec2 t = s - vec2(ij);
    vec3 top = mix(sample_at(ij), sample_at(ij + ivec2(1, 0)), t.x);
    vec3 bottom = mix(sample_at(ij + ivec2(0, 1)), sample_at(ij + ivec2(1, 1)), t.x);
    vec3 v = mix(top, bottom, t.y);
    int i = (px.y * size.x + px.x) * 3;  // the box's pixel
    rgb[i] += v.r;
    rgb[i + 1] += v.g;
    rgb[i + 2] += v.b;
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
// A smooth ghost's box grown by what its upsampling spreads (two reduced samples), clamped to the image.
Box grown(const Box& b, int by, const measured::MeasuredView& view) {
    return {std::max(b[0] - by, 0), std::max(b[1] - by, 0), std::min(b[2] + by, view.width), std::min(b[3] + by, view.height)};
}

// The ghosts of one view in the shader's tables, and the boxes they light.
struct GhostTables {
    std::array<std::vector<float>, 4> by_reduction;  // 1, 2, 4, 8 (measured::reduction_for)
    std::vector<float> distances;
    Box full_size{0, 0, 0, 0};  // of the ghosts drawn at full size
    Box all{0, 0, 0, 0};        // of every ghost, smooth ones grown
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
        t.all = joined(t.all, reduction == 1 ? box : grown(box, 2 * reduction, view));
    }
    return t;
}

struct MeasuredRenderer::State {
    Program program{"measured.comp", {{ShaderStage::Type::Compute, kMeasuredShader}}};
    Program upsample{"measured_upsample.comp", {{ShaderStage::Type::Compute, kUpsampleShader}}};
    GlObject ghosts = GlObject::buffer();
    GlObject image = GlObject::buffer();
    GlObject samples = GlObject::buffer();
    GlObject distances = GlObject::buffer();

    // Draws the table's ghosts into `target`: a grid of width x height samples at image pixel origin + i x
    // spacing, sample (0, 0) written at write_at of the target's rows of `row` samples.
    void draw(const std::vector<float>& table, const measured::MeasuredView& view, double roll, GLuint target, std::array<int, 2> size,
              std::array<double, 2> origin, double spacing, std::array<int, 2> write_at, int row) {
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, ghosts.get());
        glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(table.size() * sizeof(float)), table.data(), GL_STREAM_DRAW);
        glUseProgram(program.get());
        glUniform1i(program.uniform("ghost_count"), static_cast<GLint>(table.size() / kStride));
        glUniform2i(program.uniform("size"), size[0], size[1]);
        glUniform2f(program.uniform("centre"), static_cast<float>(0.5 * view.width), static_cast<float>(0.5 * view.height));
        glUniform2f(program.uniform("origin"), static_cast<float>(origin[0]), static_cast<float>(origin[1]));
        glUniform1f(program.uniform("spacing"), static_cast<float>(spacing));
        glUniform2i(program.uniform("write_at"), write_at[0], write_at[1]);
        glUniform1i(program.uniform("row"), row);
        glUniform2f(program.uniform("pixel_mm"), static_cast<float>(view.sensor_width_mm / view.width), static_cast<float>(view.sensor_height_mm / view.height));
        glUniform2f(program.uniform("roll"), static_cast<float>(std::cos(roll)), static_cast<float>(std::sin(roll)));
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, ghosts.get());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, target);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, distances.get());
        glDispatchCompute(static_cast<GLuint>((size[0] + 15) / 16), static_cast<GLuint>((size[1] + 15) / 16), 1);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    }

    // Full-size ghosts drawn over their box into the image buffer, which holds box `all`.
    void draw_full(const GhostTables& t, const measured::MeasuredView& view, double roll) {
        const Box& f = t.full_size;
        draw(t.by_reduction[0], view, roll, image.get(), {box_width(f), box_height(f)}, {static_cast<double>(f[0]), static_cast<double>(f[1])}, 1.0,
             {f[0] - t.all[0], f[1] - t.all[1]}, box_width(t.all));
    }

    // Smooth ghosts at a reduction: drawn on the reduced grid, then added upsampled into the image buffer
    // (box `all`).
    void draw_reduced(const std::vector<float>& table, const measured::MeasuredView& view, double roll, const measured::ReducedGrid& grid, const Box& all) {
        const std::vector<float> zeros(static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height) * 3, 0.0f);
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, samples.get());
        glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(zeros.size() * sizeof(float)), zeros.data(), GL_STREAM_COPY);
        draw(table, view, roll, samples.get(), {grid.width, grid.height}, {grid.pixel_of(0), grid.pixel_of(0)}, grid.reduction, {0, 0}, grid.width);
        glUseProgram(upsample.get());
        glUniform2i(upsample.uniform("size"), box_width(all), box_height(all));
        glUniform2i(upsample.uniform("offset"), all[0], all[1]);
        glUniform2i(upsample.uniform("grid"), grid.width, grid.height);
        glUniform1f(upsample.uniform("reduction"), static_cast<float>(grid.reduction));
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, image.get());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, samples.get());
        glDispatchCompute(static_cast<GLuint>((box_width(all) + 15) / 16), static_cast<GLuint>((box_height(all) + 15) / 16), 1);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
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
    if (box_width(t.all) <= 0) return;
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, state_->distances.get());
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(t.distances.size() * sizeof(float)), t.distances.data(), GL_STREAM_DRAW);
    // The ghosts are drawn into a cleared buffer of their box alone, read back and added on the CPU: no
    // upload of the image, and a read-back of the lit box only.
    const auto bw = static_cast<std::size_t>(box_width(t.all)), bh = static_cast<std::size_t>(box_height(t.all));
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, state_->image.get());
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(bw * bh * 3 * sizeof(float)), nullptr, GL_STREAM_READ);
    glClearBufferData(GL_SHADER_STORAGE_BUFFER, GL_R32F, GL_RED, GL_FLOAT, nullptr);
    if (!t.by_reduction[0].empty()) state_->draw_full(t, view, roll);
    for (std::size_t k = 1; k < t.by_reduction.size(); ++k)
        if (!t.by_reduction[k].empty()) state_->draw_reduced(t.by_reduction[k], view, roll, measured::reduced_grid(view, 1 << k), t.all);
    std::vector<float> lit(bw * bh * 3);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, state_->image.get());
    glGetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(lit.size() * sizeof(float)), lit.data());
    check_gl("measured ghosts");
    for (std::size_t y = 0; y < bh; ++y) {
        float* out = rgb + ((static_cast<std::size_t>(t.all[1]) + y) * static_cast<std::size_t>(view.width) + static_cast<std::size_t>(t.all[0])) * 3;
        const float* in = lit.data() + y * bw * 3;
        for (std::size_t k = 0; k < bw * 3; ++k) out[k] += in[k];
    }
}

}  // namespace lensfx::gpu
