// GLSL of the lens-blur trace (renderer.cpp).
#pragma once

namespace lensfx::dof {

inline constexpr const char* kTraceShader = R"GLSL(
#version 430
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) writeonly uniform image2D result;
uniform sampler2D hiz;            // (lowest, highest) inverse depth per cell, one mip level per hierarchy level
uniform sampler2DArray layer_w;   // (1/front, 1/back); front < 0: no surface here or in later layers
uniform sampler2DArray layer_rgba;
uniform sampler2DArray ray_line;  // (cx, ax, cy, ay): pixel(w) = c + a w; x sample, y grid point, layer band;
                                  // cx = -1e30: the ray is stopped
uniform sampler2D colour_min, colour_max;  // per cell of colour_level, the range of every layer's RGBA
uniform int colour_level;
uniform float reach_px, focus_w;           // the widest blur radius of the frame, the focused depth
uniform sampler2D achromatic_cell;         // per cell of the table's grid: 1 where the bands' rays are one
uniform ivec2 origin;                      // the layers' pixel (0, 0) in the table's raster
uniform ivec2 size;
uniform int layer_count, top_level, start_level, max_iterations;
uniform float w_near, w_far;
uniform int samples, rays, chromatic, open_scene;
uniform int bands, achromatic;     // table channels (RGB's 3 or spectral bands), the one nearest 550 nm
uniform vec3 band_weight[128];     // what each band's gathered colour adds to R, G, B
uniform ivec2 grid;
uniform vec2 cell;

ivec2 clamp_cell(ivec2 c, int level) {
    ivec2 n = (size + ivec2((1 << level) - 1)) >> level;
    return clamp(c, ivec2(0), n - 1);
}

// Each corner's ray relative to its grid point, moved to p (lens_rays.cpp ray_at): a sample that passes at
// some corners only still converges on this pixel. p in the layers' pixels, the line too.
float fetch_ray(int ch, vec2 p, int s, out vec4 line) {
    p += vec2(origin);
    vec2 f = clamp(p / cell, vec2(0.0), vec2(grid - 1));
    ivec2 g0 = min(ivec2(f), grid - 2);
    vec2 t = f - vec2(g0);
    line = vec4(0.0);
    float weight = 0.0;
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec3 at = ivec3(s, (g0.y + j) * grid.x + g0.x + i, ch);
            vec4 l = texelFetch(ray_line, at, 0);
            if (l.x < -1e29) continue;
            float w = (i == 1 ? t.x : 1.0 - t.x) * (j == 1 ? t.y : 1.0 - t.y);
            vec2 g = vec2(g0 + ivec2(i, j)) * cell;
            line += w * (l - vec4(g.x, 0.0, g.y, 0.0));
            weight += w;
        }
    }
    if (weight > 0.0) line = line / weight + vec4(f.x * cell.x - float(origin.x), 0.0, f.y * cell.y - float(origin.y), 0.0);
    return weight;
}

vec4 farthest(ivec2 c) {
    ivec2 px = clamp_cell(c, 0);
    vec4 colour = vec4(0.0);
    for (int k = 0; k < layer_count; ++k) {
        if (texelFetch(layer_w, ivec3(px, k), 0).x < 0.0) break;
        colour = texelFetch(layer_rgba, ivec3(px, k), 0);
    }
    return colour;
}

// Premultiplied colour and alpha a lens ray gathers; a flat scene's surfaces are opaque whatever their alpha.
vec4 trace(vec4 l) {
    vec2 c = l.xz, a = l.yw;
    // w falls along the ray, so it moves along -a on screen
    ivec2 st = ivec2(a.x > 0.0 ? -1 : 1, a.y > 0.0 ? -1 : 1);
    vec2 far_side = vec2(st.x > 0 ? 1.0 : 0.0, st.y > 0 ? 1.0 : 0.0);
    float w = w_near;
    int level = min(start_level, top_level);
    vec2 nudge = vec2(0.0);
    vec4 acc = vec4(0.0);
    float trans = 1.0;
    bool opaque = false;  // no early return inside the loops: llvmpipe's SIMD lanes (see docs/dof.md)
    for (int it = 0; it < max_iterations; ++it) {
        float cs = float(1 << level);
        vec2 p = c + a * w + nudge;
        ivec2 cid = ivec2(floor(p / cs));
        vec2 bound = (vec2(cid) + far_side) * cs;
        float wx = a.x != 0.0 ? (bound.x - c.x) / a.x : -1e30;
        float wy = a.y != 0.0 ? (bound.y - c.y) / a.y : -1e30;
        float w_exit = max(max(wx, wy), w_far);
        // Stingray: offset only along the axis whose plane is crossed, so the next cell is always entered
        vec2 cross_offset = wx >= wy ? vec2(float(st.x) * 1e-3, 0.0) : vec2(0.0, float(st.y) * 1e-3);
        vec2 mm = texelFetch(hiz, clamp_cell(cid, level), level).xy;
        if (w_exit > mm.y || w < mm.x) {  // wholly in front of or behind every surface of the cell
            if (w_exit <= w_far) break;
            w = w_exit;
            nudge = cross_offset;
            level = min(level + 1, top_level);
            continue;
        }
        if (level > 0) {
            if (mm.y < w) { w = mm.y; nudge = vec2(0.0); }  // clamp the ray to the cell's depth range
            --level;
            continue;
        }
        ivec2 px = clamp_cell(cid, 0);
        for (int k = 0; k < layer_count; ++k) {
            vec2 fb = texelFetch(layer_w, ivec3(px, k), 0).xy;
            if (fb.x < 0.0) break;
            if (w_exit > fb.x || w < fb.y) continue;
            vec4 colour = texelFetch(layer_rgba, ivec3(px, k), 0);
            acc += trans * colour;
            trans *= open_scene != 0 ? 1.0 - colour.a : 0.0;
            if (trans < 1e-3) {
                opaque = true;
                break;
            }
        }
        if (opaque || w_exit <= w_far) break;
        w = w_exit;
        nudge = cross_offset;
        level = min(1, top_level);  // floating cells: a miss climbs one level only
    }
    if (opaque || open_scene != 0) return acc;
    return acc + trans * farthest(ivec2(floor(c + a * max(w, w_far))));
}

// Whether every surface any ray of this pixel can reach has one colour (then that is the pixel's): the
// rays converge on `centre` at the focused depth and spread at most reach_px from it.
bool uniform_colour(vec2 centre, out vec4 colour) {
    float r = reach_px + 4.0;
    int level = colour_level;  // renderer.cpp: cells of at least 2 r + 2, so at most 2 x 2 of them
    float cs = float(1 << level);
    ivec2 a = clamp_cell(ivec2(floor((centre - r) / cs)), level), b = clamp_cell(ivec2(floor((centre + r) / cs)), level);
    vec4 lo = vec4(1e30), hi = vec4(-1e30);
    for (int y = a.y; y <= b.y; ++y) {
        for (int x = a.x; x <= b.x; ++x) {
            lo = min(lo, texelFetch(colour_min, ivec2(x, y), 0));
            hi = max(hi, texelFetch(colour_max, ivec2(x, y), 0));
        }
    }
    colour = lo;
    return (open_scene == 0 || lo.a >= 1.0) && all(lessThanEqual(hi - lo, 1e-6 * (vec4(1.0) + abs(hi))));
}

// Each band's mean over its valid rays, into R, G, B by the band's weights; alpha with the achromatic
// band's rays; without chromatic blur the achromatic band's rays for everything.
vec4 band_pixel(vec2 p, int offset, int chromatic) {
    vec4 colour = vec4(0.0);
    for (int b = 0; b < bands; ++b) {
        if (chromatic == 0 && b != achromatic) continue;
        vec4 sum = vec4(0.0);
        float weight = 0.0;
        for (int k = 0; k < rays; ++k) {
            vec4 line;
            float w = fetch_ray(b, p, (offset + k) % samples, line);
            if (w > 0.0) { sum += w * trace(line); weight += w; }
        }
        if (weight <= 0.0) continue;
        vec4 mean = sum / weight;
        colour.rgb += (chromatic != 0 ? band_weight[b] : vec3(1.0)) * mean.rgb;
        if (b == achromatic) colour.a = mean.a;
    }
    return colour;
}

uint hash(uvec2 v) {
    uint h = v.x * 1664525u + v.y * 1013904223u;
    h ^= h >> 16; h *= 0x7feb352du; h ^= h >> 15; h *= 0x846ca68bu; h ^= h >> 16;
    return h;
}

void main() {
    ivec2 pix = ivec2(gl_GlobalInvocationID.xy);
    if (pix.x >= size.x || pix.y >= size.y) return;
    vec2 p = vec2(pix) + 0.5;
    int offset = int(hash(uvec2(pix + origin)) % uint(samples));  // as for the uncropped raster
    for (int k = 0; k < samples; ++k) {  // the first valid ray gives where the rays converge
        vec4 line;
        if (fetch_ray(achromatic, p, (offset + k) % samples, line) > 0.0) {
            vec4 colour;
            if (reach_px >= 0.0 && uniform_colour(line.xz + line.yw * focus_w, colour)) {
                imageStore(result, pix, colour);
                return;
            }
            break;
        }
    }
    // where every band's rays stay within chroma_tolerance of the achromatic band's, its rays serve all
    vec2 f = clamp((p + vec2(origin)) / cell, vec2(0.0), vec2(grid - 1));
    bool one_blur = texelFetch(achromatic_cell, min(ivec2(f), grid - 2), 0).r > 0.5;
    vec4 colour = band_pixel(p, offset, chromatic != 0 && !one_blur ? 1 : 0);
    imageStore(result, pix, colour);
}
)GLSL";

}  // namespace lensfx::dof
