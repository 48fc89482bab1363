// The band filter: per ghost and band, a box blur along the centroid's path between neighbouring bands.
#include <gpu/band_filter.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include <fmt/core.h>

#include <optics/ghosts.h>

namespace lensfx::gpu {

namespace {

// The band filter's share of the ghosts (split_by_brightness).
constexpr double kFilteredPowerShare = 0.999;
constexpr std::size_t kMaxFilteredGhosts = 32;

struct Point {
    double x = 0.0, y = 0.0;
};

// Pixels [x0, x1) x [y0, y1) of an image.
struct Box {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

// Where a ghost's image lies: the brightness-weighted centroid of channel 0 (pixels, continuous), the box
// of its lit pixels and their sum.
struct Lit {
    Point centre;
    Box box;
    double sum = 0.0;
};

// The ghost's centroid and lit box; nullopt for an empty image.
std::optional<Lit> lit_part(const FlareImage& image) {
    double sum = 0.0, sx = 0.0, sy = 0.0;
    Box box{image.width, image.height, 0, 0};
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const auto v = static_cast<double>(std::max(0.0f, image.at(x, y, 0)));
            if (v == 0.0) continue;
            sum += v;
            sx += v * (x + 0.5);
            sy += v * (y + 0.5);
            box = {std::min(box.x0, x), std::min(box.y0, y), std::max(box.x1, x + 1), std::max(box.y1, y + 1)};
        }
    if (!(sum > 0.0)) return std::nullopt;
    return Lit{{sx / sum, sy / sum}, box, sum};
}

// The pixels a smear of `lit` by offsets along a..b can reach: the lit box grown by the longest offset and
// the bilinear taps, within the image (the edge-clamped taps of a box touching an edge stay inside it).
Box smear_reach(const Box& lit, Point a, Point b, int width, int height) {
    const int grow_x = static_cast<int>(std::ceil(std::max(std::abs(a.x), std::abs(b.x)))) + 2;
    const int grow_y = static_cast<int>(std::ceil(std::max(std::abs(a.y), std::abs(b.y)))) + 2;
    return {std::max(0, lit.x0 - grow_x), std::max(0, lit.y0 - grow_y), std::min(width, lit.x1 + grow_x),
            std::min(height, lit.y1 + grow_y)};
}

// Channel 0 of `image` over `box`, a plane of box-width x box-height doubles.
std::vector<double> plane_of(const FlareImage& image, const Box& box) {
    const int w = box.x1 - box.x0;
    std::vector<double> plane(static_cast<std::size_t>(w) * static_cast<std::size_t>(box.y1 - box.y0));
    for (int y = box.y0; y < box.y1; ++y)
        for (int x = box.x0; x < box.x1; ++x)
            plane[static_cast<std::size_t>(y - box.y0) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x - box.x0)] =
                static_cast<double>(image.at(x, y, 0));
    return plane;
}

// to(x) = mix x from(x) + (1 - mix) x from(x - o): a gather with bilinear taps over a w x h plane, clamped at its
// edges (the reach's edges are dark, or the image's, beyond which light is assumed to continue).
void shifted_mix(const std::vector<double>& from, int w, int h, Point o, double mix, std::vector<double>& to) {
    const int ix = static_cast<int>(std::floor(o.x)), iy = static_cast<int>(std::floor(o.y));
    const double fx = o.x - ix, fy = o.y - iy;
    const auto fetch = [&](int x, int y) {
        return from[static_cast<std::size_t>(std::clamp(y, 0, h - 1)) * static_cast<std::size_t>(w) + static_cast<std::size_t>(std::clamp(x, 0, w - 1))];
    };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const int sx = x - ix - 1, sy = y - iy - 1;
            const double v = fx * fy * fetch(sx, sy) + (1 - fx) * fy * fetch(sx + 1, sy) + fx * (1 - fy) * fetch(sx, sy + 1) +
                             (1 - fx) * (1 - fy) * fetch(sx + 1, sy + 1);
            const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
            to[i] = mix * from[i] + (1 - mix) * v;
        }
}

// Adds weight[c] x `image` (channel 0) averaged over N copies shifted along the segment from a to b (pixel
// offsets, at most half a pixel apart, N a power of two) into `out` (RGB doubles) over `reach` (smear_reach:
// no other pixel receives light). The N copies are made in log2(N) + 1 passes over the reach: the first
// shifts to the first copy, each next one averages what it has with itself shifted by 1, 2, 4, ... copy
// steps (a box of 2^k taps is k two-tap boxes in a row), so a long smear over a frame-wide ghost costs a few
// passes rather than one per copy.
void smear_along(const FlareImage& image, Point a, Point b, const Box& reach, const std::array<double, 3>& weight,
                 std::vector<double>& out) {
    const double length = std::hypot(b.x - a.x, b.y - a.y);
    int copies = 1;
    while (copies < 2.0 * length) copies *= 2;
    const Point step{(b.x - a.x) / copies, (b.y - a.y) / copies};
    const int w = reach.x1 - reach.x0, h = reach.y1 - reach.y0;
    std::vector<double> plane = plane_of(image, reach), next(plane.size());
    shifted_mix(plane, w, h, {a.x + step.x / 2, a.y + step.y / 2}, 0.0, next);
    for (int span = 1; span < copies; span *= 2) {
        plane.swap(next);
        shifted_mix(plane, w, h, {step.x * span, step.y * span}, 0.5, next);
    }
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double v = next[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)];
            if (v == 0.0) continue;
            const std::size_t i = (static_cast<std::size_t>(y + reach.y0) * static_cast<std::size_t>(image.width) +
                                   static_cast<std::size_t>(x + reach.x0)) * 3;
            for (std::size_t c = 0; c < 3; ++c) out[i + c] += weight[c] * v;
        }
}

// Halfway from `c` towards a neighbouring band's centroid (an offset); none without a lit neighbour (that
// side stays sharp).
Point halfway(const std::optional<Lit>& neighbour, Point c) {
    if (!neighbour) return {0.0, 0.0};
    return {(neighbour->centre.x - c.x) / 2, (neighbour->centre.y - c.y) / 2};
}

// The ghosts to filter: the view's, or those of them in draw_only (either order of a pair).
std::vector<Ghost> ghosts_to_draw(const System& system, const FlareView& view, const std::vector<std::pair<int, int>>& draw_only) {
    std::vector<Ghost> ghosts = selected_ghosts(system, view);
    if (draw_only.empty()) return ghosts;
    std::erase_if(ghosts, [&](const Ghost& g) {
        return std::none_of(draw_only.begin(), draw_only.end(), [&](const std::pair<int, int>& p) {
            return (p.first == g.first && p.second == g.second) || (p.first == g.second && p.second == g.first);
        });
    });
    return ghosts;
}

// A ghost pair as the renderers take it.
std::pair<int, int> pair_of(const Ghost& g) { return {g.first, g.second}; }

// The ghosts smeared one by one (the brightest along the axis at the d line, together holding
// kFilteredPowerShare of the ghosts' axial power, at most kMaxFilteredGhosts of them) and the rest, drawn
// together one render per band: a zoom lens's hundreds of faint ghosts cost a few renders, not one each per
// band, and their smear would not show.
struct GhostSplit {
    std::vector<Ghost> filtered, plain;
};
GhostSplit split_by_brightness(const System& system, const std::vector<Ghost>& ghosts) {
    const optics::TraceSystem traced(system, optics::kLambdaD_nm);
    std::vector<std::pair<double, std::size_t>> order;
    double total = 0.0;
    for (std::size_t g = 0; g < ghosts.size(); ++g) {
        const double factor = optics::ghost_axial_factor(traced, ghosts[g]);
        order.emplace_back(std::isfinite(factor) && factor > 0.0 ? factor : 0.0, g);
        total += order.back().first;
    }
    std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    GhostSplit split;
    double held = 0.0;
    for (const auto& [factor, g] : order) {
        const bool enough = split.filtered.size() >= kMaxFilteredGhosts || (held >= kFilteredPowerShare * total && total > 0.0);
        (enough ? split.plain : split.filtered).push_back(ghosts[g]);
        held += factor;
    }
    return split;
}

// The plain ghosts, all of them in one render per band, weighted into `sum` unsmeared; their powers where the
// renderer gave them (per-ghost power).
void add_plain_bands(const std::vector<Ghost>& plain, const std::vector<SpectralPass>& passes, FlareView band, const RenderOne& render,
                     std::vector<double>& sum, std::vector<GhostPower>& powers) {
    if (plain.empty()) return;
    std::vector<std::pair<int, int>> pairs;
    for (const Ghost& g : plain) pairs.push_back(pair_of(g));
    const std::size_t first_power = powers.size();
    for (const SpectralPass& pass : passes) {
        band.wavelength_nm = pass.wavelength_nm;
        const FlareImage image = render(band, pairs);
        for (std::size_t i = 0; i < sum.size(); ++i) sum[i] += pass.weight[i % 3] * static_cast<double>(image.rgb[i - i % 3]);
        for (const GhostPower& g : image.ghosts) {
            auto it = std::find_if(powers.begin() + static_cast<std::ptrdiff_t>(first_power), powers.end(),
                                   [&](const GhostPower& p) { return p.first == g.first && p.second == g.second; });
            if (it == powers.end()) it = powers.insert(powers.end(), GhostPower{g.first, g.second, {}});
            for (std::size_t ch = 0; ch < 3; ++ch) it->power[ch] += pass.weight[ch] * g.power[0];
        }
    }
}

}  // namespace

FlareImage render_band_filtered(const System& system, const FlareView& view, const RenderOne& render,
                                const std::vector<std::pair<int, int>>& draw_only) {
    if (view.bands <= 0) throw std::invalid_argument("--band-filter needs spectral bands (--bands N)");
    const std::vector<SpectralPass> passes = view.passes();
    const GhostSplit ghosts = split_by_brightness(system, ghosts_to_draw(system, view, draw_only));
    const std::size_t pixels = static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height);
    std::vector<double> sum(pixels * 3, 0.0);
    std::vector<GhostPower> powers;

    FlareView band = view;
    band.bands = 0;
    // A band of a ghost: its image (dropped when unlit) and where it lies.
    struct Rendered {
        FlareImage image;
        std::optional<Lit> lit;
    };
    const auto render_band = [&](const Ghost& ghost, std::size_t i) {
        band.wavelength_nm = passes[i].wavelength_nm;
        Rendered r{render(band, {pair_of(ghost)}), std::nullopt};
        r.lit = lit_part(r.image);
        if (!r.lit) r.image = {};
        return r;
    };
    for (const Ghost& ghost : ghosts.filtered) {
        // Three bands held at a time (the one smeared and its neighbours), whatever the band count.
        std::optional<Rendered> before, next;
        Rendered now = render_band(ghost, 0);
        GhostPower power{ghost.first, ghost.second, {}};
        for (std::size_t i = 0; i < passes.size(); ++i) {
            next = i + 1 < passes.size() ? std::optional<Rendered>(render_band(ghost, i + 1)) : std::nullopt;
            if (now.lit) {
                const Point c = now.lit->centre;
                const Point a = before ? halfway(before->lit, c) : Point{};
                const Point b = next ? halfway(next->lit, c) : Point{};
                smear_along(now.image, a, b, smear_reach(now.lit->box, a, b, view.width, view.height), passes[i].weight, sum);
                const double total = now.lit->sum * band.pixel_area_mm2();
                for (std::size_t ch = 0; ch < 3; ++ch) power.power[ch] += passes[i].weight[ch] * total;
            }
            before = std::move(now);
            if (next) now = std::move(*next);
        }
        powers.push_back(power);
    }
    add_plain_bands(ghosts.plain, passes, band, render, sum, powers);
    FlareImage out;
    out.width = view.width;
    out.height = view.height;
    out.rgb.assign(sum.begin(), sum.end());
    out.ghosts = std::move(powers);
    return out;
}

RenderOne render_one_on(FlareRenderer& renderer, const System& system, const GpuFlareOptions& options) {
    return [&renderer, &system, options](const FlareView& band, const std::vector<std::pair<int, int>>& ghosts) {
        GpuFlareOptions one = options;
        one.draw_only = ghosts;
        return renderer.render(system, band, one);
    };
}

}  // namespace lensfx::gpu
