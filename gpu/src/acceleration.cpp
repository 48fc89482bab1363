// Ghost renderer accelerations: per-ghost plans, the system hash and the bounds table's disk cache.
#include <gpu/acceleration.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <system_error>

#include <flare/cache.h>
#include <fmt/core.h>

namespace lensfx::gpu {

Bounding parse_bounding(const std::string& text) {
    if (text == "table") return Bounding::Table;
    if (text == "coarse") return Bounding::Coarse;
    if (text == "none") return Bounding::None;
    throw std::invalid_argument(fmt::format("--bounding {}: table, coarse or none expected", text));
}

const char* to_string(Bounding bounding) {
    switch (bounding) {
        case Bounding::Table: return "table";
        case Bounding::Coarse: return "coarse";
        case Bounding::None: return "none";
    }
    return "?";
}

namespace {

// Adaptive grid: cells whose sensor areas vary by less than kSmoothCv (nearly an affine map, which the
// linear triangles reproduce exactly) get half the base grid; above kSharpCv (caustics) each doubling
// of the variation doubles the grid, up to kMaxLevel doublings (more bought no measurable accuracy at
// 32x32-pixel blocks, `lensfx bench time-vs-error`). Distorted cells never get less than the base.
constexpr double kSmoothCv = 0.1;
constexpr double kSharpCv = 0.8;
constexpr int kMaxLevel = 1;
constexpr int kMinGrid = 16;
constexpr int kMaxGrid = 512;
// Outline rule: ghosts whose light passes through a small part of their rectangle, or whose outline the
// renderer resolves only at its cells (failed rays: such cells are dropped whole; the iris: clipped on
// interpolated stop coordinates), get a finer grid: enough that the passing part holds at least
// kMinFill * base^2 cells and that, at base 16, those outlines stay under kFailedShare and kIrisShare of
// its cells (the shares shrink in proportion at a larger base); never less than the cell-area rule's grid,
// at most kMaxRefine times the base. The shares are fitted to the two ghosts that the cell-area rule alone
// drew 41% and 21% off (docs/acceleration.md); giving every ghost base^2 passing cells bought no
// measurable accuracy on five presets (bench_flare) at up to 1.8 times the time.
constexpr double kMinFill = 0.25;
constexpr double kFailedShare = 0.08;
constexpr double kIrisShare = 0.6;
constexpr int kMaxRefine = 8;
// Outlines cut by a lens's rim (vignetting) are clipped per pixel on the relative radius interpolated over
// each cell; where the map from pupil to sensor bends (the cells' areas vary), a coarse cell puts that cut far
// from the true rim: a polygonal or ragged outline, and vignetted regions with straight sides. Such outlines
// stay under kRimShare of the cells at base 16 (failed rays: kFailedShare), but cells no smaller than kRimCellPx
// pixels on the sensor (finer only moves the cut within a pixel). Only for ghosts whose cells' areas vary
// (cv from kSmoothCv): a nearly affine map interpolates the radius well, and most ghosts of a vignetting lens
// have such cuts (pbrt's dgauss.50mm at the CandleGlass flame's angle: all but a few). Not in a footprint
// group (spread_level > 1), where the light's footprint blurs the outline. Fitted to two ghosts of that lens
// at (-5.8, 1.5) degrees, 1000 px wide: 5,7 (rim_edge 5.0, cv 0.62, 533 px) and 7,9 (3.4, cv 0.28, 1300 px)
// showed straight-sided vignetting and a ragged rim at 16 cells, and match a 512^2-ray reference by eye from
// about 48 (docs/acceleration.md; RimRule.VignettedGhostKeepsItsShapeAtDefault).
constexpr double kRimShare = 0.12;
constexpr double kRimCellPx = 4.0;
// Intensity LOD: ghosts under kFullShare of the estimated total get a grid scaled by sqrt(share/kFullShare).
constexpr double kFullShare = 0.01;
// Reduced drawing: smooth ghosts (cells this uniform) at least this many pixels across at 1/2, 1/4, 1/8,
// 1/16 of the image size (their edges soften by at most 2 % of their size); ghosts with caustics only when
// they are so large that the softening (2 pixels at 1/2, 4 at 1/4) is under 0.2 % of their size.
constexpr double kHalfExtentPx = 96.0;
constexpr double kQuarterExtentPx = 256.0;
constexpr double kEighthExtentPx = 1024.0;
constexpr double kSixteenthExtentPx = 2048.0;
constexpr double kReducedMaxCv = 0.3;
constexpr double kSharpHalfExtentPx = 1024.0;
constexpr double kSharpQuarterExtentPx = 2048.0;

// A faint ghost (scene culling: its peak alone under what the frame shows there) is drawn at the most
// reduced level that keeps at least kFaintCells of its level's pixels across it, whatever its smoothness.
// Its grid is coarsened to kMinGrid (kept where its outline has failed rays: failed_outline): 8 or 4 cells for
// every faint ghost lost light along the outline (pan1080, canon-70-200: 0.09% and 1.6% of 8-bit sRGB values 2
// codes off, against under 0.02% at 16).
constexpr double kFaintCells = 64.0;
// The most reduced level a faint ghost is drawn at: 1/32 (a ghost at least 2048 px across). Its fragments were
// most of a faint ghost's cost (canon-70-200 on pan1080: 943 faint draws at 1/16, ~0.3 s of raster into a
// 120 x 68 target that a ghost wider than the frame covers whole), and 1/32 has a quarter of them.
constexpr int kFaintMaxReduce = 32;
// A faint ghost whose coarse pass found no outline of failed rays (no cell with some corners passing and
// some not) loses no light along its outline to whole dropped cells: its outline is cut per pixel (r_rel, the
// iris), so a coarser grid changes only how finely its shading is sampled. Such a ghost, when also smooth
// (cells too uneven to draw reduced keep kMinGrid), gets kFaintOpenGrid cells: a quarter of the rays and of the
// vertex work at 16 (canon-70-200 on pan1080 at physical strength: 954 of its 1299 faint draws).
constexpr int kFaintOpenGrid = 8;
bool open_outline(const GhostEstimate& e) { return e.failed_edge == 0.0 && e.area_cv < kReducedMaxCv; }
// A faint ghost whose outline has failed rays keeps the grid the outline rule gives it: the cells dropped
// whole along that outline lose light that its coarse peak does not bound (rays that nearly fail, near total
// internal reflection, crowd into a bright edge there). Desk.exr, canon-70-200, gain 1: one such ghost (peak
// 0.7 of a code, failed_edge 2.7, its grid 51 coarsened to 16) left an 8-bit sRGB value 5 codes dark; with its
// grid kept, 4 at most over the frame, for ~0.1 CPU s on the 1080p stage frame.
bool failed_outline(const GhostEstimate& e) { return e.failed_edge > 0.0; }

// Area coverage (GhostPlan::area_coverage) for a ghost whose mean triangle is under kAreaCoveragePx pixels of
// its level, and every ghost whose sensor box is not known (a render without accelerations, e.g. the dense
// reference). Point sampling (a pixel takes its centre's value) gives the same where triangles are well over a
// pixel, at less than half the cost; at about a pixel it samples the mesh's shading unevenly and hands
// sub-pixel triangles over to their own draw, and both show (rings beating against the pixels, a seam). A
// caustic ghost on the default grid keeps point sampling: its triangles are large but at the caustic, and
// area coverage there cost canon-70-200's 49 caustic ghosts some 40% of a 1080p frame for a structure error
// 0.005 lower (docs/benchmarks.md, look7).
constexpr double kAreaCoveragePx = 16.0;

// A ghost's mean triangle on the sensor (mm^2) at `grid` cells a side: its sensor box over the triangles of
// the passing part of its rectangle. 0 when the box is not known.
double mean_triangle_mm2(const GhostEstimate& e, int grid) {
    const double box = (e.sensor.x1 - e.sensor.x0) * (e.sensor.y1 - e.sensor.y0);
    if (!(box > 0.0) || !std::isfinite(box)) return 0.0;
    return box / (2.0 * std::max(e.fill, 1e-4) * static_cast<double>(grid) * grid);
}

// A Veil (SceneVerdict::Veil) is drawn at the most reduced level that keeps kVeilCells of its level's pixels
// across it: its outline blurs by up to a quarter of its size, which moves no value by more than its peak, at
// most kVeilRatio of a code. Most Veils are wider than the frame, so they go from 1/8 or 1/16 to 1/32, where a
// faint ghost's cost was its fragments (canon-70-200 on pan1080: the faint draws' fragment-shader invocations
// 13.5 million, 5 million pixels written).
constexpr double kVeilCells = 16.0;

// The most reduced level (up to kFaintMaxReduce) that keeps `cells` of its pixels across a ghost extent_px wide.
int faint_reduce(double extent_px, double cells) {
    int reduce = 1;
    while (reduce < kFaintMaxReduce && extent_px / (2 * reduce) >= cells) reduce *= 2;
    return reduce;
}

// A ghost's size on the sensor (mm): its extent, or where it has none its sensor box's larger side (a sliver
// ghost, with no whole coarse cell, has an extent of 0 and its box from the finer pass that found its peak,
// learn_peak; drawn as if small, one 2000 px across cost 40 ms at full size).
double sensor_size_mm(const GhostEstimate& e) {
    if (e.extent_mm > 0.0) return e.extent_mm;
    const double box = std::max(e.sensor.x1 - e.sensor.x0, e.sensor.y1 - e.sensor.y0);
    return std::isfinite(box) ? std::max(box, 0.0) : 0.0;
}

}  // namespace

int spread_level(const GhostSpread& spread) {
    if (!(spread.peak_share > 0.0 && spread.peak_share < 1.0)) return 1;
    const double radius_px = std::sqrt(1.0 / (std::numbers::pi * spread.peak_share));
    int level = 1;
    while (level < 16 && 2.0 * level <= 0.25 * radius_px) level *= 2;
    return level;
}

double pixel_peak(const GhostEstimate& e, double pixel_mm) {
    // A ring crossing a pixel slantwise lies over up to sqrt(2) of its side; beside it, the whole cells' light.
    const double ring = std::min(e.edge_peak, e.peak + std::numbers::sqrt2 * e.edge_line / pixel_mm);
    return std::max(e.peak, ring);
}

double caustic_spike(const GhostEstimate& e) {
    return e.area_cv >= kReducedMaxCv ? kCausticSpike : 1.0;
}

namespace {

// The level a ghost is drawn at (1, 2, 4, 8 or 16; a faint one up to kFaintMaxReduce): smooth ghosts from
// kHalfExtentPx across, ghosts with caustics only when very large.
int drawn_level(const GhostEstimate& e, double pixel_mm, SceneVerdict verdict) {
    if (verdict == SceneVerdict::Faint) return faint_reduce(sensor_size_mm(e) / pixel_mm, kFaintCells);
    if (verdict == SceneVerdict::Veil) return faint_reduce(sensor_size_mm(e) / pixel_mm, kVeilCells);
    const double extent_px = e.extent_mm / pixel_mm;
    if (e.area_cv >= kReducedMaxCv) return extent_px >= kSharpQuarterExtentPx ? 4 : extent_px >= kSharpHalfExtentPx ? 2 : 1;
    return extent_px >= kSixteenthExtentPx ? 16
           : extent_px >= kEighthExtentPx  ? 8
           : extent_px >= kQuarterExtentPx ? 4
           : extent_px >= kHalfExtentPx    ? 2
                                           : 1;
}

// How the adaptive grid sees a ghost's lens rims: drawn sharp, at pixel_mm per pixel, or not (no rim term).
struct RimOutline {
    bool sharp = false;
    double pixel_mm = 0.0;
};

// The adaptive grid: the cell-area rule, then the outline rule (failed rays, the iris, lens rims as `rim`
// sees them, thin ghosts).
int adaptive_grid(const GhostEstimate& e, int base_grid, const RimOutline& rim) {
    int grid = base_grid;
    if (e.area_cv < kSmoothCv) {
        grid = std::max(std::min(kMinGrid, base_grid), base_grid / 2);
    } else if (e.area_cv > kSharpCv) {
        const int level = std::min(kMaxLevel, static_cast<int>(std::ceil(std::log2(e.area_cv / kSharpCv))));
        grid = std::max(base_grid, std::min(kMaxGrid, base_grid << level));
    }
    const double across = std::sqrt(std::clamp(e.fill, 1e-4, 1.0));  // passing share of a grid row
    const double scale = static_cast<double>(base_grid) / kMinGrid;
    double edges = std::max(e.failed_edge / kFailedShare, e.iris_edge / kIrisShare);
    // Rim outlines (kRimShare) where the map bends, down to cells of kRimCellPx at the rim's pixel size (one of
    // no size has no rim term either)
    if (e.rim_edge > 0.0 && e.area_cv >= kSmoothCv && rim.sharp && rim.pixel_mm > 0.0)
        edges = std::max(edges, std::min(e.rim_edge / kRimShare, e.extent_mm / rim.pixel_mm / kRimCellPx * across / scale));
    // (bounded before the cast: a cached outline may be as long as the table allows, 1e9)
    int refined = static_cast<int>(std::ceil(std::min(scale * edges / across, 1e6)));
    if (e.fill < kMinFill) refined = std::max(refined, static_cast<int>(std::ceil(base_grid * std::sqrt(kMinFill) / across)));
    if (refined > grid) grid = std::min(refined, std::max(grid, std::min(kMaxGrid, kMaxRefine * base_grid)));
    return grid;
}

}  // namespace

std::vector<GhostPlan> plan_ghosts(const std::vector<GhostEstimate>& estimates, const Acceleration& accel,
                                   int base_grid, double pixel_mm, bool per_ghost_power, double total_power,
                                   const std::vector<SceneVerdict>& verdicts, int spread_level) {
    std::vector<GhostPlan> plans(estimates.size());
    double total = total_power;
    if (!(total > 0.0))
        for (const GhostEstimate& e : estimates) total += e.power;
    std::vector<std::size_t> order(estimates.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return estimates[a].power > estimates[b].power; });
    std::vector<int> rank(estimates.size());
    for (std::size_t r = 0; r < order.size(); ++r) rank[order[r]] = static_cast<int>(r);

    for (std::size_t g = 0; g < estimates.size(); ++g) {
        const GhostEstimate& e = estimates[g];
        GhostPlan& plan = plans[g];
        if (e.rect.empty()) continue;
        const double share = total > 0.0 ? e.power / total : 1.0;
        if (accel.lod && (share < accel.ghost_threshold || (accel.max_ghosts > 0 && rank[g] >= accel.max_ghosts))) {
            continue;
        }
        const SceneVerdict verdict = g < verdicts.size() ? verdicts[g] : SceneVerdict::Draw;
        if (verdict == SceneVerdict::Cull) continue;
        const bool veil = verdict == SceneVerdict::Veil;
        const bool faint = verdict == SceneVerdict::Faint || verdict == SceneVerdict::Spiky || veil;
        // A faint ghost with caustics (cells too uneven to draw reduced) may peak far above its coarse cells'
        // estimate in a pixel or two: where that spike could show (Spiky) it keeps its small triangles and the level a
        // sharp ghost gets (nikon-80-200, pan1080, --gain 20: a 7-code spike otherwise).
        const bool smooth_faint = verdict == SceneVerdict::Faint || veil;
        plan.draw = true;
        plan.rim = !faint;
        plan.small_apart = !smooth_faint;
        plan.faint = smooth_faint;
        if (accel.reduced && !per_ghost_power && pixel_mm > 0.0) plan.reduce = drawn_level(e, pixel_mm, verdict);
        // The finest level its outline is seen at: its rim pass's, and never finer than the caller's spread.
        const int outline_level = std::max(spread_level, plan.rim_pass() ? plan.reduce / kRimReduce : plan.reduce);
        // Rim outlines are drawn finer only for ghosts with a full share of the light and not spread (adaptive_grid)
        const bool sharp_rim = spread_level == 1 && !(accel.lod && share < kFullShare);
        int grid = accel.adaptive ? adaptive_grid(e, base_grid, RimOutline{sharp_rim, pixel_mm * outline_level}) : base_grid;
        if (accel.lod && share < kFullShare) {
            grid = std::clamp(static_cast<int>(std::ceil(grid * std::sqrt(share / kFullShare))), std::min(kMinGrid, grid),
                              grid);
        }
        if (faint && !failed_outline(e)) grid = std::min(grid, std::max(kMinGrid, base_grid / 2));
        // A smooth Veil's light lost along an outline of failed rays is at most a few times its peak (Desk.exr's
        // failed_outline ghost: 7 times), a third of a code: kFaintOpenGrid whatever its outline. One with caustics
        // keeps kMinGrid, the grid its spike (kCausticSpike) was measured on.
        if (smooth_faint && (open_outline(e) || (veil && e.area_cv < kReducedMaxCv))) grid = std::min(grid, kFaintOpenGrid);
        plan.grid = grid;
        const double level_pixel_mm = pixel_mm * plan.reduce;
        plan.area_coverage =
            plan.small_apart && !(mean_triangle_mm2(e, grid) >= kAreaCoveragePx * level_pixel_mm * level_pixel_mm);
    }
    return plans;
}

namespace {

// The cells of `map` under an item's box, clipped to the image; empty (c1 <= c0) when it lies off the image.
struct CellRange {
    int c0 = 0, r0 = 0, c1 = 0, r1 = 0;
    bool empty() const { return c1 <= c0 || r1 <= r0; }
};
CellRange cells_under(const CullItem& item, const VisibilityMap& map) {
    auto clamp_to = [](double v, int hi) { return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(hi))); };
    const double cell = map.cell;
    return {clamp_to(std::floor(item.x0 / cell), map.cols), clamp_to(std::floor(item.y0 / cell), map.rows),
            clamp_to(std::ceil(item.x1 / cell), map.cols), clamp_to(std::ceil(item.y1 / cell), map.rows)};
}

bool item_known(const CullItem& item) {
    const bool any = std::any_of(item.peak.begin(), item.peak.end(), [](double p) { return p > 0.0; });
    const bool valid = std::all_of(item.peak.begin(), item.peak.end(), [](double p) { return p >= 0.0 && std::isfinite(p); });
    return item.x1 > item.x0 && item.y1 > item.y0 && any && valid && std::isfinite(item.x0) && std::isfinite(item.x1) &&
           std::isfinite(item.y0) && std::isfinite(item.y1);
}

std::size_t cell_index(const VisibilityMap& map, int r, int c) {
    return static_cast<std::size_t>(r) * static_cast<std::size_t>(map.cols) + static_cast<std::size_t>(c);
}

// The largest, over the channels, of an item's peak over the least visible value of that channel under it.
double visible_ratio(const CullItem& item, const CellRange& range, const VisibilityMap& map) {
    std::array<float, 3> least;
    least.fill(std::numeric_limits<float>::max());
    for (int r = range.r0; r < range.r1; ++r)
        for (int c = range.c0; c < range.c1; ++c)
            for (std::size_t k = 0; k < 3; ++k) least[k] = std::min(least[k], map.visible[cell_index(map, r, c) * 3 + k]);
    double ratio = 0.0;
    for (std::size_t k = 0; k < 3; ++k) {
        if (!(item.peak[k] > 0.0)) continue;
        ratio = std::max(ratio, least[k] > 0.0f ? item.peak[k] / static_cast<double>(least[k]) : std::numeric_limits<double>::infinity());
    }
    return ratio;
}

// Whether culling the item keeps every channel of every cell under it within the budget.
bool fits_budget(const CullItem& item, const CellRange& range, const VisibilityMap& map) {
    for (int r = range.r0; r < range.r1; ++r)
        for (int c = range.c0; c < range.c1; ++c)
            for (std::size_t k = 0; k < 3; ++k) {
                const std::size_t i = cell_index(map, r, c) * 3 + k;
                if (item.peak[k] > 0.0 && map.used[i] + item.peak[k] / static_cast<double>(map.visible[i]) > map.budget) return false;
            }
    return true;
}

void spend_budget(const CullItem& item, const CellRange& range, VisibilityMap& map) {
    for (int r = range.r0; r < range.r1; ++r)
        for (int c = range.c0; c < range.c1; ++c)
            for (std::size_t k = 0; k < 3; ++k) {
                const std::size_t i = cell_index(map, r, c) * 3 + k;
                if (item.peak[k] > 0.0) map.used[i] += item.peak[k] / static_cast<double>(map.visible[i]);
            }
}

// A ghost not culled whose peak alone is under what the frame shows, by how far its peak times its spike is under it.
SceneVerdict faint_verdict(double spiked_ratio, double veil_ratio) {
    return spiked_ratio < veil_ratio ? SceneVerdict::Veil : spiked_ratio < 1.0 ? SceneVerdict::Faint : SceneVerdict::Spiky;
}

}  // namespace

std::vector<SceneVerdict> scene_cull(const std::vector<CullItem>& items, VisibilityMap& map) {
    std::vector<SceneVerdict> verdicts(items.size(), SceneVerdict::Draw);
    if (map.cols <= 0 || map.rows <= 0 || map.visible.size() != static_cast<std::size_t>(map.cols) * static_cast<std::size_t>(map.rows) * 3)
        return verdicts;
    // Each known item's cells and its ratio to the least visible value under it: the order of culling.
    std::vector<CellRange> ranges(items.size());
    std::vector<double> ratio(items.size(), std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < items.size(); ++i) {
        if (!item_known(items[i])) continue;
        ranges[i] = cells_under(items[i], map);
        if (ranges[i].empty()) {
            verdicts[i] = SceneVerdict::Cull;  // wholly off the image
            continue;
        }
        ratio[i] = visible_ratio(items[i], ranges[i], map);
    }
    std::vector<std::size_t> order(items.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return ratio[a] < ratio[b]; });
    map.used.resize(map.visible.size(), 0.0);  // per cell and channel: the culled items' sum of peak / visible
    for (std::size_t i : order) {
        if (verdicts[i] == SceneVerdict::Cull || !std::isfinite(ratio[i])) continue;
        if (ratio[i] <= map.budget && fits_budget(items[i], ranges[i], map)) {
            verdicts[i] = SceneVerdict::Cull;
            spend_budget(items[i], ranges[i], map);
        } else if (ratio[i] < 1.0) {
            verdicts[i] = faint_verdict(ratio[i] * items[i].spike, map.veil_ratio);
        }
    }
    return verdicts;
}

FieldDirection field_direction(const FlareView& view) {
    const double k = std::numbers::pi / 180.0;
    const double tx = std::tan(view.angle_x_deg * k);
    const double ty = std::tan(view.angle_y_deg * k);
    const double t = std::hypot(tx, ty);
    return {std::atan(t) / k, t > 0.0 ? std::atan2(ty, tx) : 0.0};
}

BoundsTable::BoundsTable(std::uint64_t key, int passes, int ghosts, std::string dir)
    : key_(key), passes_(passes), ghosts_(ghosts), dir_(std::move(dir)) {}

std::string BoundsTable::path() const {
    if (dir_.empty() || dir_ == "none") return {};
    return flare::cache_file(dir_, "bounds", key_);
}

const std::vector<std::vector<GhostEstimate>>* BoundsTable::entry(int index) const {
    auto it = entries_.find(index);
    return it == entries_.end() ? nullptr : &it->second;
}

void BoundsTable::store(int index, std::vector<std::vector<GhostEstimate>> estimates) {
    if (static_cast<int>(estimates.size()) != passes_) {
        throw std::logic_error(fmt::format("bounds table: {} passes stored, {} expected", estimates.size(), passes_));
    }
    entries_[index] = std::move(estimates);
}

namespace {

constexpr char kMagic[8] = {'L', 'F', 'X', 'B', 'N', 'D', 'S', '7'};  // 7: veils' peaks (measure_veil_cells)
constexpr int kFieldsPerGhost = 18;

}  // namespace

namespace {

// Larger than any coordinate (mm) or power (mm^2) of a real lens's ghost by orders of magnitude.
constexpr double kMaxTableValue = 1e9;
static_assert(kMaxPeak <= kMaxTableValue, "a coarse pass's peak must fit a bounds table");

// An estimate a trace could have made: the quantities that cannot be negative are not, and fill is a share.
bool plausible(const GhostEstimate& g) {
    return g.power >= 0.0 && g.area_cv >= 0.0 && g.extent_mm >= 0.0 && g.fill >= 0.0 && g.fill <= 1.0 && g.failed_edge >= 0.0 &&
           g.iris_edge >= 0.0 && g.rim_edge >= 0.0 && g.peak >= 0.0 && g.edge_peak >= 0.0 && g.edge_line >= 0.0;
}

}  // namespace

int BoundsTable::load() {
    const std::string file = path();
    if (file.empty()) return 0;
    flare::CacheFile in = flare::open_cache_file(file);
    if (!in) return 0;
    char magic[8];
    std::uint64_t key = 0;
    std::int32_t shape[3] = {0, 0, 0};  // passes, ghosts, entries
    in.read(magic, sizeof magic);
    in.read(reinterpret_cast<char*>(&key), sizeof key);
    in.read(reinterpret_cast<char*>(shape), sizeof shape);
    if (!in || std::memcmp(magic, kMagic, sizeof magic) != 0 || key != key_ || shape[0] != passes_ ||
        shape[1] != ghosts_ || shape[2] < 0 || shape[2] > 100000) {
        return 0;
    }
    std::map<int, std::vector<std::vector<GhostEstimate>>> read;
    std::vector<double> values(static_cast<std::size_t>(passes_) * static_cast<std::size_t>(ghosts_) * kFieldsPerGhost);
    for (int e = 0; e < shape[2]; ++e) {
        std::int32_t index = 0;
        in.read(reinterpret_cast<char*>(&index), sizeof index);
        in.read(reinterpret_cast<char*>(values.data()), static_cast<std::streamsize>(values.size() * sizeof(double)));
        if (!in) return 0;
        std::vector<std::vector<GhostEstimate>> entry(static_cast<std::size_t>(passes_),
                                                      std::vector<GhostEstimate>(static_cast<std::size_t>(ghosts_)));
        // A value no trace could give (a damaged or doctored file) makes the whole file a miss.
        if (!std::all_of(values.begin(), values.end(), [](double x) { return std::isfinite(x) && std::abs(x) <= kMaxTableValue; }))
            return 0;
        const double* v = values.data();
        for (auto& pass : entry) {
            for (GhostEstimate& g : pass) {
                g = {{v[0], v[1], v[2], v[3]}, v[4], v[5], v[6], v[7], v[8], v[9], v[10], {v[11], v[12], v[13], v[14]}, v[15], v[16], v[17]};
                if (!plausible(g)) return 0;
                v += kFieldsPerGhost;
            }
        }
        read[index] = std::move(entry);
    }
    const int count = static_cast<int>(read.size());
    for (auto& [index, entry] : read) entries_.try_emplace(index, std::move(entry));
    return count;
}

void BoundsTable::save() const {
    const std::string file = path();
    if (file.empty()) return;
    flare::write_cache_file(file, [&](std::ostream& out) {
        const std::int32_t shape[3] = {passes_, ghosts_, static_cast<std::int32_t>(entries_.size())};
        out.write(kMagic, sizeof kMagic);
        out.write(reinterpret_cast<const char*>(&key_), sizeof key_);
        out.write(reinterpret_cast<const char*>(shape), sizeof shape);
        for (const auto& [index, entry] : entries_) {
            const std::int32_t i = index;
            out.write(reinterpret_cast<const char*>(&i), sizeof i);
            for (const auto& pass : entry) {
                for (const GhostEstimate& g : pass) {
                    const double v[kFieldsPerGhost] = {g.rect.x0, g.rect.y0, g.rect.x1, g.rect.y1, g.power, g.area_cv,
                                                       g.extent_mm, g.fill, g.failed_edge, g.iris_edge, g.rim_edge,
                                                       g.sensor.x0, g.sensor.y0, g.sensor.x1, g.sensor.y1, g.peak,
                                                       g.edge_peak, g.edge_line};
                    out.write(reinterpret_cast<const char*>(v), sizeof v);
                }
            }
        }
    });
}

std::vector<GhostEstimate> BoundsTable::interpolate(int pass, double theta_deg) const {
    const int i0 = static_cast<int>(std::floor(theta_deg / step_deg));
    const double t = theta_deg / step_deg - i0;
    const auto* a = entry(i0);
    const auto* b = entry(i0 + 1);
    if (!a || !b) throw std::logic_error(fmt::format("bounds table: entries {} and {} missing", i0, i0 + 1));
    const auto& ea = (*a)[static_cast<std::size_t>(pass)];
    const auto& eb = (*b)[static_cast<std::size_t>(pass)];
    std::vector<GhostEstimate> out(ea.size());
    for (std::size_t g = 0; g < ea.size(); ++g) {
        const GhostEstimate& p = ea[g];
        const GhostEstimate& q = eb[g];
        GhostEstimate& r = out[g];
        if (p.rect.empty() || q.rect.empty()) {
            r = p.rect.empty() ? q : p;
        } else {
            r.rect = {std::min(p.rect.x0, q.rect.x0), std::min(p.rect.y0, q.rect.y0), std::max(p.rect.x1, q.rect.x1),
                      std::max(p.rect.y1, q.rect.y1)};
        }
        r.power = (1.0 - t) * p.power + t * q.power;
        r.area_cv = std::max(p.area_cv, q.area_cv);
        r.extent_mm = std::max(p.extent_mm, q.extent_mm);
        r.fill = std::min(p.fill, q.fill);
        r.failed_edge = std::max(p.failed_edge, q.failed_edge);
        r.iris_edge = std::max(p.iris_edge, q.iris_edge);
        r.rim_edge = std::max(p.rim_edge, q.rim_edge);
        // Between the two angles the ghost moves from one box to the other; unknown at either: unknown.
        const bool known = !p.sensor.empty() && !q.sensor.empty() && p.peak > 0.0 && q.peak > 0.0;
        r.sensor = known ? PupilRect{std::min(p.sensor.x0, q.sensor.x0), std::min(p.sensor.y0, q.sensor.y0),
                                     std::max(p.sensor.x1, q.sensor.x1), std::max(p.sensor.y1, q.sensor.y1)}
                         : PupilRect{};
        r.peak = known ? std::max(p.peak, q.peak) : 0.0;
        r.edge_peak = std::max(p.edge_peak, q.edge_peak);
        r.edge_line = std::max(p.edge_line, q.edge_line);
    }
    return out;
}

}  // namespace lensfx::gpu
