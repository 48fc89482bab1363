// The GPU lens-blur trace (see renderer.h); the shader is in dof_shaders.h.
#include <dof/renderer.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include <epoxy/gl.h>
#include <fmt/core.h>
#include <gpu/gl.h>
#include <optics/stopwatch.h>

#include "dof_shaders.h"

namespace lensfx::dof {

namespace {

constexpr int kMaxBands = 128;  // band_weight's size in the shader
constexpr int kTile = 8;        // the shader's work group side: one ray count per group

int next_pow2(int n) {
    int p = 1;
    while (p < n) p *= 2;
    return p;
}

gpu::GlObject make_texture(GLenum target) {
    GLuint n = 0;
    glCreateTextures(target, 1, &n);
    return {gpu::GlObject::Kind::Texture, n};
}

gpu::GlObject texture_array(GLenum format, int w, int h, int layers, GLenum pixel_format, const float* data) {
    gpu::GlObject t = make_texture(GL_TEXTURE_2D_ARRAY);
    glTextureStorage3D(t.get(), 1, format, w, h, layers);
    glTextureSubImage3D(t.get(), 0, 0, 0, 0, w, h, layers, pixel_format, GL_FLOAT, data);
    return t;
}

}  // namespace

struct Renderer::State {
    gpu::Program program{"dof_trace.comp", {{gpu::ShaderStage::Type::Compute, kTraceShader}}};
};

Renderer::Renderer() : state_(std::make_unique<State>()) {}
Renderer::~Renderer() = default;

std::vector<std::vector<float>> minmax_pyramid(const LayerStack& layers, int& padded_w, int& padded_h) {
    padded_w = next_pow2(layers.width), padded_h = next_pow2(layers.height);
    std::vector<std::vector<float>> levels;
    std::vector<float> base(2 * static_cast<std::size_t>(padded_w) * static_cast<std::size_t>(padded_h));
    for (std::size_t i = 0; i < base.size(); i += 2) base[i] = 1e30f, base[i + 1] = -1e30f;
    for (int y = 0; y < layers.height; ++y) {
        for (int x = 0; x < layers.width; ++x) {
            float* cell = &base[2 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(padded_w) + static_cast<std::size_t>(x))];
            for (int k = 0; k < layers.count; ++k) {
                const std::size_t i = layers.at(k, x, y);
                if (layers.front[i] <= 0.0f) break;
                cell[0] = std::min(cell[0], 1.0f / layers.back[i]);
                cell[1] = std::max(cell[1], 1.0f / layers.front[i]);
            }
        }
    }
    levels.push_back(std::move(base));
    for (int w = padded_w, h = padded_h; w > 1 || h > 1;) {
        const int nw = std::max(1, w / 2), nh = std::max(1, h / 2);
        const std::vector<float>& prev = levels.back();
        std::vector<float> next(2 * static_cast<std::size_t>(nw) * static_cast<std::size_t>(nh));
        for (int y = 0; y < nh; ++y) {
            for (int x = 0; x < nw; ++x) {
                float lo = 1e30f, hi = -1e30f;
                for (int j = 0; j < 2; ++j) {
                    for (int i = 0; i < 2; ++i) {
                        const int px = std::min(2 * x + i, w - 1), py = std::min(2 * y + j, h - 1);
                        const std::size_t k = 2 * (static_cast<std::size_t>(py) * static_cast<std::size_t>(w) + static_cast<std::size_t>(px));
                        lo = std::min(lo, prev[k]), hi = std::max(hi, prev[k + 1]);
                    }
                }
                next[2 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(nw) + static_cast<std::size_t>(x))] = lo;
                next[2 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(nw) + static_cast<std::size_t>(x)) + 1] = hi;
            }
        }
        levels.push_back(std::move(next));
        w = nw, h = nh;
    }
    return levels;
}

std::array<std::vector<float>, 2> colour_level(const LayerStack& layers, int level) {
    const int cs = 1 << level;
    const int nw = (layers.width + cs - 1) / cs, nh = (layers.height + cs - 1) / cs;
    const std::size_t n = 4 * static_cast<std::size_t>(nw) * static_cast<std::size_t>(nh);
    std::array<std::vector<float>, 2> out{std::vector<float>(n, 1e30f), std::vector<float>(n, -1e30f)};
    std::vector<float>&lo = out[0], &hi = out[1];
    for (int y = 0; y < layers.height; ++y) {
        for (int x = 0; x < layers.width; ++x) {
            const std::size_t cell = 4 * (static_cast<std::size_t>(y / cs) * static_cast<std::size_t>(nw) + static_cast<std::size_t>(x / cs));
            for (int k = 0; k < layers.count; ++k) {
                const std::size_t i = layers.at(k, x, y);
                const bool empty = layers.front[i] <= 0.0f;
                if (empty && k > 0) break;
                for (std::size_t c = 0; c < 4; ++c) {
                    const float v = layers.rgba[4 * i + c];
                    lo[cell + c] = std::min(lo[cell + c], empty ? -1e30f : v);  // an empty pixel is never uniform
                    hi[cell + c] = std::max(hi[cell + c], empty ? 1e30f : v);
                }
            }
        }
    }
    return out;
}

namespace {

gpu::GlObject mip_texture(GLenum format, GLenum pixel_format, int w, int h, const std::vector<std::vector<float>>& levels) {
    gpu::GlObject t = make_texture(GL_TEXTURE_2D);
    glTextureStorage2D(t.get(), static_cast<GLsizei>(levels.size()), format, w, h);
    for (std::size_t l = 0; l < levels.size(); ++l)
        glTextureSubImage2D(t.get(), static_cast<GLint>(l), 0, 0, std::max(1, w >> l), std::max(1, h >> l), pixel_format, GL_FLOAT, levels[l].data());
    return t;
}

// The layers' inverse depths (1/front, 1/back; -1 where empty) as one array.
std::vector<float> inverse_depths(const LayerStack& layers) {
    std::vector<float> w(2 * layers.front.size());
    for (std::size_t i = 0; i < layers.front.size(); ++i) {
        const bool empty = layers.front[i] <= 0.0f;
        w[2 * i] = empty ? -1.0f : 1.0f / layers.front[i];
        w[2 * i + 1] = empty ? -1.0f : 1.0f / layers.back[i];
    }
    return w;
}

// The table's lines with a stopped ray's cx set to -1e30 (the shader's mark: one fetch per ray and corner).
std::vector<std::array<float, 4>> marked_lines(const RayTable& table) {
    std::vector<std::array<float, 4>> lines = table.line;
    for (std::size_t i = 0; i < lines.size(); ++i)
        if (table.weight[i] <= 0.0f) lines[i][0] = -1e30f;
    return lines;
}

// An image the trace reads and writes between dispatches, cleared to 0.
gpu::GlObject work_image(GLenum format, int w, int h) {
    gpu::GlObject t = make_texture(GL_TEXTURE_2D);
    glTextureStorage2D(t.get(), 1, format, w, h);
    glClearTexImage(t.get(), 0, format == GL_R32I ? GL_RED_INTEGER : GL_RED, format == GL_R32I ? GL_INT : GL_FLOAT, nullptr);
    return t;
}

// Loop budget. llvmpipe gives each shader invocation (a SIMD vector of pixels) one count of 65535 loop
// iterations shared by every loop, and once it is spent every loop leaves after one iteration without a
// word: a pixel tracing every band's rays in one invocation lost its later bands (one band 0, or a few
// rays standing for the whole band). So each dispatch traces one band's chunk of rays; an invocation that
// still runs out keeps what it had, marks its pixels, and those are traced again one ray per dispatch.
class ChunkedTrace {
public:
    ChunkedTrace(const gpu::Program& program, int width, int height)
        : program_(program), width_(width), height_(height), band_sum_(work_image(GL_RGBA32F, width, height)),
          band_weight_(work_image(GL_R32F, width, height)), retry_(work_image(GL_R32I, width, height)), counter_(gpu::GlObject::buffer()) {
        const GLuint zero = 0;
        glNamedBufferData(counter_.get(), sizeof(zero), &zero, GL_DYNAMIC_READ);
        glBindImageTexture(1, band_sum_.get(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_RGBA32F);
        glBindImageTexture(2, band_weight_.get(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32F);
        glBindImageTexture(3, retry_.get(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32I);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, counter_.get());
        glUniform1i(program_.uniform("budget_check"), 2);
    }

    // Rays [first, first + count) of `band` at every pixel that has that many (tile_ray_counts); a pixel's
    // last chunk is folded into the result. Returns how many pixels ran out of loop budget (traced again
    // ray by ray).
    std::size_t trace(int band, int first, int count) {
        glUniform1i(program_.uniform("band"), band);
        std::size_t retried = dispatch(first, count, first == 0, false);
        if (retried == 0) return 0;
        for (int k = first; k < first + count; ++k)
            if (dispatch(k, 1, false, true) != 0) throw std::runtime_error("lens blur: one lens ray ran past the GL driver's loop limit");
        glClearTexImage(retry_.get(), 0, GL_RED_INTEGER, GL_INT, nullptr);
        return retried;
    }

private:
    std::size_t dispatch(int first, int count, bool fresh, bool retry_pass) {
        glUniform1i(program_.uniform("ray_first"), first);
        glUniform1i(program_.uniform("ray_count"), count);
        glUniform1i(program_.uniform("fresh"), fresh ? 1 : 0);
        glUniform1i(program_.uniform("retry_pass"), retry_pass ? 1 : 0);
        glDispatchCompute(static_cast<GLuint>((width_ + 7) / 8), static_cast<GLuint>((height_ + 7) / 8), 1);
        glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
        GLuint retried = 0;
        glGetNamedBufferSubData(counter_.get(), 0, sizeof(retried), &retried);
        if (retried != 0) {
            const GLuint zero = 0;
            glNamedBufferSubData(counter_.get(), 0, sizeof(zero), &zero);
        }
        return retried;
    }

    const gpu::Program& program_;
    int width_, height_;
    gpu::GlObject band_sum_, band_weight_, retry_, counter_;
};

// Per 8 x 8-pixel cell (the pyramid's level 3), the widest blur radius (px) of its surfaces; 0 if empty.
std::vector<double> cell_blur_radii(const std::vector<float>& level3, int cells, const RayTable& table) {
    std::vector<double> radius(static_cast<std::size_t>(cells), 0.0);
    for (std::size_t c = 0; c < radius.size(); ++c) {
        const double lo = static_cast<double>(level3[2 * c]), hi = static_cast<double>(level3[2 * c + 1]);
        if (lo <= hi) radius[c] = table.max_slope * std::max(std::abs(hi - table.focus_w), std::abs(lo - table.focus_w));
    }
    return radius;
}

// Distance (px) between the 8 x 8 cells (ax, ay) and (bx, by), 0 when they touch.
double cell_gap(int ax, int ay, int bx, int by) {
    const auto gap = [](int a, int b) { return std::max(0, (std::abs(a - b) - 1) * kTile); };
    return std::hypot(gap(ax, bx), gap(ay, by));
}

}  // namespace

double uniform_reach_px(const LayerStack& layers, const RayTable& table) {
    const double w_near = 1.0 / static_cast<double>(layers.nearest()), w_far = 1.0 / static_cast<double>(layers.farthest());
    return table.max_slope * std::max(std::abs(w_near - table.focus_w), std::abs(w_far - table.focus_w)) + 2.0 * table.focus_spread;
}

std::vector<float> tile_ray_counts(const std::vector<std::vector<float>>& pyramid, int padded_w, int padded_h, int width, int height,
                                   const RayTable& table, double reach_px, int min_rays, int max_rays, double spacing_px) {
    const int tiles_x = (width + kTile - 1) / kTile, tiles_y = (height + kTile - 1) / kTile;
    min_rays = std::max(1, min_rays), max_rays = std::max(min_rays, max_rays);
    std::vector<float> counts(static_cast<std::size_t>(tiles_x) * static_cast<std::size_t>(tiles_y), static_cast<float>(min_rays));
    if (max_rays == min_rays || !(spacing_px > 0.0)) return counts;
    // the pyramid's level of kTile-wide cells (2^3), or its 1 x 1 top when the layers are at most 4 x 4
    const std::size_t level = std::min<std::size_t>(3, pyramid.size() - 1);
    const int lw = std::max(1, padded_w >> level);
    const std::vector<double> radius = cell_blur_radii(pyramid[level], lw * std::max(1, padded_h >> level), table);
    const double slack = 2.0 * table.focus_spread;  // where the rays converge may lie off the pixel
    // tiles either side a blur can reach from, at most the whole frame (a depth of 1e-10 m reaches 1e10 pixels)
    const double reach_tiles = std::ceil((reach_px + slack) / kTile) + 1.0;
    const int span = std::isfinite(reach_tiles) ? static_cast<int>(std::min(reach_tiles, static_cast<double>(std::max(tiles_x, tiles_y))))
                                                : std::max(tiles_x, tiles_y);
    for (int ty = 0; ty < tiles_y; ++ty)
        for (int tx = 0; tx < tiles_x; ++tx) {
            // the widest blur disc reaching this tile: every cell whose own blur spans the gap to it
            double widest = 0.0;
            for (int cy = std::max(0, ty - span); cy <= std::min(tiles_y - 1, ty + span); ++cy)
                for (int cx = std::max(0, tx - span); cx <= std::min(tiles_x - 1, tx + span); ++cx) {
                    const double r = radius[static_cast<std::size_t>(cy) * static_cast<std::size_t>(lw) + static_cast<std::size_t>(cx)];
                    if (r > widest && cell_gap(tx, ty, cx, cy) <= r + slack) widest = r;
                }
            // rays a disc of diameter 2 widest needs to land spacing_px apart: its area over a spacing disc's
            const double d = 2.0 * widest / spacing_px, wanted = std::ceil(0.25 * std::numbers::pi * d * d);
            counts[static_cast<std::size_t>(ty * tiles_x + tx)] = static_cast<float>(std::clamp(wanted, double(min_rays), double(max_rays)));
        }
    return counts;
}

std::vector<float> achromatic_cells(const RayTable& t, double w_near, double w_far, double tolerance_px) {
    const int cw = t.grid_x - 1, ch = t.grid_y - 1;
    std::vector<float> one(static_cast<std::size_t>(cw) * static_cast<std::size_t>(ch), 1.0f);
    const auto to_double = [](float v) { return static_cast<double>(v); };
    const auto apart = [&](const std::array<float, 4>& a, const std::array<float, 4>& b) {
        double d = 0.0;
        for (double w : {w_near, w_far})
            d = std::max(d, std::hypot(to_double(a[0]) - to_double(b[0]) + (to_double(a[1]) - to_double(b[1])) * w,
                                       to_double(a[2]) - to_double(b[2]) + (to_double(a[3]) - to_double(b[3])) * w));
        return d;
    };
    // whether grid point (gx, gy)'s every band ray passes where the achromatic one does and stays within tolerance of it
    const auto one_blur_at = [&](int gx, int gy) {
        for (int b = 0; b < t.channels; ++b)
            for (int k = 0; b != t.achromatic && k < t.samples; ++k) {
                const std::size_t i = t.at(b, gx, gy, k), g = t.at(t.achromatic, gx, gy, k);
                if ((t.weight[i] > 0.0f) != (t.weight[g] > 0.0f)) return false;
                if (t.weight[i] > 0.0f && !(apart(t.line[i], t.line[g]) <= tolerance_px)) return false;
            }
        return true;
    };
    std::vector<char> point(static_cast<std::size_t>(t.grid_x) * static_cast<std::size_t>(t.grid_y));
    for (int gy = 0; gy < t.grid_y; ++gy)
        for (int gx = 0; gx < t.grid_x; ++gx) point[static_cast<std::size_t>(gy * t.grid_x + gx)] = one_blur_at(gx, gy) ? 1 : 0;
    for (int y = 0; y < ch; ++y)
        for (int x = 0; x < cw; ++x) {
            const auto at = [&](int i, int j) { return point[static_cast<std::size_t>((y + j) * t.grid_x + x + i)] != 0; };
            one[static_cast<std::size_t>(y * cw + x)] = at(0, 0) && at(1, 0) && at(0, 1) && at(1, 1) ? 1.0f : 0.0f;
        }
    return one;
}

std::vector<float> Renderer::render(const LayerStack& layers, const RayTable& table, const TraceSettings& settings,
                                    std::vector<float>* alpha) {
    const auto start = std::chrono::steady_clock::now();
    const GLuint prog = state_->program.get();
    int pw = 0, ph = 0;
    const std::vector<std::vector<float>> pyramid = minmax_pyramid(layers, pw, ph);
    gpu::GlObject hiz = mip_texture(GL_RG32F, GL_RG, pw, ph, pyramid);
    const int top_level = static_cast<int>(pyramid.size()) - 1;
    const double reach = uniform_reach_px(layers, table);
    const int level = std::min(top_level, static_cast<int>(std::ceil(std::log2(2.0 * (reach + 4.0) + 2.0))));
    const auto colours = colour_level(layers, level);
    const int cw = (layers.width + (1 << level) - 1) >> level, ch = (layers.height + (1 << level) - 1) >> level;
    gpu::GlObject cmin = mip_texture(GL_RGBA32F, GL_RGBA, cw, ch, {colours[0]});
    gpu::GlObject cmax = mip_texture(GL_RGBA32F, GL_RGBA, cw, ch, {colours[1]});
    const std::vector<float> inv = inverse_depths(layers);
    gpu::GlObject layer_w = texture_array(GL_RG32F, layers.width, layers.height, layers.count, GL_RG, inv.data());
    gpu::GlObject layer_rgba = texture_array(GL_RGBA32F, layers.width, layers.height, layers.count, GL_RGBA, layers.rgba.data());
    if (table.channels > kMaxBands) throw std::invalid_argument(fmt::format("lens blur: {} bands, at most {}", table.channels, kMaxBands));
    const int points = table.grid_x * table.grid_y;  // one layer per band
    gpu::GlObject line = texture_array(GL_RGBA32F, table.samples, points, table.channels, GL_RGBA, marked_lines(table).front().data());
    const std::vector<float> one_blur = achromatic_cells(table, 1.0001 / static_cast<double>(layers.nearest()), 1.0 / static_cast<double>(layers.farthest()),
                                                        settings.chroma_tolerance_px);
    gpu::GlObject cells = make_texture(GL_TEXTURE_2D);
    glTextureStorage2D(cells.get(), 1, GL_R32F, table.grid_x - 1, table.grid_y - 1);
    glTextureSubImage2D(cells.get(), 0, 0, 0, table.grid_x - 1, table.grid_y - 1, GL_RED, GL_FLOAT, one_blur.data());
    gpu::GlObject out = work_image(GL_RGBA32F, layers.width, layers.height);

    glUseProgram(prog);
    const int min_rays = std::clamp(settings.rays, 1, table.samples), max_rays = std::clamp(settings.max_rays, min_rays, table.samples);
    const std::vector<float> tile_rays = tile_ray_counts(pyramid, pw, ph, layers.width, layers.height, table, reach, min_rays, max_rays,
                                                         settings.ray_spacing_px);
    const int tiles_x = (layers.width + kTile - 1) / kTile, tiles_y = (layers.height + kTile - 1) / kTile;
    gpu::GlObject tiles = mip_texture(GL_R32F, GL_RED, tiles_x, tiles_y, {tile_rays});
    const GLuint units[] = {hiz.get(), layer_w.get(), layer_rgba.get(), line.get(), cells.get(), cmin.get(), cmax.get(), tiles.get()};
    const char* names[] = {"hiz", "layer_w", "layer_rgba", "ray_line", "achromatic_cell", "colour_min", "colour_max", "tile_rays"};
    for (GLuint u = 0; u < 8; ++u) {
        glBindTextureUnit(u, units[u]);
        glUniform1i(state_->program.uniform(names[u]), static_cast<GLint>(u));
    }
    glBindImageTexture(0, out.get(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_RGBA32F);
    const auto& p = state_->program;
    glUniform2i(p.uniform("size"), layers.width, layers.height);
    glUniform1i(p.uniform("layer_count"), layers.count);
    glUniform1i(p.uniform("top_level"), top_level);
    glUniform1i(p.uniform("colour_level"), level);
    glUniform1i(p.uniform("start_level"), settings.start_level);
    glUniform1i(p.uniform("max_iterations"), settings.max_iterations);
    glUniform1f(p.uniform("w_near"), 1.0001f / layers.nearest());
    glUniform1f(p.uniform("w_far"), 1.0f / layers.farthest());
    glUniform1f(p.uniform("reach_px"), settings.uniform_skip ? static_cast<float>(reach) : -1e30f);
    glUniform2i(p.uniform("origin"), settings.origin_x, settings.origin_y);
    glUniform1f(p.uniform("focus_w"), static_cast<float>(table.focus_w));
    glUniform1i(p.uniform("samples"), table.samples);
    glUniform1i(p.uniform("chromatic"), settings.chromatic ? 1 : 0);
    glUniform1i(p.uniform("bands"), table.channels);
    glUniform1i(p.uniform("achromatic"), table.achromatic);
    glUniform3fv(p.uniform("band_weight"), table.channels, table.channel_weight.front().data());
    glUniform1i(p.uniform("open_scene"), layers.open ? 1 : 0);
    glUniform2i(p.uniform("grid"), table.grid_x, table.grid_y);
    glUniform2f(p.uniform("cell"), static_cast<float>(table.cell_w), static_cast<float>(table.cell_h));
    ChunkedTrace chunks(state_->program, layers.width, layers.height);
    const int rays = static_cast<int>(*std::max_element(tile_rays.begin(), tile_rays.end())), chunk = std::max(1, settings.rays_per_dispatch);
    last_retried_ = 0;
    last_rays_ = std::accumulate(tile_rays.begin(), tile_rays.end(), 0.0) / static_cast<double>(tile_rays.size());
    for (int b = 0; b < table.channels; ++b) {
        if (!settings.chromatic && b != table.achromatic) continue;
        for (int first = 0; first < rays; first += chunk) last_retried_ += chunks.trace(b, first, std::min(chunk, rays - first));
    }
    glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
    std::vector<float> rgba(4 * static_cast<std::size_t>(layers.width) * static_cast<std::size_t>(layers.height));
    glGetTextureImage(out.get(), 0, GL_RGBA, GL_FLOAT, static_cast<GLsizei>(rgba.size() * sizeof(float)), rgba.data());
    gpu::check_gl("dof trace");
    if (glGetError() != GL_NO_ERROR) throw std::runtime_error("lens blur: the GL trace failed");
    std::vector<float> rgb(3 * static_cast<std::size_t>(layers.width) * static_cast<std::size_t>(layers.height));
    for (std::size_t i = 0, n = rgb.size() / 3; i < n; ++i)
        for (std::size_t c = 0; c < 3; ++c) rgb[3 * i + c] = rgba[4 * i + c];
    if (alpha) {
        alpha->resize(rgb.size() / 3);
        for (std::size_t i = 0; i < alpha->size(); ++i) (*alpha)[i] = rgba[4 * i + 3];
    }
    last_ms_ = ms_since(start);
    return rgb;
}

}  // namespace lensfx::dof
