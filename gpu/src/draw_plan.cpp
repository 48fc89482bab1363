// The CPU steps of FlareRenderer::draw: selection, totals, scene culling, pass plans, batches, bands, keys.
#include <gpu/draw_plan.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

#include <gpu/flare_renderer.h>

namespace lensfx::gpu {

GhostSelection GhostSelection::of(const std::vector<Ghost>& ghosts, const std::vector<std::pair<int, int>>& draw_only,
                                  const std::vector<optics::GhostStyle>& styles) {
    GhostSelection out;
    out.drawn.assign(ghosts.size(), 1);
    if (!draw_only.empty()) {
        std::vector<std::pair<int, int>> index;  // each pair in both orders, sorted
        for (const auto& [a, b] : draw_only) {
            index.emplace_back(a, b);
            index.emplace_back(b, a);
        }
        std::sort(index.begin(), index.end());
        for (std::size_t g = 0; g < ghosts.size(); ++g)
            out.drawn[g] = std::binary_search(index.begin(), index.end(), std::pair<int, int>{ghosts[g].first, ghosts[g].second});
    }
    out.style.assign(ghosts.size(), nullptr);
    for (const optics::GhostStyle& st : styles)
        for (std::size_t g = 0; g < ghosts.size(); ++g)
            if (ghosts[g].first == std::max(st.first, st.second) && ghosts[g].second == std::min(st.first, st.second))
                out.style[g] = &st;
    return out;
}

bool GhostSelection::dark(std::size_t ghost) const {
    const optics::GhostStyle* st = style[ghost];
    return st && !(st->gain[0] > 0.0 || st->gain[1] > 0.0 || st->gain[2] > 0.0);
}

double pass_light_weight(const std::array<double, 3>& pass_weight, const std::array<double, 3>& light_scale) {
    double weight = 0.0;
    for (std::size_t c = 0; c < 3; ++c) weight += std::abs(pass_weight[c] * light_scale[c]);
    return weight;
}

std::vector<double> pass_totals(const std::vector<LightEstimates>& lights, std::size_t passes, const std::vector<char>& drawn) {
    std::vector<double> total(passes, 0.0);
    for (const LightEstimates& light : lights)
        for (std::size_t p = 0; p < light.pass.size(); ++p)
            for (std::size_t g = 0; g < light.pass[p].size(); ++g)
                if (drawn[g]) total[p] += light.pass[p][g].power;
    return total;
}

CullItem cull_item(const GhostEstimate& e, double rotation, const std::array<double, 3>& light_scale,
                   const std::array<double, 3>& pass_weight, const optics::GhostStyle* style, const FlareView& view,
                   const GhostSpread& spread) {
    // What each of R, G, B adds the ghost with (the light's irradiance and gains, the pass weight, a look's
    // gain), and what estimate_light scaled its power by (the light over the pass's channels).
    std::array<double, 3> factor{};
    for (std::size_t k = 0; k < 3; ++k) factor[k] = std::abs(pass_weight[k] * light_scale[k] * (style ? style->gain[k] : 1.0));
    const double light_weight = pass_light_weight(pass_weight, light_scale);
    // The peak per unit of those factors as drawn, and as the caller's spread leaves it: the kernel's largest
    // share of the ghost's power.
    const double pixel_w = view.sensor_width_mm / view.width, pixel_h = view.sensor_height_mm / view.height;
    const double spread_peak = spread.peak_share > 0.0 && e.power > 0.0 && light_weight > 0.0
                                   ? kSpreadPowerMargin * e.power / light_weight * spread.peak_share / (pixel_w * pixel_h)
                                   : std::numeric_limits<double>::infinity();
    // A peak of kMaxPeak (a cell folded flat) is not known: such a ghost is drawn unless spread.
    const double drawn_peak =
        e.peak > 0.0 && e.peak < kMaxPeak ? pixel_peak(e, std::min(pixel_w, pixel_h)) : std::numeric_limits<double>::infinity();
    const double peak = std::min(drawn_peak, spread_peak);
    if (e.rect.empty() || e.sensor.x1 < e.sensor.x0 || e.sensor.y1 < e.sensor.y0 || !std::isfinite(peak)) return {};
    const double c = std::cos(rotation), sn = std::sin(rotation);
    const std::array<double, 2> offset = style ? style->offset_mm : std::array<double, 2>{};
    CullItem item{1e300, 1e300, -1e300, -1e300, {}};
    for (const double sx : {e.sensor.x0, e.sensor.x1})
        for (const double sy : {e.sensor.y0, e.sensor.y1}) {
            const double up_x = offset[0] - (c * sx - sn * sy);
            const double up_y = offset[1] - (sn * sx + c * sy);
            const double px = (up_x + 0.5 * view.sensor_width_mm) / pixel_w;
            const double py = (0.5 * view.sensor_height_mm - up_y) / pixel_h;
            item = {std::min(item.x0, px), std::min(item.y0, py), std::max(item.x1, px), std::max(item.y1, py), {}};
        }
    constexpr double kSpreadPx = 20.0;  // small triangles' area coverage, a 1/16 level's bilinear upsampling, the rim band
    const double spread_px = kSpreadPx + spread.px;
    item.x0 -= spread_px;
    item.y0 -= spread_px;
    item.x1 += spread_px;
    item.y1 += spread_px;
    for (std::size_t k = 0; k < 3; ++k) item.peak[k] = peak * factor[k];
    // A caustic's spike (a pixel or two) reaches over its coarse peak when drawn; spread, its light is shared
    // out as any other, and it adds no more than its power times the kernel's largest share.
    double spike_peak = drawn_peak * caustic_spike(e);
    if (spread.peak_share > 0.0) spike_peak = std::min(spike_peak, drawn_peak * (1.0 + caustic_spike(e) * kSpikePixels * spread.peak_share));
    item.spike = std::min(spike_peak, spread_peak) / peak;
    return item;
}

LightVerdicts cull_lights(const std::vector<LightEstimates>& estimates, std::span<const ScaledLight> lights,
                          const std::vector<SpectralPass>& passes, const GhostSelection& selection,
                          const FlareView& view, const GhostSpread& spread, VisibilityMap& map) {
    const std::size_t ghosts = selection.drawn.size();
    std::vector<CullItem> items;
    for (std::size_t l = 0; l < lights.size(); ++l)
        for (std::size_t p = 0; p < passes.size(); ++p)
            for (std::size_t g = 0; g < ghosts; ++g)
                items.push_back(selection.drawn[g] ? cull_item(estimates[l].pass[p][g], estimates[l].rotation, lights[l].scale,
                                                               passes[p].weight, selection.style[g], view, spread)
                                                   : CullItem{});
    const std::vector<SceneVerdict> all = scene_cull(items, map);
    LightVerdicts verdicts(lights.size());
    auto next = all.begin();
    for (std::size_t l = 0; l < lights.size(); ++l)
        for (std::size_t p = 0; p < passes.size(); ++p) {
            verdicts[l].emplace_back(next, next + static_cast<std::ptrdiff_t>(ghosts));
            next += static_cast<std::ptrdiff_t>(ghosts);
        }
    return verdicts;
}

namespace {

// Ghosts the caller spreads over spread_level's disc: drawn at that level at least, with no sharp rim.
void coarsen_to_spread(std::vector<GhostPlan>& plans, int level) {
    for (GhostPlan& plan : plans) {
        plan.reduce = std::max(plan.reduce, level);
        plan.rim = false;
    }
}

}  // namespace

PassPlan plan_pass(const std::vector<GhostEstimate>& estimates, double total_power, const std::vector<SceneVerdict>& verdicts,
                   const GhostSelection& selection, const DetailSettings& detail, int band) {
    PassPlan out;
    out.plans = plan_ghosts(estimates, detail.accel, detail.base_grid, detail.pixel_mm, detail.per_ghost_power, total_power, verdicts,
                            detail.spread_level);
    if (detail.spread_level > 1) coarsen_to_spread(out.plans, detail.spread_level);
    for (std::size_t g = 0; g < estimates.size(); ++g) {
        if (!selection.drawn[g] || selection.dark(g)) continue;
        const SceneVerdict verdict = verdicts.empty() ? SceneVerdict::Draw : verdicts[g];
        const GhostPlan& plan = out.plans[g];
        if (!plan.draw) {
            if (band == 0) {
                ++out.skipped;
                out.culled += verdict == SceneVerdict::Cull && !estimates[g].rect.empty();
            }
            continue;
        }
        // no full-size part: neither the ghost nor its rim (drawn at 1/(reduce/kRimReduce)) is at full size
        if (band > 0 && plan.reduce != 1 && !(plan.rim && plan.reduce == kRimReduce)) continue;
        const bool faint = plan.faint;  // Faint or Veil: coarsened by plan_ghosts (no rim pass, small triangles left out)
        out.faint += band == 0 && faint;
        (faint && detail.batch_faint ? out.batched : out.todo).push_back(g);
    }
    return out;
}

namespace {

// Whether two sensor boxes (mm) lie within `tolerance` of each other, edge by edge.
bool boxes_within(const PupilRect& a, const PupilRect& b, double tolerance) {
    return std::abs(a.x0 - b.x0) <= tolerance && std::abs(a.x1 - b.x1) <= tolerance && std::abs(a.y0 - b.y0) <= tolerance &&
           std::abs(a.y1 - b.y1) <= tolerance;
}

// Whether a host's plan draws a ghost at least as finely as another pass's: no coarser level, no fewer cells (a Veil
// in the host's pass, drawn coarser still, takes no Faint pass's light).
bool draws_as_finely(const GhostPlan& host, const GhostPlan& other) { return host.reduce <= other.reduce && host.grid >= other.grid; }

// Whether the host's draw of a ghost may also draw another pass's: at least as finely, and in every band the other
// would be drawn in. A reduced faint ghost is drawn with the first band only (plan_pass), so one merged into a
// full-size host would lose its light in every later band of a frame drawn in bands (an 8K frame): a full-size host
// takes full-size passes only.
bool may_host(const GhostPlan& host, const GhostPlan& other) {
    return draws_as_finely(host, other) && (host.reduce == 1) == (other.reduce == 1);
}

// The pass that hosts ghost g's faint light: the first pass of `order` (the middle first) that draws it batched,
// passed over for each later one that may host it and draws it more finely (so that the passes it lands with may
// merge into it: may_host); order.end() when no pass draws it batched.
std::vector<std::size_t>::const_iterator host_pass(const std::vector<std::size_t>& order, const std::vector<std::vector<char>>& batched,
                                                   const std::vector<PassPlan>& plans, std::size_t g) {
    auto host = std::find_if(order.begin(), order.end(), [&](std::size_t p) { return batched[p][g] != 0; });
    if (host == order.end()) return host;
    for (auto it = std::next(host); it != order.end(); ++it) {
        const GhostPlan& candidate = plans[*it].plans[g];
        const GhostPlan& so_far = plans[*host].plans[g];
        if (batched[*it][g] && may_host(candidate, so_far) && !draws_as_finely(so_far, candidate)) host = it;
    }
    return host;
}

}  // namespace

MergedFaint merge_faint_passes(std::vector<PassPlan>& plans, const LightEstimates& estimates, const std::vector<SpectralPass>& passes,
                               const std::array<double, 3>& light_scale, double pixel_mm) {
    MergedFaint out;
    const std::size_t ghosts = plans.empty() ? 0 : plans.front().plans.size();
    // Each pass's batched ghosts as a mask, what its powers were scaled by and its own weights for every ghost.
    std::vector<std::vector<char>> batched(plans.size(), std::vector<char>(ghosts, 0));
    std::vector<double> scaled_by(plans.size());
    for (std::size_t p = 0; p < plans.size(); ++p) {
        for (const std::size_t g : plans[p].batched) batched[p][g] = 1;
        scaled_by[p] = pass_light_weight(passes[p].weight, light_scale);
        out.weight.emplace_back(ghosts, passes[p].weight);
    }
    // The passes from the middle outwards: a ghost's host is the first that draws it batched, or a finer one (host_pass).
    std::vector<std::size_t> order(plans.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    const auto middle = static_cast<std::ptrdiff_t>(plans.size() / 2);
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return std::abs(static_cast<std::ptrdiff_t>(a) - middle) < std::abs(static_cast<std::ptrdiff_t>(b) - middle);
    });
    for (std::size_t g = 0; g < ghosts; ++g) {
        const auto host = host_pass(order, batched, plans, g);
        if (host == order.end()) continue;
        const std::size_t h = *host;
        const GhostEstimate& at_host = estimates.pass[h][g];
        const double host_power = at_host.power / scaled_by[h];
        if (!(host_power > 0.0) || !std::isfinite(host_power)) continue;
        const double tolerance = kMergeShiftPx * pixel_mm * plans[h].plans[g].reduce;
        for (const std::size_t p : order) {
            const GhostEstimate& e = estimates.pass[p][g];
            if (p == h || !batched[p][g] || !may_host(plans[h].plans[g], plans[p].plans[g]) || !boxes_within(e.sensor, at_host.sensor, tolerance))
                continue;
            const double ratio = e.power / scaled_by[p] / host_power;  // the ghost's power here over the host's
            if (!std::isfinite(ratio)) continue;
            for (std::size_t c = 0; c < 3; ++c) out.weight[h][g][c] += passes[p].weight[c] * ratio;
            batched[p][g] = 0;
            ++out.merged;
        }
    }
    for (std::size_t p = 0; p < plans.size(); ++p) std::erase_if(plans[p].batched, [&](std::size_t g) { return !batched[p][g]; });
    return out;
}

bool splits_interior(const GhostPlan& plan) { return !plan.area_coverage && !plan.rim_pass() && !plan.faint; }

std::size_t triangle_indices(const GhostPlan& plan) {
    const auto cells = static_cast<std::size_t>(plan.grid) * static_cast<std::size_t>(plan.grid);
    return plan.area_coverage ? 0 : splits_interior(plan) ? 12 * cells : 6 * cells;
}

std::vector<std::vector<BatchJob>> batch_ghosts(const std::vector<std::size_t>& todo, const std::vector<GhostPlan>& plans,
                                                std::size_t capacity, bool per_ghost_power) {
    std::vector<std::vector<BatchJob>> batches;
    for (std::size_t next = 0; next < todo.size();) {
        std::vector<BatchJob> batch;
        std::size_t used = 0, indices = 0;
        while (next < todo.size()) {
            const std::size_t g = todo[next];
            const auto side = static_cast<std::size_t>(plans[g].grid + 1);
            if (!batch.empty() && (per_ghost_power || used + side * side > capacity)) break;
            batch.push_back({g, used, indices});
            used += side * side;
            indices += triangle_indices(plans[g]);
            ++next;
        }
        batches.push_back(std::move(batch));
    }
    return batches;
}

std::vector<std::vector<FaintRun>> batch_faint(const std::vector<std::size_t>& batched, const std::vector<GhostPlan>& plans,
                                               std::size_t capacity, int band) {
    std::vector<std::size_t> order;
    for (std::size_t g : batched)
        if (band == 0 || plans[g].reduce == 1) order.push_back(g);  // the reduced targets are drawn with band 0
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return std::pair{plans[a].reduce, plans[a].grid} < std::pair{plans[b].reduce, plans[b].grid};
    });
    std::vector<std::vector<FaintRun>> chunks;
    std::size_t vertices = 0, indices = 0, jobs = 0;
    for (std::size_t g : order) {
        const auto side = static_cast<std::size_t>(plans[g].grid + 1);
        const auto cells = static_cast<std::size_t>(plans[g].grid) * static_cast<std::size_t>(plans[g].grid);
        if (chunks.empty() || vertices + side * side > capacity) {  // a new chunk
            chunks.emplace_back();
            vertices = indices = jobs = 0;
        }
        std::vector<FaintRun>& runs = chunks.back();
        if (runs.empty() || runs.back().grid != plans[g].grid || runs.back().reduce != plans[g].reduce)
            runs.push_back({plans[g].grid, plans[g].reduce, {}, jobs, vertices, indices});
        runs.back().ghosts.push_back(g);
        vertices += side * side;
        indices += 6 * cells;
        ++jobs;
    }
    return chunks;
}

FullBands full_target_bands(int width, int height, double max_bytes, bool whole) {
    FullBands b;
    b.image_rows = height;
    const double bytes = 16.0 * width * height;
    if (!whole && max_bytes > 0.0 && bytes > max_bytes)
        b.count = static_cast<int>(std::min<double>(height, std::ceil(bytes / max_bytes)));
    b.rows_per_band = (height + b.count - 1) / b.count;
    b.count = (height + b.rows_per_band - 1) / b.rows_per_band;  // no empty band
    return b;
}

std::uint64_t ghosts_key(const System& system, const std::vector<Ghost>& ghosts) {
    flare::KeyHash key{system_hash(system)};
    for (const Ghost& ghost : ghosts) {
        key.num(static_cast<std::int64_t>(ghost.first));
        key.num(static_cast<std::int64_t>(ghost.second));
    }
    return key.h;
}

std::uint64_t bounds_table_key(std::uint64_t ghosts_key, const std::vector<SpectralPass>& passes, double sensor_radius_mm) {
    flare::KeyHash key{ghosts_key};
    for (const SpectralPass& pass : passes) key.num(pass.wavelength_nm);
    key.num(sensor_radius_mm);
    return key.h;
}

}  // namespace lensfx::gpu
