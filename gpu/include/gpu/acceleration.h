// The ghost renderer's accelerations (flare paper section 4.2, culling paper): ray bounding from a
// per-lens table of entrance-pupil rectangles, adaptive grid resolution, intensity level of detail and
// reduced-resolution drawing. Each can be switched off; `lensfx bench time-vs-error` measures them.
// Also the bounds table itself, cached in memory and on disk per lens, zoom, f-number and aperture.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include <gpu/flare_model.h>

namespace lensfx::gpu {

// Where each ghost's ray grid lies on the entrance plane. Table: looked up in the cached bounds table
// (no per-frame coarse pass). Coarse: a coarse GPU pass over the entrance square every frame. None: the
// whole entrance square (a coarse pass still estimates power when the level of detail needs it).
enum class Bounding { Table, Coarse, None };
Bounding parse_bounding(const std::string& text);  // "table", "coarse" or "none"; throws otherwise
const char* to_string(Bounding bounding);

struct Acceleration {
    Bounding bounding = Bounding::Table;
    bool adaptive = true;          // grid per ghost from the variance of its cell areas on the sensor, its fill
                                   // and its outlines (acceleration.cpp)
    bool lod = true;               // skip dim ghosts, fewer rays for ghosts under 1% of the estimated total
    double ghost_threshold = 1e-4; // lod: skip ghosts below this fraction of the estimated total power
    int max_ghosts = 0;            // lod: draw at most this many (the brightest); 0 = no budget
    bool reduced = true;           // draw large ghosts at 1/2, 1/4, 1/8 or 1/16 (faint ones 1/32) resolution and upsample
    // Aperture culling (section 4.2): leave out the ghosts that cross the stop three times (first reflection
    // behind the stop, second in front), mostly blocked when the iris is small. Off by default: the level
    // of detail already skips them when they are dim, and wide open they are not.
    bool aperture_culling = false;
    std::string cache_dir;         // bounds table files: as --cache-dir (flare::cache_dir_of)
};

// Documented errors: switching one acceleration off changes a 480x320 image of the test lenses
// (tests/gpu/acceleration_test.cpp) by less than this relative L1 over 32x32-pixel blocks (the measure
// of `lensfx bench time-vs-error`) and this relative total power.
// Measured at the default base grid 16 on the Tessar at (8, 5) and the Angenieux double Gauss at
// (-4, 11) degrees: table against coarse bounds 0.0037, adaptive 0.0070, LOD 0.0003, reduced drawing
// 0.0006 in L1; 0.0030 (adaptive) and at most 0.0003 (the others) in power.
// Issue 16 (Gouraud shading) moved adaptive power to 0.0102 (Tessar): a coarse grid's Gouraud triangles
// share their power with their neighbours (every triangle scaled to its own flux gives 0.0010, but shows
// the cells again); that bound stays 0.012. With reduced ghosts' rims drawn at 4x their level and the
// vertex irradiance taken over the rasterised triangles only (not their sub-pixel neighbours), reduced
// drawing measured 0.0006 L1 and 0.00002 power (the 1080p frame-filling test): back within the old bounds.
inline constexpr double kTableL1 = 0.006, kTablePower = 0.001;
inline constexpr double kAdaptiveL1 = 0.012, kAdaptivePower = 0.012;
inline constexpr double kLodL1 = 0.003, kLodPower = 0.002;
inline constexpr double kReducedL1 = 0.003, kReducedPower = 0.001;

// What a coarse pass learns of one ghost at one wavelength and light direction.
struct GhostEstimate {
    PupilRect rect;           // entrance-plane rectangle of the rays that get through to the circle round
                              // the sensor (empty: none did)
    double power = 0.0;       // their power, mm^2 per unit irradiance
    double area_cv = 0.0;     // coefficient of variation of the unblocked coarse cells' sensor areas
    double extent_mm = 0.0;   // larger side of the ghost's bounding box on the sensor
    double fill = 1.0;        // share of the coarse vertices within rect whose rays get through
    // The outline, as coarse cells with some corners passing and some not, per square root of the coarse
    // cells with a passing corner (so outline / (sqrt(fill) * grid) is roughly the outline's share of a
    // grid's cells on the passing part): where a corner's ray fails (misses a surface, total internal
    // reflection; the renderer drops such cells whole), where a corner is blocked by the iris (clipped
    // on interpolated stop coordinates) and where a corner is clipped by a lens's rim (clipped on the
    // interpolated relative radius, which a coarse cell over a strongly bent map puts far from the true rim:
    // a polygonal or ragged outline, a vignetted region with straight sides).
    double failed_edge = 0.0;
    double iris_edge = 0.0;
    double rim_edge = 0.0;
    // Where it lands and how bright it gets, for culling against the frame (scene_cull): the bounding box of
    // its passing rays on the sensor (mm, sensor coordinates at the estimate's light azimuth; empty: not
    // known) and the largest irradiance of a coarse cell whose corners all pass (per unit irradiance of the
    // light; 0: not known). Scene culling keeps any ghost either is unknown of.
    PupilRect sensor{0.0, 0.0, 0.0, 0.0};
    double peak = 0.0;
    // Its outline's cells (some corners pass, none failed), which `peak` leaves out: a ghost's rim is often a
    // caustic, its light squeezed into a thin bright ring there. The largest irradiance of such a cell had it
    // passed whole (per unit irradiance of the light), and the largest of that irradiance times the cell's width
    // on the sensor (its area over its longest side, mm: its power per length): a ring narrower than a pixel of
    // side p adds about sqrt(2) edge_line / p to it (pixel_peak).
    double edge_peak = 0.0;
    double edge_line = 0.0;
};
// The largest peak (and outline irradiance) a coarse pass records, per unit irradiance of the light: a cell folded
// flat (a caustic) records it, and scene culling takes a peak of kMaxPeak as not known (drawn). Within what a
// bounds table stores (a value beyond would make its file a miss on every run).
inline constexpr double kMaxPeak = 1e9;
// The largest value one pixel of side pixel_mm may take of a ghost (per unit irradiance of the light), as
// estimated from its coarse cells: its whole cells' peak, or where more, its outline's ring spread over a pixel's
// width (at most the ring's own irradiance). The smaller the pixel, the more of a thin ring it holds: at 8K
// canon-70-200's faint ring ghost on the stage frame reaches 8 times its whole cells' peak. An estimate, not a
// bound: a coarse cell averages what it covers, and one shaped like a triangle is up to twice as wide as its area
// over its longest side.
double pixel_peak(const GhostEstimate& e, double pixel_mm);

// Per-ghost drawing decisions from the estimates of one pass.
// Ghosts drawn at 1/4 of the image or smaller get their rims drawn at 4 times their level's resolution
// (1/4 at full size, 1/8 at 1/2, 1/16 at 1/4): the upsampling then softens a rim by a pixel or two at 1/2, a
// few at 1/4, against 8-16 px stairs drawn wholly reduced; at full size the rim pass of a frame-filling
// ghost at 1/16 (a 48-px band along its outline, filled by whole grid triangles) cost more than all the
// rest of the render.
inline constexpr int kRimReduce = 4;

struct GhostPlan {
    bool draw = false;
    int grid = 0;    // cells per side
    int reduce = 1;  // 1 full resolution, 2, 4, 8 or 16: drawn at 1/reduce of the image size and upsampled
    bool rim = true;    // a ghost drawn at 1/4 or less: its rim drawn sharp at 4x its level (the renderer's rim pass)
    // Its small triangles (under a pixel, or slivers) drawn apart with area coverage, else left out (only the
    // rasterised ones drawn).
    bool small_apart = true;
    // With small_apart: all its triangles drawn with area coverage (each pixel takes the light of the part of
    // it a triangle covers, so none is small), because they may come near a pixel (plan_ghosts: caustics, or
    // small triangles); else point-sampled at pixel centres.
    bool area_coverage = false;
    // Drawn at the coarsest detail because it is under what the plate shows (SceneVerdict::Faint): its rim's and
    // iris's cuts taken at pixel centres, not by the share of each pixel inside them.
    bool faint = false;
    // Whether it is drawn in two parts: at its level, and its rim at kRimReduce times that resolution.
    bool rim_pass() const { return rim && reduce >= kRimReduce; }
};
// What scene culling decided of one ghost (scene_cull): drawn as the level of detail plans it, left out, or
// drawn at the coarsest detail because its peak alone is under what the frame can show where it lands: its
// total light matters there, not its shape (kMinGrid cells, or 8 when its outline has no failed rays and it
// is smooth, and the level of detail's grid when it has failed rays; the most reduced level its size allows,
// no rim pass, small triangles left out).
// Spiky: a ghost with caustics whose coarse peak is under what the frame shows, but whose peak times
// caustic_spike (a pixel or two of a caustic) is not: coarsened too, but it keeps its small triangles and the level a
// sharp ghost gets, so a caustic's spike stays where it is.
// Veil: a faint ghost far under what the frame shows (its peak times caustic_spike under kVeilRatio of it): one of
// the hundreds that together make a zoom's veil of light, each too faint for its outline to show. Drawn as Faint,
// but coarser still: at the most reduced level that keeps kVeilCells (not kFaintCells) of its level's pixels across
// it and, when smooth, at kFaintOpenGrid cells whatever its outline (one with caustics keeps a Faint ghost's grid).
enum class SceneVerdict : unsigned char { Draw, Cull, Faint, Spiky, Veil };
// How far under what the frame shows a faint ghost is a Veil: a twentieth of a code (canon-70-200 on the 1080p
// stage frame at physical strength: of its 1,451 faint items, 1,053 are under 0.03 of it and 1,281 under 0.1). What
// its coarser level and grid change moves no value by more than its peak; on the issue-17 frames the error against
// --no-scene-cull kept its percentiles and maxima (docs/benchmarks.md, twenty-ninth stop).
inline constexpr double kVeilRatio = 0.05;
// How far above its coarse cells' peak a ghost may reach in a pixel or two: kCausticSpike for a ghost with
// caustics (cells too uneven to draw reduced), 1 for a smooth one. Measured: nikon-80-200 on pan1080 at
// --gain 20 has a faint caustic ghost whose one-pixel spike is 7 codes when drawn as Faint with a factor of 1,
// 2 codes (the bound is 4) with 2 or more; 8 keeps a margin of 4 over that.
inline constexpr double kCausticSpike = 8.0;
double caustic_spike(const GhostEstimate& e);
// base_grid: the --grid option. pixel_mm: the sensor width of one pixel. per_ghost_power disables the
// reduced drawing (the per-ghost read-back happens on the full-size target). total_power: what the level
// of detail takes each ghost's share of (all lights' ghosts in this pass); 0: the estimates' sum.
// verdicts: scene culling's per ghost (empty: every ghost Draw).
// spread_level: the caller spreads every ghost over that level's disc (an extended light's footprint group),
// so no outline is seen finer.
std::vector<GhostPlan> plan_ghosts(const std::vector<GhostEstimate>& estimates, const Acceleration& accel,
                                   int base_grid, double pixel_mm, bool per_ghost_power, double total_power = 0.0,
                                   const std::vector<SceneVerdict>& verdicts = {}, int spread_level = 1);

// What a frame can show of a flare added to it, cell by cell and channel by channel (scene culling, issue 17):
// in each cell of `cell` x `cell` pixels, the smallest addition to R, G and B (in the frame's units) that
// counts as visible there. Built by the flare stage from the plate (filter/visibility.h); null in
// GpuFlareOptions: no scene culling.
struct VisibilityMap {
    int width = 0;   // the frame (display window), pixels
    int height = 0;
    int cell = 32;   // pixels per cell side
    int cols = 0;    // cells across and down
    int rows = 0;
    std::vector<float> visible;  // per cell (row 0 at the top) R, G, B: the least visible addition there (> 0)
    double budget = 1.0;         // --visibility V: the culled ghosts together add at most V x visible to any
                                 // channel of any cell
    double veil_ratio = kVeilRatio;  // faint ghosts whose peak times spike is under this x visible are Veils (0: none)
    std::vector<double> used;    // per cell and channel (as `visible`): what culled ghosts have spent of the
                                 // budget (scene_cull fills it), shared by every render of the frame
};

// How the caller spreads each ghost after it is drawn (an extended light's footprint, convolved with the
// group's image): how far beyond where the ghost lands, and the largest share of the ghost's power one pixel
// keeps (the footprint kernel's largest weight over its sum; 0: not spread). A spread ghost's peak is at most
// its power times that share over a pixel's area, however sharp it was drawn.
struct GhostSpread {
    double px = 0.0;
    double peak_share = 0.0;
};
// The coarsest level a spread ghost is drawn at: the spread blurs it over a disc of 1 / peak_share pixels, so
// it is drawn at 1/2, 1/4 ... 1/16 of the image while the level's pixel is at most a quarter of that disc's
// radius (the level's upsampling then blurs it far less than the spread does); 1 when not spread.
int spread_level(const GhostSpread& spread);
// A caustic's spike is a pixel or two; spread, it adds at most its power times the kernel's largest share:
// kSpikePixels pixels at kCausticSpike times the peak. An assumption with a margin, not a bound: a caustic line
// bright over many pixels would exceed it (measured: bench_cull within 1 code at 99.9% and 4 anywhere on the
// issue-17 frames with the four biggest presets, docs/benchmarks.md).
inline constexpr double kSpikePixels = 4.0;

// One ghost of one light and pass as scene culling sees it: its box on the image (pixels, upright, row 0 at
// the top; x1 <= x0: not known) and the largest value it adds to each of R, G, B there (frame units; a
// spectral pass adds to one channel, or to several with their own factors).
struct CullItem {
    double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;
    std::array<double, 3> peak{};
    double spike = 1.0;  // how far above peak a pixel or two of it may reach (caustic_spike)
};
// Which items to leave out: the faintest first (by the largest of their channels' peak over the least
// visible value of that channel under their box), as long as every cell's sum of culled peak / visible stays
// within the budget in each channel, so all the culled ghosts together change no channel of any cell by more
// than budget x visible. Items wholly off the image cost nothing; items whose box or peak is not known
// (x1 <= x0, no channel's peak > 0, or any not finite) are drawn. Items not culled whose peak alone is under
// the least visible value under their box in every channel are Faint (Veil when their peak times their spike is
// under map.veil_ratio of it), or Spiky when their peak times their spike is not. What the culled items spend is added
// to map.used, so several calls (an extended light's groups, then the point lights) share one budget.
std::vector<SceneVerdict> scene_cull(const std::vector<CullItem>& items, VisibilityMap& map);

// Entrance-pupil rectangles of every ghost over a grid of field angles (and a sensor size) (light in the x-z plane, at
// multiples of step_deg), for a round iris of the stop radius (which contains any bladed iris): by the
// lens's rotational symmetry a light at field angle theta and azimuth phi sees the rectangle of theta
// turned by phi. Entries are computed on demand (by the caller's coarse pass), kept in memory and
// written to <dir>/bounds-<key>.bin through the disk cache (flare/cache.h).
class BoundsTable {
public:
    static constexpr double step_deg = 0.5;

    BoundsTable(std::uint64_t key, int passes, int ghosts, std::string dir);
    std::uint64_t key() const { return key_; }
    std::string path() const;  // empty without a disk cache
    // The entry at step index i (angle i * step_deg): per pass, per ghost; nullptr when not computed.
    const std::vector<std::vector<GhostEstimate>>* entry(int index) const;
    void store(int index, std::vector<std::vector<GhostEstimate>> estimates);
    // Reads the file if it exists and matches the key and shape; returns the number of entries read.
    // A corrupt or foreign file is ignored (and overwritten by the next save).
    int load();
    void save() const;  // writes atomically (temporary file, then rename); throws naming the file

    // For a field angle between two entries: the union of their rectangles, the larger cv, extent and
    // outlines, the smaller fill, the interpolated power. Both entries must be present.
    std::vector<GhostEstimate> interpolate(int pass, double theta_deg) const;

private:
    std::uint64_t key_;
    int passes_;
    int ghosts_;
    std::string dir_;
    std::map<int, std::vector<std::vector<GhostEstimate>>> entries_;
};

// The field angle (degrees from the axis) and azimuth (radians, counter-clockwise from +x on the
// entrance plane) of a view's light direction, as collimated_ray builds it.
struct FieldDirection {
    double theta_deg = 0.0;
    double phi = 0.0;
};
FieldDirection field_direction(const FlareView& view);

// What the last render did: for tests and the benchmark.
struct RenderStats {
    int ghosts_drawn = 0;       // summed over passes
    int ghosts_skipped = 0;     // by the level of detail or an empty rectangle
    int ghosts_reduced = 0;     // drawn at reduced resolution
    int ghosts_culled = 0;      // by scene culling (also counted in ghosts_skipped)
    int ghosts_faint = 0;       // drawn at the coarsest detail by scene culling
    int ghosts_merged = 0;      // faint ghosts of one pass drawn by another's (merge_faint_passes)
    long long rays = 0;         // grid vertices traced for drawing
    int table_computed = 0;     // bounds-table entries computed by this render
    int table_loaded = 0;       // entries read from disk by this render
};

}  // namespace lensfx::gpu
