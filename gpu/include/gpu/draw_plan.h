// The CPU steps of FlareRenderer::draw (no GL): which ghosts a render draws and how they look, every light's
// estimates, scene culling's verdicts, each pass's plan (which ghosts at which grid and level), the batches
// they are traced in and the bands of the full-size target. The GL steps (estimate, trace a batch, raster a
// batch, read back) are in flare_renderer.cpp; each step here can be run alone (tests/gpu/draw_plan_test.cpp).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include <gpu/acceleration.h>
#include <gpu/flare_model.h>
#include <optics/flare_look.h>

namespace lensfx::gpu {

struct ScaledLight;  // gpu/flare_renderer.h

// What a render draws of a lens's ghosts, indexed like its ghost list: GpuFlareOptions::draw_only as a mask
// (looked up in a sorted index, not searched per ghost) and each ghost's style (null: its physical look).
struct GhostSelection {
    std::vector<char> drawn;
    std::vector<const optics::GhostStyle*> style;

    // draw_only pairs in either order (empty: every ghost); styles by their two interfaces in either order.
    static GhostSelection of(const std::vector<Ghost>& ghosts, const std::vector<std::pair<int, int>>& draw_only,
                             const std::vector<optics::GhostStyle>& styles);
    // A ghost whose style adds nothing to any channel.
    bool dark(std::size_t ghost) const;
};

// One light's ghost estimates: per pass, per ghost, power scaled by the light's weight in that pass.
struct LightEstimates {
    std::vector<std::vector<GhostEstimate>> pass;
    double rotation = 0.0;  // bounds-table rectangles turned to the light's azimuth
};

// What estimate_light scales a pass's ghost powers by: the light over the pass's channels (the sum of
// |pass weight x light| over R, G, B).
double pass_light_weight(const std::array<double, 3>& pass_weight, const std::array<double, 3>& light_scale);

// The level of detail's total per pass: the drawn ghosts' estimated power summed over every light.
std::vector<double> pass_totals(const std::vector<LightEstimates>& lights, std::size_t passes, const std::vector<char>& drawn);

// Scene culling's verdicts per light, pass and ghost: every light's drawn ghosts against what the frame shows
// where they land, all at once (one budget per cell of the image). Spends map's budget.
using LightVerdicts = std::vector<std::vector<std::vector<SceneVerdict>>>;
LightVerdicts cull_lights(const std::vector<LightEstimates>& estimates, std::span<const ScaledLight> lights,
                          const std::vector<SpectralPass>& passes, const GhostSelection& selection,
                          const FlareView& view, const GhostSpread& spread, VisibilityMap& map);

// One ghost of one light and pass as scene culling sees it (its sensor box turned to the light's azimuth,
// moved by its style, grown by the small triangles' and reduced levels' spread and the caller's; its peak, or for a
// spread ghost the least of that and what the spread leaves of its power (kSpreadPowerMargin times it), times
// the factor each channel adds it with).
inline constexpr double kSpreadPowerMargin = 2.0;
CullItem cull_item(const GhostEstimate& e, double rotation, const std::array<double, 3>& light_scale,
                   const std::array<double, 3>& pass_weight, const optics::GhostStyle* style, const FlareView& view,
                   const GhostSpread& spread = {});

// What the level of detail needs besides the estimates (plan_ghosts' arguments).
struct DetailSettings {
    Acceleration accel;
    int base_grid = 16;          // --grid
    double pixel_mm = 0.1;       // the sensor width of one pixel
    bool per_ghost_power = false;
    bool batch_faint = true;     // GpuFlareOptions::batch_faint
    int spread_level = 1;        // no ghost drawn finer (spread_level of GpuFlareOptions::spread)
};

// One light's ghosts in one pass: each ghost's plan and the ghosts drawn in a band of the full-size target,
// in ghost order (later bands only those with a full-size part: the ghost or its rim), with what band 0
// counts for RenderStats. Faint ghosts (scene culling; no rim pass, no small triangles) are drawn together, grouped
// by grid and level (the renderer's batched draw), the others one draw each.
struct PassPlan {
    std::vector<GhostPlan> plans;     // per ghost
    std::vector<std::size_t> todo;    // ghost indices to trace and raster one by one
    std::vector<std::size_t> batched; // faint ghost indices to trace and raster together
    int skipped = 0, culled = 0, faint = 0;
};
// verdicts: this light and pass's (empty: all Draw); total_power: pass_totals' entry for the pass.
PassPlan plan_pass(const std::vector<GhostEstimate>& estimates, double total_power, const std::vector<SceneVerdict>& verdicts,
                   const GhostSelection& selection, const DetailSettings& detail, int band);

// Faint ghosts drawn once for all passes (issue 17). A faint ghost drawn batched (PassPlan::batched) by
// several passes is traced and drawn by one of them, its host (the pass nearest the middle of the spectrum
// that draws it batched, passed over for a later one that draws it more finely), for every other that it draws
// at least as finely (no coarser level, no fewer cells: a Veil there takes no Faint pass's light) and in every
// band (a full-size host takes no reduced pass's light, which is drawn with the first band only) and whose
// sensor box lies within kMergeShiftPx pixels of the host's level of the host's (its dispersion under what its
// level shows): it adds to R, G, B what that pass would have, the pass's weights times the ghost's power there
// over its power in the host (its coatings' colour kept as a total), and that pass leaves it out.
inline constexpr double kMergeShiftPx = 2.0;
struct MergedFaint {
    std::vector<std::vector<std::array<double, 3>>> weight;  // per pass and ghost, the R, G, B weights it draws with
    int merged = 0;                                          // ghosts left out of a pass (drawn by their host)
};
// estimates: the light's (power scaled by the light over each pass's channels, estimate_light); light_scale:
// its R, G, B; pixel_mm: the sensor width of a full-size pixel. Takes merged ghosts out of plans' batched lists.
MergedFaint merge_faint_passes(std::vector<PassPlan>& plans, const LightEstimates& estimates, const std::vector<SpectralPass>& passes,
                               const std::array<double, 3>& light_scale, double pixel_mm);

// Whether a ghost is drawn by its triangle indices in two lists (ghost_shade_comp's split_interior): the triangles a
// cut (a rim, the iris) may reach, and after them the interior ones, drawn without looking at the cuts. Those
// point-sampled without a rim pass and not faint: a faint ghost's few pixels at its level lie mostly in triangles a
// cut reaches (canon-70-200 on the 1080p stage frame: 0.6 of its fragments), and the split's shading of each grid
// vertex twice and its look at the iris cost more than its interior saved.
bool splits_interior(const GhostPlan& plan);
// The indices a ghost's rasterised triangles take in the index buffer (ghost_shade_comp's write_cell_indices):
// 6 a grid cell when point-sampled, 12 when its interior is split off (splits_interior); none with area coverage,
// which draws each triangle's corners alone.
std::size_t triangle_indices(const GhostPlan& plan);

// A ghost of a batch, where its grid vertices start in the vertex buffer and its triangles
// (triangle_indices) in the index buffer.
struct BatchJob {
    std::size_t ghost;
    std::size_t first_vertex;
    std::size_t first_index;
};
// The todo ghosts in batches traced into one vertex buffer of `capacity` vertices, in order; a ghost larger
// than the buffer alone (the buffer is made for the largest grid). Per-ghost power: a ghost a batch.
std::vector<std::vector<BatchJob>> batch_ghosts(const std::vector<std::size_t>& todo, const std::vector<GhostPlan>& plans,
                                                std::size_t capacity, bool per_ghost_power);

// Faint ghosts of one grid and level in a chunk of PassPlan::batched: traced, shaded and drawn together,
// their jobs, grid vertices and triangle indices (6 a cell) one run after another in the chunk's buffers.
struct FaintRun {
    int grid = 0, reduce = 1;
    std::vector<std::size_t> ghosts;
    std::size_t first_job = 0, first_vertex = 0, first_index = 0;
};
// The batched ghosts (drawn in band `band`: later bands only the full-size ones) in chunks whose vertices fit
// `capacity` (a ghost larger alone), each chunk's runs ordered by level, then grid: a chunk's ghosts are
// traced before any is drawn and each level's target bound once, where a barrier or a change of target makes
// a software rasteriser finish what it has queued.
std::vector<std::vector<FaintRun>> batch_faint(const std::vector<std::size_t>& batched, const std::vector<GhostPlan>& plans,
                                               std::size_t capacity, int band);

// The full-size target's horizontal bands: one when the image's RGBA32F target is at most `max_bytes`, else
// as few as keep each band under it. Band b holds the image's rows [first(b), end(b)) (top down), drawn
// with kMargin rows more on either side, which small triangles just outside it reach into (grown by half a
// pixel for area coverage), and below them one more where needed so that its lowest drawn row has the parity of
// the image's lowest: GL's rows count up from the target's bottom, so the band's 2 x 2 pixel quads, over which the
// raster shaders take derivatives (the cuts' shares of a pixel), are then the whole target's.
struct FullBands {
    static constexpr int kMargin = 2;
    int count = 1, image_rows = 0, rows_per_band = 0;
    int first(int b) const { return b * rows_per_band; }
    int end(int b) const { return std::min(image_rows, first(b) + rows_per_band); }
    int drawn_first(int b) const { return count == 1 ? 0 : std::max(0, first(b) - kMargin); }
    int drawn_end(int b) const {
        if (count == 1) return image_rows;
        const int below = std::min(image_rows, end(b) + kMargin);
        return below + ((image_rows - below) & 1);  // never past the image: an odd gap is at least a row
    }
    int rows_drawn(int b) const { return drawn_end(b) - drawn_first(b); }
    int target_rows() const { return count == 1 ? image_rows : std::min(image_rows, rows_per_band + 2 * kMargin + 1); }
};
// whole: one band whatever the size (per-ghost power reads the whole target back).
FullBands full_target_bands(int width, int height, double max_bytes, bool whole);

// The key of a lens's ghost selection (its sequences are built once per key and wavelength): system_hash
// mixed with every ghost's two interfaces (flare::KeyHash, the disk cache's one key hash).
std::uint64_t ghosts_key(const System& system, const std::vector<Ghost>& ghosts);
// The bounds table's key: the ghosts' key, the wavelengths and the radius round the sensor.
std::uint64_t bounds_table_key(std::uint64_t ghosts_key, const std::vector<SpectralPass>& passes, double sensor_radius_mm);

}  // namespace lensfx::gpu
