// GLSL of the lens-blur trace (renderer.cpp).
#pragma once

namespace lensfx::dof {

inline constexpr const char* kTraceShader = R"GLSL(
#version 430
layout(local_size_x = 8, local_size_y = 8) in;
// The trace runs as one dispatch per band and chunk of rays (renderer.cpp, "Loop budget"): what a pixel has
// gathered so far lives in these images between dispatches.
layout(rgba32f, binding = 0) uniform image2D result;      // the bands folded so far: R, G, B, alpha
layout(rgba32f, binding = 1) uniform image2D band_sum;    // this band's weighted sum of gathered colour
layout(r32f, binding = 2) uniform image2D band_weight_sum;  // and its sum of ray weights
layout(r32i, binding = 3) uniform iimage2D retry;         // 1: this pixel's last chunk ran out of loop budget
layout(std430, binding = 0) buffer Retries { uint retries; };  // how many pixels did
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
uniform int samples, chromatic, open_scene;
uniform int bands, achromatic;     // table channels (RGB's 3 or spectral bands), the one nearest 550 nm
uniform vec3 band_weight[128];     // what each band's gathered colour adds to R, G, B
uniform int band;                  // the band this dispatch traces
uniform int ray_first, ray_count;  // rays of each pixel this dispatch traces
uniform int fresh;                 // the band's first chunk (start from 0)
uniform sampler2D tile_rays;       // rays per pixel of each 8 x 8 work group (renderer.cpp tile_ray_counts)
uniform int retry_pass;            // only pixels marked in `retry`
uniform int budget_check;          // 2: the trip count of the loop that tells whether the budget ran out
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

// Whether llvmpipe's loop limiter ran out in this invocation: it shares one count of 65535 loop iterations
// among every loop of a shader invocation (per SIMD vector of pixels), and once it is spent every loop
// leaves after one iteration, silently. A loop of budget_check (2, a uniform so it is not unrolled)
// iterations then runs once. Never on a GPU without such a limiter.
bool budget_spent() {
    int n = 0;
    for (int i = 0; i < budget_check; ++i) ++n;
    return n < budget_check;
}

// This chunk of one band's rays at p, added to what the band gathered in earlier chunks (the weighted sum
// of RGBA, the sum of weights); false when the loop budget ran out on the way (nothing added then).
bool gather_chunk(vec2 p, int offset, int end, inout vec4 sum, inout float weight) {
    vec4 s = sum;
    float w_sum = weight;
    for (int k = ray_first; k < end; ++k) {
        vec4 line;
        float w = fetch_ray(band, p, (offset + k) % samples, line);
        if (w > 0.0) { s += w * trace(line); w_sum += w; }
    }
    if (budget_spent()) return false;
    sum = s, weight = w_sum;
    return true;
}

// The band's mean over its valid rays, into R, G, B by the band's weight (one blur for all: all three);
// alpha from the achromatic band.
void fold_band(ivec2 pix, vec4 sum, float weight, bool one_blur) {
    if (weight <= 0.0) return;
    vec4 mean = sum / weight, colour = imageLoad(result, pix);
    colour.rgb += (one_blur ? vec3(1.0) : band_weight[band]) * mean.rgb;
    if (band == achromatic) colour.a = mean.a;
    imageStore(result, pix, colour);
}

uint hash(uvec2 v) {
    uint h = v.x * 1664525u + v.y * 1013904223u;
    h ^= h >> 16; h *= 0x7feb352du; h ^= h >> 15; h *= 0x846ca68bu; h ^= h >> 16;
    return h;
}

void main() {
    ivec2 pix = ivec2(gl_GlobalInvocationID.xy);
    if (pix.x >= size.x || pix.y >= size.y) return;
    if (retry_pass != 0 && imageLoad(retry, pix).x == 0) return;
    int pixel_rays = int(texelFetch(tile_rays, pix / 8, 0).r);
    if (ray_first >= pixel_rays) return;  // this pixel's rays are all traced
    // the pixel's own chunk ends at its last ray, and the dispatch that traces that ray folds the band
    int end = min(ray_first + ray_count, pixel_rays);
    bool fold = end == pixel_rays;
    if (fresh == 0 && imageLoad(band_weight_sum, pix).x < 0.0) return;  // taken whole in the band's first chunk
    vec2 p = vec2(pix) + 0.5;
    int offset = int(hash(uvec2(pix + origin)) % uint(samples));  // as for the uncropped raster
    for (int k = 0; k < samples; ++k) {  // the first valid ray gives where the rays converge
        vec4 line;
        if (fetch_ray(achromatic, p, (offset + k) % samples, line) > 0.0) {
            vec4 colour;
            if (reach_px >= 0.0 && uniform_colour(line.xz + line.yw * focus_w, colour)) {
                imageStore(result, pix, colour);
                imageStore(band_weight_sum, pix, vec4(-1.0));  // the band's later chunks skip this pixel
                return;
            }
            break;
        }
    }
    // where every band's rays stay within chroma_tolerance of the achromatic band's, its rays serve all
    vec2 f = clamp((p + vec2(origin)) / cell, vec2(0.0), vec2(grid - 1));
    bool one_blur = chromatic == 0 || texelFetch(achromatic_cell, min(ivec2(f), grid - 2), 0).r > 0.5;
    if (one_blur && band != achromatic) return;
    vec4 sum = fresh != 0 ? vec4(0.0) : imageLoad(band_sum, pix);
    float weight = fresh != 0 ? 0.0 : imageLoad(band_weight_sum, pix).x;
    if (!gather_chunk(p, offset, end, sum, weight)) {  // kept as it was before this chunk; the renderer retries
        imageStore(retry, pix, ivec4(1));
        atomicAdd(retries, 1u);
    } else if (fold) {
        fold_band(pix, sum, weight, one_blur);
        return;
    }
    imageStore(band_sum, pix, sum);
    imageStore(band_weight_sum, pix, vec4(weight));
}
)GLSL";

}  // namespace lensfx::dof
