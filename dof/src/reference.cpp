// The dense CPU reference (see reference.h).
#include <dof/reference.h>

#include <algorithm>
#include <cmath>
#include <thread>

namespace lensfx::dof {

namespace {

// Composites the layers of cell (x, y) (clamped to the raster) that the ray meets while w runs from
// w_in down to w_out, front to back; returns false once nothing more can be seen through them.
bool shade_cell(const LayerStack& layers, int x, int y, float w_in, float w_out, int channel, float& acc, float& trans) {
    x = std::clamp(x, 0, layers.width - 1), y = std::clamp(y, 0, layers.height - 1);
    for (int k = 0; k < layers.count; ++k) {
        const std::size_t i = layers.at(k, x, y);
        const float f = layers.front[i];
        if (f <= 0.0f) break;
        const float w_front = 1.0f / f, w_back = 1.0f / layers.back[i];
        if (w_out > w_front || w_in < w_back) continue;
        acc += trans * layers.rgba[4 * i + static_cast<std::size_t>(channel)];
        trans *= 1.0f - layers.opacity(i);
        if (trans < 1e-3f) return false;
    }
    return true;
}

// The farthest surface of cell (x, y) (clamped), for a ray that found nothing.
float farthest_colour(const LayerStack& layers, int x, int y, int channel) {
    x = std::clamp(x, 0, layers.width - 1), y = std::clamp(y, 0, layers.height - 1);
    float c = 0.0f;
    for (int k = 0; k < layers.count; ++k) {
        const std::size_t i = layers.at(k, x, y);
        if (layers.front[i] <= 0.0f) break;
        c = layers.rgba[4 * i + static_cast<std::size_t>(channel)];
    }
    return c;
}

float trace_channel(const LayerStack& layers, const DepthSpan& span, float cx, float ax, float cy, float ay, int channel) {
    const float w_near = span.w_near, w_far = span.w_far;
    // pos(w) = c + a w; w falls, so the ray moves along -a on screen.
    float w = w_near;
    int x = static_cast<int>(std::floor(cx + ax * w)), y = static_cast<int>(std::floor(cy + ay * w));
    const int sx = ax > 0 ? -1 : 1, sy = ay > 0 ? -1 : 1;
    float acc = 0.0f, trans = 1.0f;
    for (int guard = 0; guard < 1 << 20; ++guard) {
        // w where the ray leaves the cell through its x or y side
        const float bx = static_cast<float>(sx > 0 ? x + 1 : x), by = static_cast<float>(sy > 0 ? y + 1 : y);
        const float wx = ax != 0.0f ? (bx - cx) / ax : -1e30f, wy = ay != 0.0f ? (by - cy) / ay : -1e30f;
        const float w_exit = std::max(std::max(wx, wy), w_far);
        if (!shade_cell(layers, x, y, w, w_exit, channel, acc, trans)) return acc;
        if (w_exit <= w_far) break;
        w = w_exit;
        if (wx >= wy) x += sx; else y += sy;
    }
    return layers.open ? acc : acc + trans * farthest_colour(layers, x, y, channel);
}

// The mean of colour channel `colour` (3: alpha) over the first n rays of table channel `rays` at pixel
// (x, y), each weighted by its share of valid grid corners.
float pixel_mean(const LayerStack& layers, const DepthSpan& span, const RayTable& table, int x, int y, int rays, int colour, int n) {
    double sum = 0.0, weight = 0.0;
    for (int s = 0; s < n; ++s) {
        const ScreenRay r = ray_at(table, rays, x + 0.5, y + 0.5, s);
        if (r.weight <= 0.0f) continue;
        sum += static_cast<double>(r.weight * trace_channel(layers, span, r.cx, r.ax, r.cy, r.ay, colour));
        weight += static_cast<double>(r.weight);
    }
    return weight > 0.0 ? static_cast<float>(sum / weight) : 0.0f;
}

}  // namespace

DepthSpan depth_span(const LayerStack& layers) {
    return {1.0001f / layers.nearest(), 1.0f / layers.farthest()};
}

float trace_exact(const LayerStack& layers, const DepthSpan& span, const ScreenRay& ray, int channel) {
    return trace_channel(layers, span, ray.cx, ray.ax, ray.cy, ray.ay, channel);
}

std::vector<float> render_reference(const LayerStack& layers, const RayTable& table, int rays, int threads, std::vector<float>* alpha) {
    const DepthSpan span = depth_span(layers);
    const int n = rays > 0 ? std::min(rays, table.samples) : table.samples;
    const std::size_t pixels = static_cast<std::size_t>(layers.width) * static_cast<std::size_t>(layers.height);
    std::vector<float> out(3 * pixels, 0.0f);
    if (alpha) alpha->assign(pixels, 0.0f);
    const unsigned t = threads > 0 ? static_cast<unsigned>(threads) : std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> pool;
    for (unsigned id = 0; id < t; ++id) {
        pool.emplace_back([&, id] {
            for (int y = static_cast<int>(id); y < layers.height; y += static_cast<int>(t)) {
                for (int x = 0; x < layers.width; ++x) {
                    const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(layers.width) + static_cast<std::size_t>(x);
                    for (int b = 0; b < table.channels; ++b)  // each band's gathered colour into R, G, B by its weights
                        for (int c = 0; c < 3; ++c)
                            if (const float wc = table.channel_weight[static_cast<std::size_t>(b)][static_cast<std::size_t>(c)]; wc != 0.0f)
                                out[3 * i + static_cast<std::size_t>(c)] += wc * pixel_mean(layers, span, table, x, y, b, c, n);
                    if (alpha) (*alpha)[i] = pixel_mean(layers, span, table, x, y, table.achromatic, 3, n);
                }
            }
        });
    }
    for (auto& th : pool) th.join();
    return out;
}

}  // namespace lensfx::dof
