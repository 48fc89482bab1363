// The measured-lens renderer: a compute shader over the image, the ghosts' parameters in a buffer.
#include <gpu/measured_renderer.h>

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
uniform ivec2 size;
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
    float xs = (float(px.x) + 0.5 - 0.5 * float(size.x)) * pixel_mm.x;
    float ys = (0.5 * float(size.y) - (float(px.y) + 0.5)) * pixel_mm.y;
    float u0 = xs * roll.x + ys * roll.y;
    float v = abs(-xs * roll.y + ys * roll.x);
    vec3 sum = vec3(0.0);
    for (int g = 0; g < ghost_count; ++g) {
        int base = g * STRIDE;
        if (float(px.x) < ghost[base + 16] || float(px.y) < ghost[base + 17] || float(px.x) >= ghost[base + 18] || float(px.y) >= ghost[base + 19]) continue;
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

}  // namespace

struct MeasuredRenderer::State {
    Program program{"measured.comp", {{ShaderStage::Type::Compute, kMeasuredShader}}};
    GlObject ghosts = GlObject::buffer();
    GlObject image = GlObject::buffer();
};

MeasuredRenderer::MeasuredRenderer(const Context& context) {
    context.make_current();
    state_ = std::make_unique<State>();
}

MeasuredRenderer::~MeasuredRenderer() = default;

void MeasuredRenderer::render_add(const measured::MeasuredLens& lens, const measured::MeasuredView& view, std::array<double, 3> scale, float* rgb) {
    const auto [field, roll] = measured::field_and_roll(view.angle_x_deg, view.angle_y_deg);
    std::vector<float> table;
    for (const measured::MeasuredGhost& g : lens.ghosts) {
        if (!g.covers(field)) continue;
        measured::GhostParams p = g.at(field);
        for (int c = 0; c < 3; ++c) p[measured::kBorderR + c] *= scale[static_cast<std::size_t>(c)], p[measured::kInsideR + c] *= scale[static_cast<std::size_t>(c)];
        const auto box = measured::ghost_box(p, roll, view);
        if (box[2] <= box[0] || box[3] <= box[1]) continue;
        for (double v : p) table.push_back(static_cast<float>(v));
        for (int b : box) table.push_back(static_cast<float>(b));
    }
    if (table.empty()) return;
    const std::size_t floats = static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height) * 3;
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, state_->ghosts.get());
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(table.size() * sizeof(float)), table.data(), GL_STREAM_DRAW);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, state_->image.get());
    glBufferData(GL_SHADER_STORAGE_BUFFER, static_cast<GLsizeiptr>(floats * sizeof(float)), rgb, GL_STREAM_COPY);
    glUseProgram(state_->program.get());
    glUniform1i(state_->program.uniform("ghost_count"), static_cast<GLint>(table.size() / 20));
    glUniform2i(state_->program.uniform("size"), view.width, view.height);
    glUniform2f(state_->program.uniform("pixel_mm"), static_cast<float>(view.sensor_width_mm / view.width),
                static_cast<float>(view.sensor_height_mm / view.height));
    glUniform2f(state_->program.uniform("roll"), static_cast<float>(std::cos(roll)), static_cast<float>(std::sin(roll)));
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, state_->ghosts.get());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, state_->image.get());
    glDispatchCompute(static_cast<GLuint>((view.width + 15) / 16), static_cast<GLuint>((view.height + 15) / 16), 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, state_->image.get());
    glGetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, static_cast<GLsizeiptr>(floats * sizeof(float)), rgb);
    check_gl("measured ghosts");
}

}  // namespace lensfx::gpu
