// The band filter: per ghost and band, a box blur along the centroid's path between neighbouring bands.
#include <gpu/band_filter.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include <fmt/core.h>

namespace lensfx::gpu {

namespace {

struct Point {
    double x = 0.0, y = 0.0;
};

// The brightness-weighted centroid of channel 0 (pixels, continuous); nullopt for an empty image.
std::optional<Point> centroid(const FlareImage& image) {
    double sum = 0.0, sx = 0.0, sy = 0.0;
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const auto v = static_cast<double>(std::max(0.0f, image.at(x, y, 0)));
            sum += v;
            sx += v * (x + 0.5);
            sy += v * (y + 0.5);
        }
    if (!(sum > 0.0)) return std::nullopt;
    return Point{sx / sum, sy / sum};
}

// Adds weight[c] x `image` (channel 0) averaged over copies shifted along the segment from a to b (pixel
// offsets) into `out` (RGB doubles): a gather with bilinear taps, clamped at the image's edges so that light
// beyond the border is assumed to continue rather than dropped.
void smear_along(const FlareImage& image, Point a, Point b, const std::array<double, 3>& weight, std::vector<double>& out) {
    const double length = std::hypot(b.x - a.x, b.y - a.y);
    const int samples = std::max(1, static_cast<int>(std::ceil(length * 2.0)));
    const int w = image.width, h = image.height;
    const auto fetch = [&](int x, int y) {
        return static_cast<double>(image.at(std::clamp(x, 0, w - 1), std::clamp(y, 0, h - 1), 0));
    };
    for (int s = 0; s < samples; ++s) {
        const double t = samples == 1 ? 0.5 : (s + 0.5) / samples;
        const double ox = a.x + (b.x - a.x) * t, oy = a.y + (b.y - a.y) * t;
        const int ix = static_cast<int>(std::floor(ox)), iy = static_cast<int>(std::floor(oy));
        const double fx = ox - ix, fy = oy - iy;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                // out(x) gathers image(x - offset).
                const int sx = x - ix - 1, sy = y - iy - 1;
                const double v = fx * fy * fetch(sx, sy) + (1 - fx) * fy * fetch(sx + 1, sy) +
                                 fx * (1 - fy) * fetch(sx, sy + 1) + (1 - fx) * (1 - fy) * fetch(sx + 1, sy + 1);
                if (v == 0.0) continue;
                const std::size_t i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) * 3;
                for (std::size_t c = 0; c < 3; ++c) out[i + c] += weight[c] * v / samples;
            }
    }
}

}  // namespace

FlareImage render_band_filtered(const System& system, const FlareView& view, const RenderOne& render) {
    if (view.bands <= 0) throw std::invalid_argument("--band-filter needs spectral bands (--bands N)");
    const std::vector<SpectralPass> passes = view.passes();
    const std::vector<Ghost> ghosts = selected_ghosts(system, view);
    const std::size_t pixels = static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height);
    std::vector<double> sum(pixels * 3, 0.0);
    std::vector<GhostPower> powers;

    for (const Ghost& ghost : ghosts) {
        FlareView one = view;
        one.bands = 0;
        one.only_ghosts = {{ghost.first, ghost.second}};
        std::vector<FlareImage> images;
        std::vector<std::optional<Point>> centres;
        for (const SpectralPass& pass : passes) {
            one.wavelength_nm = pass.wavelength_nm;
            images.push_back(render(one));
            centres.push_back(centroid(images.back()));
        }
        GhostPower power{ghost.first, ghost.second, {}};
        for (std::size_t i = 0; i < passes.size(); ++i) {
            if (!centres[i]) continue;
            // Halfway to the neighbours' centroids; a band without a lit neighbour stays sharp on that side.
            const Point c = *centres[i];
            Point a{0.0, 0.0}, b{0.0, 0.0};
            if (i > 0 && centres[i - 1]) a = {(centres[i - 1]->x - c.x) / 2, (centres[i - 1]->y - c.y) / 2};
            if (i + 1 < passes.size() && centres[i + 1]) b = {(centres[i + 1]->x - c.x) / 2, (centres[i + 1]->y - c.y) / 2};
            smear_along(images[i], a, b, passes[i].weight, sum);
            const auto total = images[i].total_power(one);
            for (std::size_t ch = 0; ch < 3; ++ch) power.power[ch] += passes[i].weight[ch] * total[0];
        }
        powers.push_back(power);
    }
    FlareImage out;
    out.width = view.width;
    out.height = view.height;
    out.rgb.assign(sum.begin(), sum.end());
    out.ghosts = std::move(powers);
    return out;
}

}  // namespace lensfx::gpu
