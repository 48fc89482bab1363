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

// The shader twin of measured/src/model.cpp (signed_distance, level_weights), float precision.
constexpr const char* kMeasuredShader = R"(#version 430
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) readonly buffer Ghosts { float ghost[]; };  // 20 floats each: 16 parameters, pixel box
layout(std430, binding = 1) buffer Image { float rgb[]; };
uniform int ghost_count;
uniform ivec2 size;     // of the grid written: the image, or a reduced grid of samples
uniform vec2 centre;    // the image's centre, pixels
uniform float origin;   // the image's pixel coordinate of sample (0, 0) ...
uniform float spacing;  // ... and between samples (1: the image itself)
uniform vec2 pixel_mm;
uniform vec2 roll;  // cos, sin

const int STRIDE = 20;
float P(int g, int k) { return ghost[g * STRIDE + k]; }

vec2 bezier(vec2 p0, vec2 p1, vec2 p2, vec2 p3, float t) {
    float s = 1.0 - t;
    return s * s * s * p0 + 3.0 * s * s * t * p1 + 3.0 * s * t * t * p2 + t * t * t * p3;
}

float sq(vec2 a) { return dot(a, a); }

// Nearest distance from q to the side's upper segment (extent e, curve c, height h).
float side_distance(float e, float c, float h, vec2 q) {
    vec2 p0 = vec2(e, 0.0), p1 = vec2(e, c * h), p2 = vec2(c * e, h), p3 = vec2(0.0, h);
    int best = 0;
    float best_d = 1e30;
    for (int i = 0; i <= 16; ++i) {
        float d = sq(bezier(p0, p1, p2, p3, float(i) / 16.0) - q);
        if (d < best_d) { best_d = d; best = i; }
    }
    float lo = max(0.0, float(best - 1) / 16.0), hi = min(1.0, float(best + 1) / 16.0);
    const float G = 0.6180339887;
    float a = hi - G * (hi - lo), b = lo + G * (hi - lo);
    float fa = sq(bezier(p0, p1, p2, p3, a) - q), fb = sq(bezier(p0, p1, p2, p3, b) - q);
    for (int i = 0; i < 12; ++i) {
        if (fa < fb) { hi = b; b = a; fb = fa; a = hi - G * (hi - lo); fa = sq(bezier(p0, p1, p2, p3, a) - q); }
        else { lo = a; a = b; fa = fb; b = lo + G * (hi - lo); fb = sq(bezier(p0, p1, p2, p3, b) - q); }
    }
    return sqrt(min(best_d, min(fa, fb)));
}

float side_height(float e, float c, float h, float u) {
    vec2 p0 = vec2(e, 0.0), p1 = vec2(e, c * h), p2 = vec2(c * e, h), p3 = vec2(0.0, h);
    float lo = 0.0, hi = 1.0;
    for (int i = 0; i < 20; ++i) {
        float mid = 0.5 * (lo + hi);
        if (bezier(p0, p1, p2, p3, mid).x > u) lo = mid; else hi = mid;
    }
    return bezier(p0, p1, p2, p3, 0.5 * (lo + hi)).y;
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= size.x || px.y >= size.y) return;
    vec2 at = vec2(origin) + vec2(px) * spacing;
    float margin = spacing > 1.0 ? spacing : 0.0;  // a reduced grid's samples just outside a box interpolate into it
    float xs = (at.x + 0.5 - centre.x) * pixel_mm.x;
    float ys = (centre.y - (at.y + 0.5)) * pixel_mm.y;
    float u0 = xs * roll.x + ys * roll.y;
    float v = abs(-xs * roll.y + ys * roll.x);
    vec3 sum = vec3(0.0);
    for (int g = 0; g < ghost_count; ++g) {
        int base = g * STRIDE;
        if (at.x < ghost[base + 16] - margin || at.y < ghost[base + 17] - margin || at.x >= ghost[base + 18] + margin || at.y >= ghost[base + 19] + margin) continue;
        float u = u0 - P(g, 0);
        float L = P(g, 1), R = P(g, 2), h = P(g, 3), cl = P(g, 4), cr = P(g, 5);
        bool right = u >= 0.0;
        float e = right ? R : L, c = right ? cr : cl;
        bool inside = abs(u) < e && v < h && v < side_height(e, c, h, abs(u));
        // Outside and farther than the fall-off from the box around the shape: nothing.
        if (!inside && max(abs(u) - e, v - h) >= P(g, 8)) continue;
        // The far side's segment lies at |u| or more: it is nearer only when the near one is farther.
        float d = side_distance(e, c, h, vec2(abs(u), v));
        if (d > abs(u)) d = min(d, side_distance(right ? L : R, right ? cl : cr, h, vec2(-abs(u), v)));
        vec2 w;
        if (inside) {
            float t = min(1.0, d / P(g, 6));
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

// Adds a reduced grid of samples, bilinearly interpolated, into the image (measured::add_upsampled's twin).
constexpr const char* kUpsampleShader = R"(#version 430
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 1) buffer Image { float rgb[]; };
layout(std430, binding = 2) readonly buffer Samples { float samples[]; };
uniform ivec2 size;
uniform ivec2 grid;
uniform float reduction;

vec3 sample_at(ivec2 ij) {
    int i = (ij.y * grid.x + ij.x) * 3;
    return vec3(samples[i], samples[i + 1], samples[i + 2]);
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= size.x || px.y >= size.y) return;
    vec2 s = (vec2(px) - 0.5 * (reduction - 1.0)) / reduction + 1.0;
    ivec2 ij = clamp(ivec2(floor(s)), ivec2(0), grid - 2);
    vec2 t = s - vec2(ij);
    vec3 top = mix(sample_at(ij), sample_at(ij + ivec2(1, 0)), t.x);
    vec3 bottom = mix(sample_at(ij + ivec2(0, 1)), sample_at(ij + ivec2(1, 1)), t.x);
    vec3 v = mix(top, bottom, t.y);
    int i = (px.y * size.x + px.x) * 3;
    rgb[i] += v.r;
    rgb[i + 1] += v.g;
    rgb[i + 2] += v.b;
}
)";

// The ghost table of the shader: 16 parameters and the pixel box per ghost.
void append_ghost(std::vector<float>& table, const measured::GhostParams& p, const std::array<int, 4>& box) {
    for (double v : p) table.push_back(static_cast<float>(v));
    for (int b : box) table.push_back(static_cast<float>(b));
}

}  // namespace

struct MeasuredRenderer::State {
    Program program{"measured.comp", {{ShaderStage::Type::Compute, kMeasuredShader}}};
    Program upsample{"measured_upsample.comp", {{ShaderStage::Type::Compute, kUpsampleShader}}};
    GlObject ghosts = GlObject::buffer();
    GlObject image = GlObject::buffer();
    GlObject samples = GlObject::buffer();

    // Draws the table's ghosts into `target` (bound as the image): a grid of width x height samples at
    // image pixel origin + i x spacing.
    void draw(const std::vector<float>& table, const measured::MeasuredView& view, double roll, GLuint target, int width, int height, double origin, double spacing) {
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, ghosts.get());
        glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(table.size() * sizeof(float)), table.data(), GL_STREAM_DRAW);
        glUseProgram(program.get());
        glUniform1i(program.uniform("ghost_count"), static_cast<GLint>(table.size() / 20));
        glUniform2i(program.uniform("size"), width, height);
        glUniform2f(program.uniform("centre"), static_cast<float>(0.5 * view.width), static_cast<float>(0.5 * view.height));
        glUniform1f(program.uniform("origin"), static_cast<float>(origin));
        glUniform1f(program.uniform("spacing"), static_cast<float>(spacing));
        glUniform2f(program.uniform("pixel_mm"), static_cast<float>(view.sensor_width_mm / view.width), static_cast<float>(view.sensor_height_mm / view.height));
        glUniform2f(program.uniform("roll"), static_cast<float>(std::cos(roll)), static_cast<float>(std::sin(roll)));
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, ghosts.get());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, target);
        glDispatchCompute(static_cast<GLuint>((width + 15) / 16), static_cast<GLuint>((height + 15) / 16), 1);
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    }

    // Smooth ghosts at a reduction: drawn on the reduced grid, then added upsampled into the image.
    void draw_reduced(const std::vector<float>& table, const measured::MeasuredView& view, double roll, const measured::ReducedGrid& grid) {
        const std::vector<float> zeros(static_cast<std::size_t>(grid.width) * static_cast<std::size_t>(grid.height) * 3, 0.0f);
        glBindBuffer(GL_SHADER_STORAGE_BUFFER, samples.get());
        glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(zeros.size() * sizeof(float)), zeros.data(), GL_STREAM_COPY);
        draw(table, view, roll, samples.get(), grid.width, grid.height, grid.pixel_of(0), grid.reduction);
        glUseProgram(upsample.get());
        glUniform2i(upsample.uniform("size"), view.width, view.height);
        glUniform2i(upsample.uniform("grid"), grid.width, grid.height);
        glUniform1f(upsample.uniform("reduction"), static_cast<float>(grid.reduction));
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, image.get());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, samples.get());
        glDispatchCompute(static_cast<GLuint>((view.width + 15) / 16), static_cast<GLuint>((view.height + 15) / 16), 1);
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
    std::array<std::vector<float>, 4> tables;  // by reduction 1, 2, 4, 8 (measured::reduction_for)
    for (const measured::GhostParams& p : measured::ghosts_at(lens, field, scale)) {
        const auto box = measured::ghost_box(p, roll, view);
        if (box[2] <= box[0] || box[3] <= box[1]) continue;
        const int reduction = measured::reduction_for(p, view);
        append_ghost(tables[static_cast<std::size_t>(std::countr_zero(static_cast<unsigned>(reduction)))], p, box);
    }
    if (std::all_of(tables.begin(), tables.end(), [](const auto& t) { return t.empty(); })) return;
    const std::size_t floats = static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height) * 3;
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, state_->image.get());
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(floats * sizeof(float)), rgb, GL_STREAM_COPY);
    if (!tables[0].empty()) state_->draw(tables[0], view, roll, state_->image.get(), view.width, view.height, 0.0, 1.0);
    for (std::size_t k = 1; k < tables.size(); ++k)
        if (!tables[k].empty()) state_->draw_reduced(tables[k], view, roll, measured::reduced_grid(view, 1 << k));
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, state_->image.get());
    glGetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(floats * sizeof(float)), rgb);
    check_gl("measured ghosts");
}

}  // namespace lensfx::gpu
