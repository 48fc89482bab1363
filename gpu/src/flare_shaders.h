// GLSL sources of the ghost renderer: the bundle tracer (compute) and the grid rasteriser (vertex +
// fragment), which draws a ghost's small triangles apart. Data layouts match flare_renderer.cpp.
#pragma once

namespace lensfx::gpu::shaders {

// A ghost of a batched draw (FlareRenderer's faint ghosts of a pass: per grid and level one trace and one
// shade dispatch, the work group's z naming the ghost from first_job on, and one indexed draw): what its own
// uniforms say when drawn alone. Inserted after each batched shader's #version line (GhostJob in
// flare_renderer.cpp has the same layout).
inline constexpr const char* ghost_job_glsl = R"GLSL(
// GhostJob: steps (first step, step count, first vertex, stop crossings), rect (entrance-plane rectangle x0, y0,
// x1, y1, mm), channels (what it adds to R, G, B), flux (triangle flux, offset x, offset y (mm), 0).
// The jobs, each four texels of a buffer texture (cheaper than buffer loads on llvmpipe): its steps read as integers,
// its rectangle, channels and flux as floats.
uniform isamplerBuffer job_ints;
uniform samplerBuffer job_floats;
ivec4 job_steps(int j) { return texelFetch(job_ints, 4 * j); }
vec4 job_rect(int j) { return texelFetch(job_floats, 4 * j + 1); }
vec4 job_channels(int j) { return texelFetch(job_floats, 4 * j + 2); }
vec4 job_flux(int j) { return texelFetch(job_floats, 4 * j + 3); }
uniform bool batched;  // the ghost's data from its job (the work group's z or the vertex), not the uniforms
uniform int first_job; // batched: the dispatch's or draw's first ghost among the jobs
)GLSL";

// The grid vertex a compute invocation takes (inserted after ghost_job_glsl in the trace and shade passes;
// work groups of 8 x 8, dispatched as FlareRenderer's vertex_groups along x): a ghost's work groups (batched:
// its z) run along its vertices row after row, so that no 8-wide row of a group is left mostly idle past the
// grid's edge (a grid of 8 is 9 x 9 vertices: 18 such rows in 2 x 2 groups, 11 in a row; of 16, 51 and 37).
// Beyond the last vertex: a row past the grid.
inline constexpr const char* grid_vertex_glsl = R"GLSL(
uvec2 grid_vertex(int grid) {
    uint side = uint(grid + 1);
    uint index = gl_WorkGroupID.x * 64u + gl_LocalInvocationIndex;
    return uvec2(index % side, index / side);
}

// A batched dispatch's ghost: the work group's z from first_job on.
int batch_job() { return first_job + int(gl_WorkGroupID.z); }
)GLSL";

// One invocation per grid vertex. Steps: geom = (vertex z, curvature, conic, semi-diameter),
// media = (n_in, n_out, kind 0 refract / 1 reflect / 2 stop + 4 x its factor table, forward 1 / backward 0).
// Output per vertex:
// (sensor x, sensor y, r_rel, factor), (stop uv 0, stop uv 1), (stop uv 2, valid, 0).
inline constexpr const char* ghost_trace_comp = R"GLSL(
#version 430
layout(local_size_x = 8, local_size_y = 8) in;
struct StepData { vec4 geom; vec4 media; };
uniform samplerBuffer step_texels;    // the steps, two texels each (geom, media)
uniform samplerBuffer factor_texels;  // the factor tables
layout(std430, binding = 2) writeonly buffer Vertices { vec4 vertices[]; };
uniform int step_offset;  // this ghost's first step (two texels each in step_texels)
uniform int step_count;
uniform uint vertex_offset;  // this ghost's first vertex in vertices[]
uniform int grid;
uniform vec4 rect;       // entrance plane z = 0: x0, y0, x1, y1 (mm), in a frame turned by rect_rotation
uniform vec2 rect_rotation;  // (cos, sin) of the frame's angle: bounds-table rectangles of a turned light
uniform vec3 direction;  // unit, towards +z
uniform float sensor_z;
uniform int table_size;

float factor(int table, float cos_i) {
    float x = clamp(cos_i, 0.0, 1.0) * float(table_size - 1);
    int i = min(int(x), table_size - 2);
    float f = x - float(i);
    int base = table * table_size;
    return mix(texelFetch(factor_texels, base + i).r, texelFetch(factor_texels, base + i + 1).r, f);
}

void main() {
    uvec2 id = grid_vertex(grid);
    if (id.x > uint(grid) || id.y > uint(grid)) return;
    int first_step = batched ? job_steps(batch_job()).x : step_offset;
    int steps_n = batched ? job_steps(batch_job()).y : step_count;
    uint first_vertex = batched ? uint(job_steps(batch_job()).z) : vertex_offset;
    vec4 box = batched ? job_rect(batch_job()) : rect;
    vec2 f = vec2(id) / float(grid);
    vec2 q = mix(box.xy, box.zw, f);
    vec3 o = vec3(rect_rotation.x * q.x - rect_rotation.y * q.y, rect_rotation.y * q.x + rect_rotation.x * q.y, 0.0);
    vec3 d = direction;
    float r_rel = 0.0;
    float transmission = 1.0;
    vec2 uv[3] = vec2[3](vec2(0.0), vec2(0.0), vec2(0.0));
    int crossings = 0;
    bool ok = true;
    for (int s = 0; s < steps_n; ++s) {
        vec4 geom = texelFetch(step_texels, 2 * (first_step + s));
        vec4 media = texelFetch(step_texels, 2 * (first_step + s) + 1);
        vec3 p = o - vec3(0.0, 0.0, geom.x);
        float c = geom.y;
        float k1 = 1.0 + geom.z;
        float t;
        if (c == 0.0) {
            if (abs(d.z) < 1e-9) { ok = false; break; }
            t = -p.z / d.z;
        } else {
            // c (x^2 + y^2 + (1+k) z^2) - 2 z = 0, root on the cap through the vertex for this travel direction.
            float A = c * (d.x * d.x + d.y * d.y + k1 * d.z * d.z);
            float B = c * (p.x * d.x + p.y * d.y + k1 * p.z * d.z) - d.z;
            float C = c * (p.x * p.x + p.y * p.y + k1 * p.z * p.z) - 2.0 * p.z;
            float disc = B * B - A * C;
            if (disc < 0.0) { ok = false; break; }
            float sign_b = media.w > 0.5 ? -1.0 : 1.0;
            float den = -B - sign_b * sqrt(disc);
            if (abs(den) < 1e-20) { ok = false; break; }
            t = C / den;
        }
        p += t * d;
        vec3 hit = p + vec3(0.0, 0.0, geom.x);
        o = hit;
        int code = int(media.z + 0.5);
        int kind = code & 3;
        if (kind == 2) {
            if (crossings < 3) uv[crossings] = hit.xy / geom.w;
            crossings += 1;
            continue;
        }
        if (geom.w > 0.0) r_rel = max(r_rel, length(hit.xy) / geom.w);
        vec3 n = c == 0.0 ? vec3(0.0, 0.0, -1.0) : normalize(vec3(c * p.x, c * p.y, k1 * c * p.z - 1.0));
        float cos_i = dot(n, d);
        if (cos_i > 0.0) n = -n; else cos_i = -cos_i;
        transmission *= factor(code >> 2, cos_i);
        if (kind == 1) {
            d = d - 2.0 * dot(d, n) * n;
        } else {
            float eta = media.x / media.y;
            float k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
            if (k < 0.0) { ok = false; break; }
            d = normalize(eta * d + (eta * cos_i - sqrt(k)) * n);
        }
    }
    vec2 sensor = vec2(0.0);
    if (ok) {
        if (d.z <= 1e-9) ok = false;
        else sensor = (o + ((sensor_z - o.z) / d.z) * d).xy;
    }
    if (!ok || any(isnan(sensor)) || any(isinf(sensor)) || isnan(transmission)) {
        ok = false;
        sensor = vec2(0.0);
    }
    uint index = first_vertex + id.y * uint(grid + 1) + id.x;
    vertices[3u * index + 0u] = vec4(sensor, r_rel, transmission);
    vertices[3u * index + 1u] = vec4(uv[0], uv[1]);
    vertices[3u * index + 2u] = vec4(uv[2], ok ? 1.0 : 0.0, 0.0);
}
)GLSL";

// One invocation per grid vertex, after the trace: the vertex's irradiance for Gouraud shading (flare paper
// 4.3, "Smooth shading"), the average over the rasterised triangles around it (of the six, those whose rays
// got through and that are not small: rasterisable), weighted by their sensor areas: (triangles) / (their
// summed sensor area), per unit triangle flux. Since each triangle's Gouraud integral is its area x the mean
// of its corners, the rasterised triangles' drawn power sums to exactly their flux (a small neighbour,
// counted in, lent its tiny area to the vertex and so raised its rasterised neighbours' light). Written
// into the vertex's spare fourth float; 0 where no triangle touches it. Also, for the cell whose first
// corner this vertex is, which of its four neighbours is dropped (a corner's ray failed): bits 1 below,
// 2 right, 4 above, 8 left, and for a ghost drawn reduced which of its two triangles reach the rim band
// (16 lower, 32 upper; near_rim, once per triangle here rather than at each of its vertices in the rim
// pass, where it cost more than the pass's fill), added to the valid flag as bits / 1024 (still > 0.5: valid).
inline constexpr const char* ghost_shade_comp = R"GLSL(
#version 430
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 2) buffer Vertices { vec4 vertices[]; };  // written here; read by vertex_texel
uniform samplerBuffer vertex_texels;  // the same buffer, read by texel fetches (cheaper on llvmpipe than buffer loads)
vec4 vertex_texel(uint i) { return texelFetch(vertex_texels, int(i)); }
uniform int grid;
uniform uint vertex_offset;
uniform float small_area;     // mm^2: triangles under this (a pixel of the level) are small: not rasterised
uniform float sliver_height;  // mm: nor those thinner than this across their longest edge (0: any)
uniform float sliver_area;    // mm^2: ... and under this in area
uniform vec2 pixels_per_mm;  // of the rim pass's target (a ghost drawn reduced); 0: no rim pass
uniform float rim_band;      // pixels of that target: the band along the rim the rim pass draws
uniform sampler2D iris_sdf;  // signed distance in stop radii over [-extent, extent]^2
uniform float iris_extent;
uniform int stop_crossings;
uniform bool ringing;
uniform uint first_index;  // where the dispatch's (first) ghost's triangles go in indices[]
uniform bool write_indices;     // point-sampled: its rasterised triangles written to indices[] (write_cell_indices)
uniform bool mark_inside_iris;  // drawn by them without a rim pass: its vertices inside the iris marked (bit 64)
// Drawn by them without a rim pass: its interior triangles (no cut reaches their pixels) written apart, interior_offset
// indices after the others, for a draw that shades them without looking at the cuts (ghost_raster_frag's INTERIOR)
uniform bool split_interior;
uniform uint interior_offset;
uniform vec2 level_pixels_per_mm;  // of the target the ghost is drawn into
layout(std430, binding = 4) writeonly buffer Indices { uint indices[]; };  // the rasterised triangles
// A ghost drawn with its small triangles apart (list_small) lists them, work group by work group: group k's
// in small_list[small_first + 128 k...] and the draw command commands[command_first + k] that draws them
// (glMultiDrawArraysIndirect; ghost_raster_vert's SMALL_TRIANGLES reads the list), so that draw shades only
// them, not every triangle of the grid (a vertex is shaded on one thread on llvmpipe).
uniform bool list_small;
uniform uint small_first;
uniform uint command_first;
layout(std430, binding = 5) writeonly buffer SmallList { uint small_list[]; };
struct DrawCommand {
    uint count, instances, first, base_instance;
};
layout(std430, binding = 6) writeonly buffer Commands { DrawCommand commands[]; };
const uint kNoTriangle = 0xffffffffu;
shared uint group_small[128];  // the work group's triangles, two per invocation's cell: small, or kNoTriangle
uint first = 0u;   // this ghost's first vertex and stop crossings (vertex_offset, stop_crossings or its job)
int crossings = 0;

bool valid(uint i) { return vertex_texel(3u * i + 2u).z > 0.5; }

// Vertex i's coordinates at the iris at its stop crossing c (ghost_trace_comp's layout).
vec2 stop_uv(uint i, int c) {
    vec4 s = vertex_texel(3u * i + 1u);
    return c == 0 ? s.xy : c == 1 ? s.zw : vertex_texel(3u * i + 2u).xy;
}

bool cell_valid(int cx, int cy) {
    if (cx < 0 || cy < 0 || cx >= grid || cy >= grid) return true;  // beyond the grid: no cut of its own
    uint stride = uint(grid + 1);
    uint a = first + uint(cy) * stride + uint(cx);
    return valid(a) && valid(a + 1u) && valid(a + stride + 1u) && valid(a + stride);
}

// Signed distances (pixels, positive where f < 0) of the corners p to where f, linear over the
// triangle, is 0.
vec3 corner_distances(vec2 p0, vec2 p1, vec2 p2, vec3 f) {
    vec2 e1 = p1 - p0;
    vec2 e2 = p2 - p0;
    float det = e1.x * e2.y - e1.y * e2.x;
    if (abs(det) < 1e-12) return vec3(0.0);  // degenerate: kept
    vec2 g = vec2((f.y - f.x) * e2.y - (f.z - f.x) * e1.y, (f.z - f.x) * e1.x - (f.y - f.x) * e2.x) / det;
    float len = length(g);
    if (len < 1e-20) return vec3(f.x < 0.0 ? 1e9 : -1e9);
    return -f / len;
}

// Whether part of the triangle lies within the rim band (3 reduced pixels) and inside the ghost: the
// distances are linear over the triangle, so corners all deeper than the band, or all beyond one edge of
// the ghost, settle it.
bool near_rim(uvec3 i, int outer) {
    vec2 p0 = vertex_texel(3u * i.x).xy * pixels_per_mm;
    vec2 p1 = vertex_texel(3u * i.y).xy * pixels_per_mm;
    vec2 p2 = vertex_texel(3u * i.z).xy * pixels_per_mm;
    vec3 d = corner_distances(p0, p1, p2, vec3(vertex_texel(3u * i.x).z, vertex_texel(3u * i.y).z, vertex_texel(3u * i.z).z) - 1.0);
    bool outside = all(lessThan(d, vec3(-1.0)));
    vec3 nearest = d;
    for (int c = 0; c < 3 && c < crossings && !ringing; ++c) {
        vec2 uv[3] = vec2[3](stop_uv(i.x, c), stop_uv(i.y, c), stop_uv(i.z, c));
        vec3 f = vec3(textureLod(iris_sdf, uv[0] / (2.0 * iris_extent) + 0.5, 0.0).r,
                      textureLod(iris_sdf, uv[1] / (2.0 * iris_extent) + 0.5, 0.0).r,
                      textureLod(iris_sdf, uv[2] / (2.0 * iris_extent) + 0.5, 0.0).r);
        vec3 ds = corner_distances(p0, p1, p2, f);
        outside = outside || all(lessThan(ds, vec3(-1.0)));
        nearest = min(nearest, ds);
    }
    if (outside) return false;
    return outer != 0 || any(lessThan(nearest, vec3(rim_band)));
}

// Whether every point of the triangles round vertex me (at (cx, cy) of the grid) lies inside the iris at each
// of the ghost's stop crossings, so that their pixels need not look the iris up (ghost_raster_frag's INDEXED
// draw): the iris texture's bilinear SDF changes by at most sqrt(2) x the distance, so its value at me must be
// below -1.5 x the farthest valid neighbour's distance at that crossing (a triangle with a lost corner is not
// drawn). Never with ringing, whose transmission varies inside the iris too.
bool fan_inside_iris(uint me, int cx, int cy) {
    if (ringing) return false;
    uint stride = uint(grid + 1);
    for (int c = 0; c < 3 && c < crossings; ++c) {
        vec2 uv = stop_uv(me, c);
        float reach = 0.0;
        for (int y = max(cy - 1, 0); y <= min(cy + 1, grid); ++y)
            for (int x = max(cx - 1, 0); x <= min(cx + 1, grid); ++x) {
                uint n = first + uint(y) * stride + uint(x);
                if (valid(n)) reach = max(reach, distance(stop_uv(n, c), uv));
            }
        if (!(textureLod(iris_sdf, uv / (2.0 * iris_extent) + 0.5, 0.0).r < -1.5 * reach - 1e-3)) return false;
    }
    return true;
}

float triangle_area(uint a, uint b, uint c) {
    vec2 e1 = vertex_texel(3u * b).xy - vertex_texel(3u * a).xy;
    vec2 e2 = vertex_texel(3u * c).xy - vertex_texel(3u * a).xy;
    return 0.5 * abs(e1.x * e2.y - e1.y * e2.x);
}

// Whether pixel centres sample a triangle well enough to rasterise it: at least small_area, and at least
// sliver_height across its longest edge or at least sliver_area. The others, sub-pixel or slivers (where the grid crowds along a rim
// or a caustic), are drawn apart with area coverage (ghost_raster_vert's SMALL_TRIANGLES), or for a faint ghost
// left out.
bool rasterisable(uint a, uint b, uint c) {
    float area = triangle_area(a, b, c);
    vec2 pa = vertex_texel(3u * a).xy, pb = vertex_texel(3u * b).xy, pc = vertex_texel(3u * c).xy;
    float longest = max(max(distance(pa, pb), distance(pb, pc)), distance(pc, pa));
    return area >= small_area && (2.0 * area >= sliver_height * longest || area >= sliver_area);
}

// Whether no pixel of triangle i reaches the lens's rims: r_rel, linear over it as the raster interpolates it, at
// least kInteriorPx pixels of the level inside r_rel = 1 at every corner, so that the raster's share of each pixel
// inside the rim (ghost_raster_frag's inside_share, a ramp one pixel wide) is 1 and nothing is discarded.
const float kInteriorPx = 0.6;
bool inside_rims(uvec3 i) {
    vec2 p0 = vertex_texel(3u * i.x).xy * level_pixels_per_mm;
    vec2 p1 = vertex_texel(3u * i.y).xy * level_pixels_per_mm;
    vec2 p2 = vertex_texel(3u * i.z).xy * level_pixels_per_mm;
    vec3 d = corner_distances(p0, p1, p2, vec3(vertex_texel(3u * i.x).z, vertex_texel(3u * i.y).z, vertex_texel(3u * i.z).z) - 1.0);
    return all(greaterThanEqual(d, vec3(kInteriorPx)));
}

// The rasterised triangles of the cell at id: each of the cell's two, split as ghost_grid_glsl's, where it is
// rasterised (corners valid, not all beyond the apertures, rasterisable), else a point (a, a, a), which
// draws nothing. ghost_raster_vert's INDEXED draw draws them, shading each grid vertex once; the per-triangle
// draws (the rim passes, the small triangles) read here which triangles are rasterised (ghost_grid_glsl's
// rasterised), so that a triangle is rasterised or drawn as small by one decision.
// With split_interior, a rasterised triangle that no cut reaches goes to the interior list instead (a point in
// the first): inside the rims (inside_rims) and with its provoking vertex (its last corner: the lower triangle's at
// (x+1, y+1), the upper's at (x, y+1)) marked inside the iris, whose read the INDEXED draw would skip there too.
void write_cell_indices(uvec2 id) {
    uint stride = uint(grid + 1);
    uint a = first + id.y * stride + id.x;
    uint cells = uint(grid * grid);
    uint at = first_index + 6u * (uint(gl_WorkGroupID.z) * cells + id.y * uint(grid) + id.x);
    uvec3 tri[2] = uvec3[2](uvec3(a, a + 1u, a + stride + 1u), uvec3(a, a + stride + 1u, a + stride));
    ivec2 provoking[2] = ivec2[2](ivec2(id) + ivec2(1, 1), ivec2(id) + ivec2(0, 1));
    for (int t = 0; t < 2; ++t) {
        uvec3 i = tri[t];
        bool clipped = vertex_texel(3u * i.x).z > 1.0 && vertex_texel(3u * i.y).z > 1.0 && vertex_texel(3u * i.z).z > 1.0;
        bool kept = valid(i.x) && valid(i.y) && valid(i.z) && !clipped && rasterisable(i.x, i.y, i.z);
        bool interior = split_interior && kept && inside_rims(i) && fan_inside_iris(i.z, provoking[t].x, provoking[t].y);
        uvec3 drawn = kept && !interior ? i : uvec3(a);
        indices[at + 3u * uint(t)] = drawn.x;
        indices[at + 3u * uint(t) + 1u] = drawn.y;
        indices[at + 3u * uint(t) + 2u] = drawn.z;
        if (!split_interior) continue;
        uvec3 inner = interior ? i : uvec3(a);
        indices[interior_offset + at + 3u * uint(t)] = inner.x;
        indices[interior_offset + at + 3u * uint(t) + 1u] = inner.y;
        indices[interior_offset + at + 3u * uint(t) + 2u] = inner.z;
    }
}

// Whether triangle i is small: drawn apart (corners valid, not all beyond the apertures, not rasterisable).
bool small_triangle(uvec3 i) {
    bool clipped = vertex_texel(3u * i.x).z > 1.0 && vertex_texel(3u * i.y).z > 1.0 && vertex_texel(3u * i.z).z > 1.0;
    return valid(i.x) && valid(i.y) && valid(i.z) && !clipped && !rasterisable(i.x, i.y, i.z);
}

// The work group's small triangles listed in order (triangle 2 cell + 0 lower, + 1 upper: ghost_grid_glsl's
// triangle_corners) and its draw command written, by its first invocation once every invocation has said
// which of its cell's two are small. Called by every invocation (the barrier).
void list_small_triangles(uvec2 id) {
    uint local = gl_LocalInvocationIndex;
    bool cell = id.x < uint(grid) && id.y < uint(grid);
    uint stride = uint(grid + 1);
    uint a = first + id.y * stride + id.x;
    uint number = 2u * (id.y * uint(grid) + id.x);
    group_small[2u * local] = cell && small_triangle(uvec3(a, a + 1u, a + stride + 1u)) ? number : kNoTriangle;
    group_small[2u * local + 1u] = cell && small_triangle(uvec3(a, a + stride + 1u, a + stride)) ? number + 1u : kNoTriangle;
    memoryBarrierShared();
    barrier();
    if (local != 0u) return;
    uint slot = 128u * gl_WorkGroupID.x;
    uint n = 0u;
    for (uint k = 0u; k < 128u; ++k)
        if (group_small[k] != kNoTriangle) small_list[small_first + slot + n++] = group_small[k];
    commands[command_first + gl_WorkGroupID.x] = DrawCommand(3u * n, 1u, 3u * slot, 0u);
}

void main() {
    uvec2 id = grid_vertex(grid);
    first = batched ? uint(job_steps(batch_job()).z) : vertex_offset;
    crossings = batched ? job_steps(batch_job()).w : stop_crossings;
    if (list_small) list_small_triangles(id);  // before any invocation leaves: it waits for them all
    if (id.x > uint(grid) || id.y > uint(grid)) return;
    if (write_indices && id.x < uint(grid) && id.y < uint(grid)) write_cell_indices(id);
    uint stride = uint(grid + 1);
    float area = 0.0;
    float triangles = 0.0;
    // The triangles with this corner (ghost_grid_glsl's split): of the cell at (x, y) both, of (x-1, y) the
    // lower, of (x-1, y-1) both, of (x, y-1) the upper. Left out: those whose rays failed and the small ones.
    const ivec3 around[6] = ivec3[6](ivec3(0, 0, 0), ivec3(0, 0, 1), ivec3(-1, 0, 0), ivec3(-1, -1, 0), ivec3(-1, -1, 1),
                                     ivec3(0, -1, 1));
    for (int k = 0; k < 6; ++k) {
        int cx = int(id.x) + around[k].x;
        int cy = int(id.y) + around[k].y;
        if (cx < 0 || cy < 0 || cx >= grid || cy >= grid) continue;
        uint a = first + uint(cy) * stride + uint(cx);
        uint b = around[k].z == 0 ? a + 1u : a + stride + 1u;
        uint c = around[k].z == 0 ? a + stride + 1u : a + stride;
        if (!(valid(a) && valid(b) && valid(c))) continue;
        if (!rasterisable(a, b, c)) continue;
        float t = triangle_area(a, b, c);
        area += t;
        triangles += 1.0;
    }
    uint me = first + id.y * stride + id.x;
    vertices[3u * me + 2u].w = area > 0.0 ? triangles / area : 0.0;
    if (!valid(me)) return;
    int cx = int(id.x), cy = int(id.y);
    int bits = mark_inside_iris && fan_inside_iris(me, cx, cy) ? 64 : 0;
    // A batched (faint) ghost has no rim pass: no edge bits.
    if (!batched && cx < grid && cy < grid && cell_valid(cx, cy)) {
        int outer = (cell_valid(cx, cy - 1) ? 0 : 1) | (cell_valid(cx + 1, cy) ? 0 : 2) | (cell_valid(cx, cy + 1) ? 0 : 4) |
                    (cell_valid(cx - 1, cy) ? 0 : 8);
        // Which of the cell's two triangles the rim pass draws (bits 16 lower, 32 upper), with their edges
        // along dropped cells as ghost_raster_vert numbers them.
        int near = 0;
        if (pixels_per_mm.x > 0.0) {
            uint a = me;
            int lower = ((outer & 1) != 0 ? 4 : 0) | ((outer & 2) != 0 ? 1 : 0);
            int upper = ((outer & 4) != 0 ? 1 : 0) | ((outer & 8) != 0 ? 2 : 0);
            if (near_rim(uvec3(a, a + 1u, a + stride + 1u), lower)) near |= 16;
            if (near_rim(uvec3(a, a + stride + 1u, a + stride), upper)) near |= 32;
        }
        bits |= outer | near;
    }
    if (bits != 0) vertices[3u * me + 2u].z = 1.0 + float(bits) / 1024.0;
}
)GLSL";

// Shared by the grid draws: the grid vertices and the corners of triangle `tri` (two per grid cell), and
// whether a triangle is rasterised or, its sensor footprint too small or thin for pixel-centre rasterisation
// (ghost_shade_comp's rasterisable), drawn apart (ghost_raster_vert's SMALL_TRIANGLES).
inline constexpr const char* ghost_grid_glsl = R"GLSL(
#version 430
uniform samplerBuffer vertex_texels;  // the traced vertices (ghost_trace_comp), read by texel fetches
vec4 vertex_texel(int i) { return texelFetch(vertex_texels, i); }
uniform int grid;
uniform int first_vertex;     // the ghost's first vertex (three texels each in vertex_texels)
uniform vec2 half_sensor;     // mm
uniform float triangle_flux;  // half a cell's entrance area x cos(light angle)
uniform vec2 offset_mm;       // the ghost's shift in the upright photograph (right, up)
uniform float pixel_area;     // mm^2
uniform vec4 channels;        // what the ghost adds to R, G, B
uniform int stop_crossings;
uniform vec2 viewport;        // the target's pixels (a band of the full-size image: its rows)
uniform uint first_index;     // the ghost's first triangle index in index_texels (ghost_shade_comp's write_cell_indices)
uniform usamplerBuffer index_texels;  // the triangle indices (ghost_shade_comp's write_cell_indices)

// A batched draw's ghost of this vertex: its vertices are the (grid + 1)^2 from the draw's first_vertex on,
// one ghost's after another.
int draw_job() { return first_job + (gl_VertexID - first_vertex) / ((grid + 1) * (grid + 1)); }

// The drawn ghost's own values: its uniforms, or in a batched draw its job.
int ghost_first_vertex() { return batched ? job_steps(draw_job()).z : first_vertex; }
int ghost_stop_crossings() { return batched ? job_steps(draw_job()).w : stop_crossings; }
float ghost_triangle_flux() { return batched ? job_flux(draw_job()).x : triangle_flux; }
vec2 ghost_offset_mm() { return batched ? job_flux(draw_job()).yz : offset_mm; }
vec4 ghost_channels() { return batched ? job_channels(draw_job()) : channels; }

ivec3 triangle_corners(int tri) {
    int cell = tri / 2;
    bool upper = (tri & 1) == 1;
    int cx = cell % grid;
    int cy = cell / grid;
    int stride = grid + 1;
    int a = ghost_first_vertex() + cy * stride + cx;
    return ivec3(a, upper ? a + stride + 1 : a + 1, upper ? a + stride : a + stride + 1);
}

// Whether triangle tri is rasterised (ghost_shade_comp's write_cell_indices), not small or dropped. Asked only by
// the draws of ghosts with a rim pass, whose triangles are all in the first list (never split: splits_interior).
bool rasterised(int tri) {
    uint at = first_index + 3u * uint(tri);
    return texelFetch(index_texels, int(at)).r != texelFetch(index_texels, int(at + 1u)).r;
}

bool corners_valid(ivec3 i) {
    return vertex_texel(3 * i.x + 2).z > 0.5 && vertex_texel(3 * i.y + 2).z > 0.5 && vertex_texel(3 * i.z + 2).z > 0.5;
}

// Whether a triangle's corners all lie beyond the lens's apertures (r_rel > 1, linear over it): it draws nothing.
bool beyond_apertures(ivec3 i) {
    return vertex_texel(3 * i.x).z > 1.0 && vertex_texel(3 * i.y).z > 1.0 && vertex_texel(3 * i.z).z > 1.0;
}

// Upright photograph: the sensor image turned 180 degrees.
vec4 clip_position(vec2 sensor) {
    vec2 offset = ghost_offset_mm();
    return vec4((offset.x - sensor.x) / half_sensor.x, (offset.y - sensor.y) / half_sensor.y, 0.0, 1.0);
}

vec2 window_position(vec2 sensor) { return (clip_position(sensor).xy * 0.5 + 0.5) * viewport; }
)GLSL";

// Plane geometry shared by the raster draw's two stages for area coverage (ghost_raster_frag): a
// triangle's barycentric coordinates of a point, and the area and first moments of the part of a triangle
// within a pixel's square.
inline constexpr const char* pixel_coverage_glsl = R"GLSL(
float cross2(vec2 a, vec2 b) { return a.x * b.y - a.y * b.x; }

// Barycentric coordinates of x in the triangle p (a third each for a triangle with no area).
vec3 barycentric(vec2 x, vec2 p0, vec2 p1, vec2 p2) {
    vec2 e1 = p1 - p0;
    vec2 e2 = p2 - p0;
    vec2 d = x - p0;
    float det = cross2(e1, e2);
    if (abs(det) < 1e-12) return vec3(1.0 / 3.0);
    float l1 = cross2(d, e2) / det;
    float l2 = cross2(e1, d) / det;
    return vec3(1.0 - l1 - l2, l1, l2);
}

// A segment's signed triangle with the origin: (area, area x centroid). Summed over a closed boundary, the
// area and first moments of what it encloses.
vec3 segment_moments(vec2 a, vec2 b) {
    float c = cross2(a, b);
    return vec3(0.5 * c, c * (a + b) / 6.0);
}

// The part [t0, t1] of the segment a + t (b - a), t in [0, 1], within the square [-0.5, 0.5]^2; none of
// one along the square's side (within_triangle counts that side once, where the triangle is inside).
vec2 within_square(vec2 a, vec2 b) {
    vec2 d = b - a;
    vec2 t = vec2(0.0, 1.0);
    for (int k = 0; k < 2; ++k) {
        if (abs(d[k]) < 1e-20) {
            if (abs(a[k]) >= 0.5) t.y = -1.0;
            continue;
        }
        float ta = (-0.5 - a[k]) / d[k];
        float tb = (0.5 - a[k]) / d[k];
        t = vec2(max(t.x, min(ta, tb)), min(t.y, max(ta, tb)));
    }
    return t;
}

// The part [t0, t1] of the segment a + t (b - a), t in [0, 1], within the counter-clockwise triangle p; a
// segment along one of its edges is within where both run the same way (the triangle and the square on the
// same side of it).
vec2 within_triangle(vec2 a, vec2 b, vec2 p[3]) {
    vec2 d = b - a;
    vec2 t = vec2(0.0, 1.0);
    for (int k = 0; k < 3; ++k) {
        vec2 e = p[(k + 1) % 3] - p[k];
        float f0 = cross2(e, a - p[k]);  // inside where f0 + t df >= 0
        float df = cross2(e, d);
        if (abs(df) < 1e-20) {
            if (f0 < 0.0 || (f0 == 0.0 && dot(e, d) < 0.0)) t.y = -1.0;
            continue;
        }
        if (df > 0.0) t.x = max(t.x, -f0 / df);
        else t.y = min(t.y, -f0 / df);
    }
    return t;
}

// The part of triangle p (pixels from the pixel's centre) within the pixel's square [-0.5, 0.5]^2: its
// area and its first moments (area x centroid), summed over its boundary: the triangle's edges within the
// square and the square's edges within the triangle.
vec3 covered_moments(vec2 p0, vec2 p1, vec2 p2) {
    vec2 p[3] = cross2(p1 - p0, p2 - p0) < 0.0 ? vec2[3](p0, p2, p1) : vec2[3](p0, p1, p2);
    // Quick answers: the whole square within the triangle (each edge's nearest square corner inside), the
    // square wholly beyond an edge, the triangle wholly within the square.
    bool square_inside = true;
    for (int k = 0; k < 3; ++k) {
        vec2 e = p[(k + 1) % 3] - p[k];
        float centre = cross2(e, -p[k]);
        float reach = 0.5 * (abs(e.x) + abs(e.y));
        if (centre + reach <= 0.0) return vec3(0.0);
        square_inside = square_inside && centre >= reach;
    }
    if (square_inside) return vec3(1.0, 0.0, 0.0);
    vec2 lo = min(min(p[0], p[1]), p[2]);
    vec2 hi = max(max(p[0], p[1]), p[2]);
    if (all(greaterThanEqual(lo, vec2(-0.5))) && all(lessThanEqual(hi, vec2(0.5)))) {
        float area = 0.5 * cross2(p[1] - p[0], p[2] - p[0]);
        return vec3(area, area * (p[0] + p[1] + p[2]) / 3.0);
    }
    vec3 m = vec3(0.0);
    for (int k = 0; k < 3; ++k) {
        vec2 a = p[k];
        vec2 b = p[(k + 1) % 3];
        vec2 t = within_square(a, b);
        if (t.y > t.x) m += segment_moments(mix(a, b, t.x), mix(a, b, t.y));
    }
    const vec2 square[4] = vec2[4](vec2(-0.5, -0.5), vec2(0.5, -0.5), vec2(0.5, 0.5), vec2(-0.5, 0.5));
    for (int k = 0; k < 4; ++k) {
        vec2 a = square[k];
        vec2 b = square[(k + 1) % 4];
        vec2 t = within_triangle(a, b, p);
        if (t.y > t.x) m += segment_moments(mix(a, b, t.x), mix(a, b, t.y));
    }
    return m;
}
)GLSL";

// Triangles fetched by gl_VertexID, Gouraud-shaded: each corner carries the irradiance ghost_shade_comp
// averaged over its cells, interpolated across the triangle, so a coarse grid shows no flat cells. Triangles
// with a lost corner (missed surface, total internal reflection) are dropped. Compiled three ways:
// - point sampling: a pixel takes the value at its centre. Triangles too small or thin for that
//   (ghost_shade_comp's rasterisable) are dropped; SMALL_TRIANGLES draws them.
// - AREA_COVERAGE: every triangle is drawn, grown by half a pixel's extent across each edge so that it
//   reaches every pixel it touches, and each of those pixels takes the integral of the triangle's light over
//   the part of it the triangle covers (ghost_raster_frag): a box filter of the Gouraud-shaded mesh.
//   Sub-pixel triangles keep their light, a caustic's dense grid adds up smooth, and nothing changes where
//   triangles get small.
// - AREA_COVERAGE with SMALL_TRIANGLES: a point-sampled ghost's other triangles, with area coverage, each
//   with its own flux spread flat over it. A pixel centre would catch a sub-pixel triangle (and its flux) or
//   miss it by chance, and where the grid crowds (a caustic, the thin bright line along a rim) the catches
//   and misses are correlated: the ghost's power came out wrong, and a rim's line came out as dots. Point
//   splats of them (3 x 3 pixels at the centroid) kept the power but still drew the line as dots.
inline constexpr const char* ghost_raster_vert = R"GLSL(
out float v_r_rel;
out float v_transmission;
out vec2 v_uv0;
out vec2 v_uv1;
out vec2 v_uv2;
out float v_irradiance;
#ifndef INDEXED
out vec3 v_bary;           // barycentric: 1 at this corner
flat out int v_outer;      // corners whose opposite edge borders a dropped cell (bits 1, 2, 4)
#else
flat out int v_inside_iris;  // the provoking vertex's triangles lie inside the iris (ghost_shade_comp's bit 64)
#endif
flat out vec4 v_channels;
flat out int v_stop_crossings;
uniform int rim_mode;      // ghost_raster_frag's: 2 draws only the triangles near the rim (ghost_shade_comp's bits)

// The smooth values of a point of the grid: from its traced vertex (q, s, w: ghost_trace_comp's layout, w.w
// the irradiance ghost_shade_comp put there per unit triangle flux).
void emit_values(vec4 q, vec4 s, vec4 w) {
    v_irradiance = ghost_triangle_flux() * w.w;  // a triangle's flux x triangles per sensor area
    v_r_rel = q.z;
    v_transmission = q.w;
    v_uv0 = s.xy;
    v_uv1 = s.zw;
    v_uv2 = w.xy;
}

#ifdef AREA_COVERAGE
flat out vec2 v_corner[3];  // the triangle's corners, window pixels

// Area coverage: where corner `corner` of triangle p (window pixels) goes so that the triangle reaches every
// pixel it touches: each edge pushed out by half a pixel's extent across it (and 1/64 pixel more), corners
// where the pushed edges meet. A sliver, whose sharp corners would go far, is replaced by a triangle round
// its bounding box grown by half a pixel where that is smaller. Every corner of a triangle decides alike.
vec2 grown_corner(vec2 p[3], int corner) {
    const float grow = 1.0 / 64.0;
    float orient = cross2(p[1] - p[0], p[2] - p[0]) < 0.0 ? -1.0 : 1.0;
    vec2 moved[3];
    bool sharp = false;
    for (int k = 0; k < 3; ++k) {
        vec2 e_in = p[k] - p[(k + 2) % 3];
        vec2 e_out = p[(k + 1) % 3] - p[k];
        vec2 n_in = orient * vec2(e_in.y, -e_in.x) / max(length(e_in), 1e-20);
        vec2 n_out = orient * vec2(e_out.y, -e_out.x) / max(length(e_out), 1e-20);
        float h_in = 0.5 * (abs(n_in.x) + abs(n_in.y)) + grow;
        float h_out = 0.5 * (abs(n_out.x) + abs(n_out.y)) + grow;
        float det = cross2(n_in, n_out);
        sharp = sharp || abs(det) < 1e-3;
        moved[k] = p[k] + vec2(h_in * n_out.y - h_out * n_in.y, n_in.x * h_out - n_out.x * h_in) / (sharp ? 1.0 : det);
    }
    vec2 lo = min(min(p[0], p[1]), p[2]) - (0.5 + grow);
    vec2 size = max(max(p[0], p[1]), p[2]) + (0.5 + grow) - lo;
    float grown_area = 0.5 * abs(cross2(moved[1] - moved[0], moved[2] - moved[0]));
    if (!sharp && grown_area <= 2.0 * size.x * size.y) return moved[corner];
    return lo + (corner == 1 ? vec2(2.0 * size.x, 0.0) : corner == 2 ? vec2(0.0, 2.0 * size.y) : vec2(0.0));
}

// Triangle i's area on the sensor (mm^2).
float sensor_area(ivec3 i) {
    vec2 e1 = vertex_texel(3 * i.y).xy - vertex_texel(3 * i.x).xy;
    vec2 e2 = vertex_texel(3 * i.z).xy - vertex_texel(3 * i.x).xy;
    return 0.5 * abs(cross2(e1, e2));
}

// This corner of triangle i moved (grown_corner), with the triangle's values carried on to where it went, and
// the triangle's corners.
void emit_grown_corner(ivec3 i, int corner, bool drop) {
    mat3x4 q = mat3x4(vertex_texel(3 * i.x), vertex_texel(3 * i.y), vertex_texel(3 * i.z));
    mat3x4 s = mat3x4(vertex_texel(3 * i.x + 1), vertex_texel(3 * i.y + 1), vertex_texel(3 * i.z + 1));
    mat3x4 w = mat3x4(vertex_texel(3 * i.x + 2), vertex_texel(3 * i.y + 2), vertex_texel(3 * i.z + 2));
    vec2 p[3] = vec2[3](window_position(q[0].xy), window_position(q[1].xy), window_position(q[2].xy));
    vec2 moved = grown_corner(p, corner);
    vec3 at = barycentric(moved, p[0], p[1], p[2]);
    gl_Position = drop ? vec4(2.0, 2.0, 2.0, 1.0) : vec4(moved / viewport * 2.0 - 1.0, 0.0, 1.0);
    v_corner = p;
    v_bary = at;
    emit_values(q * at, s * at, w * at);
}
#endif

#ifdef SMALL_TRIANGLES
uniform usamplerBuffer small_texels;  // the small triangles' list (ghost_shade_comp's list_small_triangles)
uniform uint small_first;  // the ghost's list (ghost_shade_comp's list_small_triangles)

// A corner of one of a ghost's small triangles, listed by its shade pass and drawn by the work groups'
// commands (each from 3 x 128 x its group on: gl_VertexID / 3 is the triangle's slot), with area coverage,
// its own flux spread flat over its sensor area (a grid vertex's irradiance averages its larger neighbours
// in, which would take a sliver's light away from it).
void main() {
    int corner = gl_VertexID % 3;
    ivec3 i = triangle_corners(int(texelFetch(small_texels, int(small_first + uint(gl_VertexID / 3))).r));
    v_outer = 0;
    v_channels = ghost_channels();
    v_stop_crossings = ghost_stop_crossings();
    emit_grown_corner(i, corner, false);
    v_irradiance = ghost_triangle_flux() / max(sensor_area(i), 1e-30);
}
#elif defined(INDEXED)
// A grid vertex of an indexed draw (point sampling, no rim pass: a ghost drawn alone at its level, or a batch
// of faint ghosts), drawn by the indices ghost_shade_comp wrote (write_cell_indices: the rasterised triangles),
// so shaded once however many triangles share it rather than once per triangle corner; without the rim's values
// (v_bary, v_outer), which cost every triangle and every pixel.
void main() {
    vec4 q = vertex_texel(3 * gl_VertexID);
    vec4 w = vertex_texel(3 * gl_VertexID + 2);
    v_channels = ghost_channels();
    v_stop_crossings = ghost_stop_crossings();
    gl_Position = w.z > 0.5 ? clip_position(q.xy) : vec4(2.0, 2.0, 2.0, 1.0);  // a lost ray: only in points
    v_inside_iris = w.z > 0.5 ? int(round((w.z - 1.0) * 1024.0)) & 64 : 0;
    emit_values(q, vertex_texel(3 * gl_VertexID + 1), w);
}
#else
void main() {
    int tri = gl_VertexID / 3;
    int corner = gl_VertexID - 3 * tri;
    ivec3 i = triangle_corners(tri);
    // The cell's outer edges (ghost_shade_comp): lower triangle (a, a+1, a+stride+1): below is opposite
    // corner 2, right opposite 0; upper (a, a+stride+1, a+stride): above opposite 0, left opposite 1.
    int cell_bits = int(round((vertex_texel(3 * i.x + 2).z - 1.0) * 1024.0));
    int cell_outer = cell_bits & 15;
    bool in_band = (cell_bits & ((tri & 1) == 0 ? 16 : 32)) != 0;
    v_outer = (tri & 1) == 0 ? (((cell_outer & 1) != 0 ? 4 : 0) | ((cell_outer & 2) != 0 ? 1 : 0))
                             : (((cell_outer & 4) != 0 ? 1 : 0) | ((cell_outer & 8) != 0 ? 2 : 0));
    v_channels = ghost_channels();
    v_stop_crossings = ghost_stop_crossings();
#ifdef AREA_COVERAGE
    emit_grown_corner(i, corner, !corners_valid(i) || beyond_apertures(i) || (rim_mode == 2 && !in_band));
#else
    v_bary = vec3(corner == 0 ? 1.0 : 0.0, corner == 1 ? 1.0 : 0.0, corner == 2 ? 1.0 : 0.0);
    int me = i[corner];
    vec4 q = vertex_texel(3 * me);
    vec4 s = vertex_texel(3 * me + 1);
    vec4 w = vertex_texel(3 * me + 2);
    if (!rasterised(tri) || (rim_mode == 2 && !in_band)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    } else {
        gl_Position = clip_position(q.xy);
    }
    emit_values(q, s, w);
#endif
}
#endif
)GLSL";

// A ghost drawn at reduced resolution loses its sharp rim in the upsampling, so it is drawn in two
// parts (rim_mode): 1, at reduced resolution, its light weighted by w = smoothstep(1, 3, d), d its
// distance to the rim in reduced pixels, so nothing within a reduced pixel of the rim is interpolated
// over it; 2, at full resolution, the rest, 1 - w, cut sharply at the rim (ghost_raster_vert drops the
// triangles that lie wholly deeper than the band or wholly outside). The two add up to the ghost.
// rim_mode 0: the plain full-resolution draw.
// AREA_COVERAGE (ghost_raster_vert): the pixel takes the integral of the triangle's light over the part of
// it the triangle covers; the stop and aperture cuts are taken at that part's centroid.
inline constexpr const char* ghost_raster_frag = R"GLSL(
in float v_r_rel;
in float v_transmission;
in vec2 v_uv0;
in vec2 v_uv1;
in vec2 v_uv2;
in float v_irradiance;
#ifndef INDEXED
in vec3 v_bary;
flat in int v_outer;
#else
flat in int v_inside_iris;
#endif
flat in vec4 v_channels;       // the ghost's (ghost_channels)
flat in int v_stop_crossings;
uniform sampler2D iris_sdf;   // signed distance in stop radii over [-extent, extent]^2
uniform float iris_extent;
uniform bool ringing;          // shade by iris_ringing (transmission with fringes) instead of the sharp SDF
uniform sampler2D iris_ringing;
uniform int rim_mode;          // 0 plain, 1 reduced interior, 2 full-resolution rim band
uniform float rim_reduce;      // target pixels per reduced pixel (mode 2)
out vec4 colour;

// An iris texture at uv (stop radii). It has one level, filtered alike near and far (IrisTextures), so
// an indexed draw, which takes no derivatives, reads level 0: the same, for less.
float iris_texel(sampler2D t, vec2 uv) {
#ifdef INDEXED
    return textureLod(t, uv / (2.0 * iris_extent) + 0.5, 0.0).r;
#else
    return texture(t, uv / (2.0 * iris_extent) + 0.5).r;
#endif
}

float sdf(vec2 uv) { return iris_texel(iris_sdf, uv); }

float ringing_at(vec2 uv) { return iris_texel(iris_ringing, uv); }

// Distance in pixels to where f (linear across the pixel) reaches 0, positive where f < 0.
float pixels_inside(float f) {
    return -f / max(length(vec2(dFdx(f), dFdy(f))), 1e-20);
}

// The share of the pixel on the side of a cut where f < 0 (f linear across the pixel, 0 on the cut: a lens's rim
// at r_rel - 1, the iris's edge at its signed distance): its distance from the pixel's centre through a ramp one
// pixel wide, a straight edge's box-filtered coverage. A cut taken at the pixel's centre alone is a hard,
// stair-stepped edge; the dense reference's rays cover the pixel. Where f does not change across the pixel, the
// pixel is wholly on one side.
// Over a part of the pixel `width` pixels across (area coverage: the part a small triangle covers, f taken at its
// centroid), the ramp is that part's width: a part far smaller than the pixel is cut where its centroid is.
float inside_share(float f, float width) { return clamp(0.5 + pixels_inside(f) / width, 0.0, 1.0); }
float inside_share(float f) { return inside_share(f, 1.0); }

#ifndef INDEXED
// The rim pass's share of the pixel (rim_mode 1 or 2), from its distance to the rim at its centre: to r_rel = 1,
// to the iris (s: its signed distances at the stop crossings) and to the edges along dropped cells.
float rim_weight(vec3 s, int stop_crossings) {
    float d = pixels_inside(v_r_rel - 1.0);
    if (stop_crossings > 0 && !ringing) d = min(d, pixels_inside(s.x));
    if (stop_crossings > 1 && !ringing) d = min(d, pixels_inside(s.y));
    if (stop_crossings > 2 && !ringing) d = min(d, pixels_inside(s.z));
    // The edges along dropped cells: their distance is measured from inside.
    vec3 to_edge = vec3(pixels_inside(-v_bary.x), pixels_inside(-v_bary.y), pixels_inside(-v_bary.z));
    for (int k = 0; k < 3; ++k)
        if ((v_outer & (1 << k)) != 0) d = min(d, to_edge[k]);
    float interior = smoothstep(1.0, 3.0, rim_mode == 1 ? d : d / rim_reduce);
    return rim_mode == 1 ? interior : 1.0 - interior;
}
#endif

// The iris's transmission at the stop crossings' coordinates: with ringing its fringes; else 1, or 0 where any
// crossing is outside.
float iris_at(vec2 uv0, vec2 uv1, vec2 uv2, vec3 s, int stop_crossings) {
    float iris = 1.0;
    if (ringing) {
        if (stop_crossings > 0) iris *= ringing_at(uv0);
        if (stop_crossings > 1) iris *= ringing_at(uv1);
        if (stop_crossings > 2) iris *= ringing_at(uv2);
    } else if (s.x > 0.0 || s.y > 0.0 || s.z > 0.0) {
        iris = 0.0;
    }
    return iris;
}

vec3 iris_distances(vec2 uv0, vec2 uv1, vec2 uv2, int stop_crossings) {
    return vec3(stop_crossings > 0 ? sdf(uv0) : -1.0, stop_crossings > 1 ? sdf(uv1) : -1.0, stop_crossings > 2 ? sdf(uv2) : -1.0);
}

#ifdef AREA_COVERAGE
flat in vec2 v_corner[3];  // the triangle's corners, window pixels (ghost_raster_vert)

// A varying's value at offset o from the pixel's centre (the varyings are linear over the triangle).
float at_offset(float v, vec2 o) { return v + dFdx(v) * o.x + dFdy(v) * o.y; }
vec2 at_offset(vec2 v, vec2 o) { return v + dFdx(v) * o.x + dFdy(v) * o.y; }

void main() {
    int stop_crossings = v_stop_crossings;
    // Derivatives first: the whole 2 x 2 quad must still run.
    float weight = rim_mode != 0 ? rim_weight(iris_distances(v_uv0, v_uv1, v_uv2, stop_crossings), stop_crossings) : 1.0;
    // The integral of the (linear) shading over the covered part of the pixel is its value at that part's
    // centroid times the part's area; the cuts are taken there too.
    vec2 centre = gl_FragCoord.xy;
    vec3 m = covered_moments(v_corner[0] - centre, v_corner[1] - centre, v_corner[2] - centre);
    vec2 o = m.yz / max(m.x, 1e-30);
    float r_rel = at_offset(v_r_rel, o);
    vec2 uv0 = at_offset(v_uv0, o);
    vec2 uv1 = at_offset(v_uv1, o);
    vec2 uv2 = at_offset(v_uv2, o);
    float light = max(at_offset(v_irradiance, o), 0.0) * max(at_offset(v_transmission, o), 0.0);
    // The iris's cut by the share of the covered part inside it (inside_share over the part's width, its area's
    // square root), before any pixel of the quad is discarded; the rim's at the part's centroid (a ramp as wide as
    // the part let a sliver's light past the rim: canon-70-200's ghost 12,19, docs/benchmarks.md).
    float width = max(sqrt(m.x), 1e-3);
    vec3 s = iris_distances(uv0, uv1, uv2, stop_crossings);
    float iris = ringing ? iris_at(uv0, uv1, uv2, vec3(-1.0), stop_crossings)
                         : inside_share(s.x, width) * inside_share(s.y, width) * inside_share(s.z, width);
    if (!(m.x > 0.0) || weight <= 0.0 || r_rel > 1.0 || (iris <= 0.0 && !ringing)) discard;
    colour = v_channels * (light * iris * weight * m.x);
}
#elif defined(INTERIOR)
// An indexed draw's interior triangles (ghost_shade_comp's split_interior): no cut reaches their pixels, so the rim's
// and the iris's shares are 1 there and the light is the interpolated irradiance alone (the INDEXED draw's value,
// for a fraction of its work: two values interpolated, no texture read).
void main() {
    colour = v_channels * (v_irradiance * v_transmission);
}
#elif defined(INDEXED)
// An indexed draw (ghost_raster_vert's INDEXED): no rim pass: the iris read at level 0, and only at the ghost's
// own stop crossings (a loop over them, in place of three conditional reads), and not at all in a triangle known
// to lie inside it; the rim's and the iris's cuts by the share of the pixel inside them (inside_share), or for a
// faint ghost (SHARP_CUTS) at the pixel's centre.
void main() {
#ifdef SHARP_CUTS
    // A faint ghost (under what the plate shows): its cuts at the pixel's centre, the cheapest.
    if (v_r_rel > 1.0) discard;
    float rim = 1.0;
    float iris = 1.0;
    int crossings = v_inside_iris != 0 ? 0 : v_stop_crossings;
    for (int c = 0; c < crossings; ++c) {
        vec2 uv = c == 0 ? v_uv0 : c == 1 ? v_uv1 : v_uv2;
        iris *= ringing ? ringing_at(uv) : sdf(uv) > 0.0 ? 0.0 : 1.0;
    }
    if (iris <= 0.0 && !ringing) discard;
#else
    // Derivatives before any pixel of the quad is discarded (the crossings and the mark are the triangle's, the same
    // in the quad).
    float rim = inside_share(v_r_rel - 1.0);
    int crossings = v_inside_iris != 0 ? 0 : v_stop_crossings;
    float iris = 1.0;
    for (int c = 0; c < crossings; ++c) {
        vec2 uv = c == 0 ? v_uv0 : c == 1 ? v_uv1 : v_uv2;
        iris *= ringing ? ringing_at(uv) : inside_share(sdf(uv));
    }
    if (rim <= 0.0 || (iris <= 0.0 && !ringing)) discard;
#endif
    colour = v_channels * (v_irradiance * v_transmission * iris * rim);
}
#else
void main() {
    int stop_crossings = v_stop_crossings;
    vec3 s = iris_distances(v_uv0, v_uv1, v_uv2, stop_crossings);
    // Derivatives first: the whole 2 x 2 quad runs.
    float weight = rim_mode != 0 ? rim_weight(s, stop_crossings) : 1.0;
    float rim = inside_share(v_r_rel - 1.0);
    float iris = ringing ? iris_at(v_uv0, v_uv1, v_uv2, s, stop_crossings)
                         : inside_share(s.x) * inside_share(s.y) * inside_share(s.z);
    if (rim <= 0.0 || weight <= 0.0 || (iris <= 0.0 && !ringing)) discard;
    colour = v_channels * (v_irradiance * v_transmission * iris * weight * rim);
}
#endif
)GLSL";

}  // namespace lensfx::gpu::shaders
