// Layered scene construction (see layers.h).
#include <dof/layers.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace lensfx::dof {

namespace {

constexpr float kInfinityDepth = 1e9f;

float valid_depth(float z) { return (std::isfinite(z) && z > 0.0f) ? std::min(z, kInfinityDepth) : kInfinityDepth; }

// For each pixel, the index of the nearest pixel (within `radius`) whose depth lies behind it by more than
// `step` (relative), or -1: jump flooding (Rong and Tan 2006) with steps radius/2 .. 1, then 1 again.
std::vector<int> hidden_neighbours(const std::vector<float>& z, int w, int h, int radius, double step) {
    std::vector<int> seed(z.size(), -1), next(z.size());
    const auto behind = [&](int p, int q) { return q >= 0 && static_cast<double>(z[static_cast<std::size_t>(q)]) > static_cast<double>(z[static_cast<std::size_t>(p)]) * (1.0 + step); };
    const auto dist2 = [w](int p, int q) {
        const int dx = p % w - q % w, dy = p / w - q / w;
        return dx * dx + dy * dy;
    };
    std::vector<int> steps;
    for (int s = std::max(1, radius / 2); s >= 1; s /= 2) steps.push_back(s);
    steps.push_back(1);
    const int r2 = radius * radius;
    for (int s : steps) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                const int p = y * w + x;
                int best = seed[static_cast<std::size_t>(p)];
                int best_d = best >= 0 ? dist2(p, best) : std::numeric_limits<int>::max();
                for (int dy = -s; dy <= s; dy += s) {
                    for (int dx = -s; dx <= s; dx += s) {
                        const int qx = x + dx, qy = y + dy;
                        if (qx < 0 || qy < 0 || qx >= w || qy >= h || (dx == 0 && dy == 0)) continue;
                        const int q = qy * w + qx;
                        for (int c : {q, seed[static_cast<std::size_t>(q)]}) {
                            if (!behind(p, c)) continue;
                            const int d = dist2(p, c);
                            if (d < best_d && d <= r2) best = c, best_d = d;
                        }
                    }
                }
                next[static_cast<std::size_t>(p)] = best;
            }
        }
        seed.swap(next);
    }
    return seed;
}

}  // namespace

void LayerStack::resize(int w, int h, int layers) {
    width = w, height = h, count = layers;
    const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * static_cast<std::size_t>(layers);
    front.assign(n, 0.0f);
    back.assign(n, 0.0f);
    rgba.assign(n * 4, 0.0f);
}

float LayerStack::nearest() const {
    float m = std::numeric_limits<float>::max();
    for (float f : front)
        if (f > 0.0f) m = std::min(m, f);
    return m;
}

float LayerStack::farthest() const {
    float m = 0.0f;
    for (float b : back) m = std::max(m, b);
    return m;
}

LayerStack layers_from_flat(const float* rgb, const float* depth, int width, int height, const FlatLayerOptions& options,
                            const float* alpha) {
    const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    std::vector<float> z(n);
    for (std::size_t i = 0; i < n; ++i) z[i] = valid_depth(depth[i]);
    const int radius = std::max(1, static_cast<int>(std::ceil(options.hidden_radius_px)));
    const std::vector<int> hidden = hidden_neighbours(z, width, height, radius, options.step);
    const bool any_hidden = std::any_of(hidden.begin(), hidden.end(), [](int s) { return s >= 0; });
    LayerStack layers;
    layers.resize(width, height, any_hidden ? 2 : 1);
    for (std::size_t i = 0; i < n; ++i) {
        layers.front[i] = z[i];
        for (int c = 0; c < 3; ++c) layers.rgba[4 * i + static_cast<std::size_t>(c)] = rgb[3 * i + static_cast<std::size_t>(c)];
        layers.rgba[4 * i + 3] = alpha ? alpha[i] : 1.0f;
        if (!any_hidden || hidden[i] < 0) continue;
        const std::size_t h = n + i, s = static_cast<std::size_t>(hidden[i]);
        layers.front[h] = z[s];
        for (int c = 0; c < 3; ++c) layers.rgba[4 * h + static_cast<std::size_t>(c)] = rgb[3 * s + static_cast<std::size_t>(c)];
        layers.rgba[4 * h + 3] = alpha ? alpha[s] : 1.0f;
    }
    set_thickness(layers, options.thickness, options.step);
    return layers;
}

void set_thickness(LayerStack& layers, double thickness, double step) {
    const int w = layers.width, h = layers.height;
    for (int k = 0; k < layers.count; ++k) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                const std::size_t i = layers.at(k, x, y);
                const float f = layers.front[i];
                if (f <= 0.0f) continue;
                float b = std::max(layers.back[i], static_cast<float>(static_cast<double>(f) * (1.0 + thickness)));
                for (int dy = -1; dy <= 1; ++dy) {
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int qx = x + dx, qy = y + dy;
                        if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
                        const float g = layers.front[layers.at(k, qx, qy)];
                        if (g > f && static_cast<double>(g) <= static_cast<double>(f) * (1.0 + step)) b = std::max(b, g);
                    }
                }
                layers.back[i] = b;
            }
        }
    }
}

void composite_pixel(const LayerStack& layers, int x, int y, float* rgb) {
    float t = 1.0f;
    rgb[0] = rgb[1] = rgb[2] = 0.0f;
    for (int k = 0; k < layers.count && t > 0.0f; ++k) {
        const std::size_t i = layers.at(k, x, y);
        if (layers.front[i] <= 0.0f) break;
        for (int c = 0; c < 3; ++c) rgb[c] += t * layers.rgba[4 * i + static_cast<std::size_t>(c)];
        t *= 1.0f - layers.opacity(i);
    }
}

}  // namespace lensfx::dof
