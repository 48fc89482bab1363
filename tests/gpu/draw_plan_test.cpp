// The renderer's steps run alone (issue 15): the CPU plan of a pass (which ghosts at which grid and level for
// given estimates), the batches and bands, the draw_only mask; and the GL trace step of one ghost against
// the CPU tracer.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <memory>
#include <numbers>
#include <span>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include <flare/image_ops.h>
#include <gpu/context.h>
#include <gpu/draw_plan.h>
#include <gpu/flare_renderer.h>
#include <optics/aperture.h>
#include <optics/ghosts.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace lensfx::gpu {
namespace {

std::vector<Ghost> ghost_list(std::vector<std::pair<int, int>> pairs) {
    std::vector<Ghost> ghosts;
    for (const auto& [first, second] : pairs) {
        Ghost g;
        g.first = first;
        g.second = second;
        ghosts.push_back(g);
    }
    return ghosts;
}

TEST(GhostSelection, DrawOnlyMaskTakesEitherOrderAndStylesFindTheirGhost) {
    const std::vector<Ghost> ghosts = ghost_list({{3, 1}, {5, 2}, {6, 0}, {4, 3}});
    const std::vector<optics::GhostStyle> styles = {{2, 5, {0.0, 0.0, 0.0}, {}}, {0, 6, {2.0, 1.0, 1.0}, {}}};
    const GhostSelection all = GhostSelection::of(ghosts, {}, styles);
    EXPECT_EQ(all.drawn, (std::vector<char>{1, 1, 1, 1}));
    EXPECT_EQ(all.style[0], nullptr);
    EXPECT_EQ(all.style[1], &styles[0]);
    EXPECT_EQ(all.style[2], &styles[1]);
    EXPECT_TRUE(all.dark(1));    // all gains 0
    EXPECT_FALSE(all.dark(2));
    EXPECT_FALSE(all.dark(0));   // no style: its physical look
    const GhostSelection some = GhostSelection::of(ghosts, {{1, 3}, {6, 0}, {9, 9}}, {});
    EXPECT_EQ(some.drawn, (std::vector<char>{1, 0, 1, 0}));
}

// Four ghosts of one pass: a bright frame-filling smooth one (drawn at 1/16, its rim at 1/4), a bright small
// sharp one (full size), one under the level of detail's threshold, one the coarse pass saw no light of; the
// last of five is not in the mask.
std::vector<GhostEstimate> five_estimates(double pixel_mm) {
    std::vector<GhostEstimate> e(5);
    for (GhostEstimate& g : e) g.rect = {-1, -1, 1, 1};
    e[0].power = 1.0;
    e[0].area_cv = 0.01;
    e[0].extent_mm = 2100 * pixel_mm;
    e[1].power = 0.5;
    e[1].area_cv = 2.0;
    e[1].extent_mm = 40 * pixel_mm;
    e[2].power = 1e-7;
    e[3].rect = {};
    e[3].power = 0.3;
    e[4].power = 0.4;
    e[4].extent_mm = 300 * pixel_mm;
    return e;
}

// The level of detail's settings of these tests: base grid 32 at pixel_mm; and all five ghosts selected.
DetailSettings detail_32(double pixel_mm) {
    DetailSettings detail;
    detail.base_grid = 32;
    detail.pixel_mm = pixel_mm;
    return detail;
}
GhostSelection five_ghosts() { return GhostSelection::of(ghost_list({{1, 0}, {2, 0}, {3, 0}, {4, 0}, {5, 0}}), {}, {}); }

TEST(PlanPass, WhichGhostsAtWhichGridAndLevel) {
    const double pixel_mm = 0.01;
    const std::vector<GhostEstimate> e = five_estimates(pixel_mm);
    const GhostSelection selection = GhostSelection::of(ghost_list({{1, 0}, {2, 0}, {3, 0}, {4, 0}, {5, 0}}),
                                                        {{1, 0}, {2, 0}, {3, 0}, {4, 0}}, {});
    DetailSettings detail;
    detail.base_grid = 32;
    detail.pixel_mm = pixel_mm;
    const PassPlan plan = plan_pass(e, 0.0, {}, selection, detail, 0);
    EXPECT_EQ(plan.todo, (std::vector<std::size_t>{0, 1}));
    EXPECT_EQ(plan.plans[0].reduce, 16);
    EXPECT_EQ(plan.plans[0].grid, 16);  // smooth: half the base grid
    EXPECT_EQ(plan.plans[1].reduce, 1);
    EXPECT_EQ(plan.plans[1].grid, 64);  // sharp: refined
    EXPECT_EQ(plan.skipped, 2);         // below the threshold, and no light; ghost 4 is not in the mask
    EXPECT_EQ(plan.culled, 0);
    // A later band of the full-size target: only the ghosts with a full-size part (the 1/16 ghost's rim is at 1/4).
    EXPECT_EQ(plan_pass(e, 0.0, {}, selection, detail, 1).todo, (std::vector<std::size_t>{1}));
    EXPECT_EQ(plan_pass(e, 0.0, {}, selection, detail, 1).skipped, 0);  // counted in band 0 only
    // Per-ghost power: everything at full size, so every band has every drawn ghost.
    detail.per_ghost_power = true;
    const PassPlan whole = plan_pass(e, 0.0, {}, selection, detail, 1);
    EXPECT_EQ(whole.todo, (std::vector<std::size_t>{0, 1}));
    EXPECT_EQ(whole.plans[0].reduce, 1);
}

TEST(PlanPass, SceneVerdictsCullAndCoarsen) {
    const double pixel_mm = 0.01;
    std::vector<GhostEstimate> e = five_estimates(pixel_mm);
    const GhostSelection selection = five_ghosts();
    DetailSettings detail = detail_32(pixel_mm);
    std::vector<SceneVerdict> verdicts = {SceneVerdict::Draw, SceneVerdict::Spiky, SceneVerdict::Draw,
                                          SceneVerdict::Cull, SceneVerdict::Cull};
    // Ghost 1 sharp and Spiky (caustics: a spike far above the coarse estimate could show): coarsened, but it
    // keeps its small triangles and a sharp ghost's level, so it is drawn alone.
    const PassPlan sharp = plan_pass(e, 0.0, verdicts, selection, detail, 0);
    EXPECT_EQ(sharp.todo, (std::vector<std::size_t>{0, 1}));
    EXPECT_LE(sharp.plans[1].grid, 16);
    EXPECT_EQ(sharp.plans[1].reduce, 1);
    EXPECT_TRUE(!sharp.plans[1].rim && sharp.plans[1].small_apart);
    EXPECT_EQ(sharp.faint, 0);
    // Ghost 1 sharp but Faint (even its spikes under what the frame shows): the coarsest detail, batched.
    verdicts[1] = SceneVerdict::Faint;
    const PassPlan caustic = plan_pass(e, 0.0, verdicts, selection, detail, 0);
    EXPECT_EQ(caustic.batched, (std::vector<std::size_t>{1}));
    EXPECT_FALSE(caustic.plans[1].rim || caustic.plans[1].small_apart);
    // A sliver ghost (no whole coarse cell: extent 0, its sensor box from the finer pass) 600 pixels across:
    // drawn at the level its box allows (600 / 8 >= 2 x 64 cells), not at full size.
    e[1].extent_mm = 0.0;
    e[1].sensor = {-300 * pixel_mm, -100 * pixel_mm, 300 * pixel_mm, 100 * pixel_mm};
    EXPECT_EQ(plan_pass(e, 0.0, verdicts, selection, detail, 0).plans[1].reduce, 8);
    e[1].extent_mm = 40 * pixel_mm;
    e[1].sensor = {};
    // Ghost 1 smooth: drawn at the coarsest detail, with the pass's other faint ghosts.
    e[1].area_cv = 0.2;
    const PassPlan plan = plan_pass(e, 0.0, verdicts, selection, detail, 0);
    EXPECT_EQ(plan.todo, (std::vector<std::size_t>{0}));
    EXPECT_EQ(plan.batched, (std::vector<std::size_t>{1}));  // faint: drawn with the pass's other faint ghosts
    EXPECT_FALSE(plan.plans[1].rim || plan.plans[1].small_apart);
    EXPECT_EQ(plan.culled, 1);  // ghost 4; ghost 3 had no light to cull
    EXPECT_EQ(plan.faint, 1);
    EXPECT_EQ(plan.skipped, 3);
    EXPECT_LE(plan.plans[1].grid, 16);  // faint: at most half the base grid
    // A total over every light's ghosts larger than this light's: its ghost 1 now falls under the threshold.
    EXPECT_EQ(plan_pass(e, 8e3, verdicts, selection, detail, 0).todo, (std::vector<std::size_t>{0}));
    EXPECT_TRUE(plan_pass(e, 8e3, verdicts, selection, detail, 0).batched.empty());
    // Faint ghosts drawn one by one when asked.
    detail.batch_faint = false;
    EXPECT_EQ(plan_pass(e, 0.0, verdicts, selection, detail, 0).todo, (std::vector<std::size_t>{0, 1}));
    EXPECT_TRUE(plan_pass(e, 0.0, verdicts, selection, detail, 0).batched.empty());
}

// A ghost the caller spreads (an extended light's footprint) weighs against the frame with what the spread
// leaves of its peak: at most its power (with kSpreadPowerMargin) times the kernel's largest share over a
// pixel's area, and its caustic spike no higher; its box grows by the spread.
TEST(CullItem, SpreadGhostsPeakAtTheirPowerTimesTheKernelsLargestShare) {
    FlareView view;
    view.width = 1000;
    view.height = 500;
    view.sensor_width_mm = 10.0;
    view.sensor_height_mm = 5.0;  // pixels of 0.01 mm, 1e-4 mm^2
    GhostEstimate e;
    e.rect = {-1.0, -1.0, 1.0, 1.0};
    e.sensor = {-0.5, -0.5, 0.5, 0.5};  // 100 px square at the centre
    e.peak = 3.0;
    e.power = 2e-2;  // as estimate_light gives it: 100 pixels' worth at irradiance 1, times the pass's weight 2
    e.area_cv = 1.0;  // caustics: its spike may reach kCausticSpike x peak when drawn
    const std::array<double, 3> unit{1.0, 1.0, 1.0};
    const CullItem sharp = cull_item(e, 0.0, unit, {0.0, 2.0, 0.0}, nullptr, view);
    EXPECT_DOUBLE_EQ(sharp.peak[1], 6.0);
    EXPECT_DOUBLE_EQ(sharp.spike, caustic_spike(e));
    // Spread so one pixel keeps at most 1/400 of a ghost's light: 100 / 400 = 0.25 (with the margin 0.5),
    // times the pass's weight 2.
    const std::array<double, 3> green{0.0, 2.0, 0.0};
    const CullItem spread = cull_item(e, 0.0, unit, green, nullptr, view, {30.0, 1.0 / 400.0});
    EXPECT_DOUBLE_EQ(spread.peak[1], 2.0 * kSpreadPowerMargin * 100.0 / 400.0);
    EXPECT_DOUBLE_EQ(spread.peak[0], 0.0);
    EXPECT_DOUBLE_EQ(spread.spike, 1.0);  // the spread bounds the spike too
    EXPECT_DOUBLE_EQ(spread.x0, sharp.x0 - 30.0);
    EXPECT_DOUBLE_EQ(spread.y1, sharp.y1 + 30.0);
    // A spread that keeps more than the ghost's own peak changes nothing but the box.
    const CullItem wide = cull_item(e, 0.0, unit, green, nullptr, view, {30.0, 0.9});
    EXPECT_DOUBLE_EQ(wide.peak[1], 6.0);
    EXPECT_DOUBLE_EQ(wide.spike, caustic_spike(e));
    // A peak the coarse pass did not find is drawn unspread (not known), but a spread one is bounded by its power.
    e.peak = 0.0;
    EXPECT_LE(cull_item(e, 0.0, unit, green, nullptr, view).x1, cull_item(e, 0.0, unit, green, nullptr, view).x0);
    EXPECT_DOUBLE_EQ(cull_item(e, 0.0, unit, green, nullptr, view, {30.0, 1.0 / 400.0}).peak[1], 2.0 * kSpreadPowerMargin * 100.0 / 400.0);
    // The power is the light's over the pass's channels: a light 10 times as bright, and a look's gain of 3 on
    // green, scale the spread peak as they scale the drawn one.
    e.power = 10.0 * 2e-2;
    const CullItem bright = cull_item(e, 0.0, {10.0, 10.0, 10.0}, green, nullptr, view, {30.0, 1.0 / 400.0});
    EXPECT_DOUBLE_EQ(bright.peak[1], 10.0 * 2.0 * kSpreadPowerMargin * 100.0 / 400.0);
    const optics::GhostStyle look{0, 1, {1.0, 3.0, 1.0}, {0.0, 0.0}};
    EXPECT_DOUBLE_EQ(cull_item(e, 0.0, {10.0, 10.0, 10.0}, green, &look, view, {30.0, 1.0 / 400.0}).peak[1],
                     3.0 * bright.peak[1]);
}

// A ghost's bright rim (its outline's cells squeezed into a ring, which its whole cells' peak leaves out)
// weighs by what one pixel holds of it: sqrt(2) times its width times its irradiance over a pixel's side while the
// ring is narrower than a pixel, so four times as much on a frame of four times the width, and at most the ring's own
// irradiance once a pixel is narrower than it. canon-70-200's faint ring ghost on the stage frame at 4K and 8K
// was 5 codes in 8-bit sRGB when weighed by its whole cells alone.
TEST(PixelPeak, ARingNarrowerThanAPixelAddsItsWidthsShare) {
    GhostEstimate e;
    e.peak = 1.0;
    EXPECT_DOUBLE_EQ(pixel_peak(e, 0.01), 1.0);  // no ring
    e.edge_peak = 40.0;                           // a ring 40 times as bright as the inside...
    e.edge_line = 40.0 * 0.001;                   // ...1 micrometre wide
    const double hd = pixel_peak(e, 0.02), uhd = pixel_peak(e, 0.005);
    EXPECT_NEAR(hd, 1.0 + std::numbers::sqrt2 * 40.0 * 0.001 / 0.02, 1e-12);
    EXPECT_NEAR(uhd - 1.0, 4.0 * (hd - 1.0), 1e-12);
    EXPECT_DOUBLE_EQ(pixel_peak(e, 1e-5), 40.0);  // pixels narrower than the ring: its irradiance
    e.edge_peak = 0.5;                            // a dim outline never lowers the peak
    EXPECT_DOUBLE_EQ(pixel_peak(e, 1e-5), 1.0);
    // cull_item weighs a ghost by it: the 4K frame's item is brighter than the HD frame's, the box the same.
    FlareView view;
    view.sensor_width_mm = 36.0;
    view.sensor_height_mm = 20.25;
    e.edge_peak = 40.0;
    e.rect = {-1.0, -1.0, 1.0, 1.0};
    e.sensor = {-0.5, -0.5, 0.5, 0.5};
    const std::array<double, 3> unit{1.0, 1.0, 1.0};
    view.width = 1920;
    view.height = 1080;
    const CullItem at_hd = cull_item(e, 0.0, unit, unit, nullptr, view);
    view.width = 3840;
    view.height = 2160;
    const CullItem at_uhd = cull_item(e, 0.0, unit, unit, nullptr, view);
    EXPECT_DOUBLE_EQ(at_hd.peak[0], pixel_peak(e, 36.0 / 1920));
    EXPECT_DOUBLE_EQ(at_uhd.peak[0], pixel_peak(e, 36.0 / 3840));
    EXPECT_GT(at_uhd.peak[0], 1.5 * at_hd.peak[0]);
}

// A faint ghost's grid: 8 cells when its outline loses no light to dropped cells (no failed rays in the
// coarse pass) and it is smooth; 16 (kMinGrid) with failed rays along its outline, or with caustics.
TEST(PlanPass, FaintGhostsWithAnOpenOutlineGetACoarserGrid) {
    const double pixel_mm = 0.01;
    std::vector<GhostEstimate> e = five_estimates(pixel_mm);
    const GhostSelection selection = five_ghosts();
    const DetailSettings detail = detail_32(pixel_mm);
    const std::vector<SceneVerdict> verdicts = {SceneVerdict::Faint, SceneVerdict::Faint, SceneVerdict::Draw,
                                                SceneVerdict::Cull, SceneVerdict::Faint};
    e[0].failed_edge = 0.0;
    e[0].area_cv = 0.05;
    e[1].failed_edge = 0.0;
    e[1].area_cv = 0.5;  // caustics
    e[4].failed_edge = 2.0;  // the outline rule refines its grid
    e[4].area_cv = 0.05;
    const PassPlan plan = plan_pass(e, 0.0, verdicts, selection, detail, 0);
    EXPECT_EQ(plan.batched, (std::vector<std::size_t>{0, 1, 4}));
    EXPECT_EQ(plan.plans[0].grid, 8);
    EXPECT_EQ(plan.plans[1].grid, 16);
    // Drawn (not faint), the same open ghost keeps the level of detail's grid.
    const PassPlan drawn = plan_pass(e, 0.0, {}, selection, detail, 0);
    EXPECT_EQ(drawn.plans[0].grid, 16);
    // A faint ghost with failed rays along its outline keeps the grid the outline rule gives it (its cells
    // dropped whole there lose light its peak does not bound), no rim and no small triangles all the same.
    EXPECT_GT(drawn.plans[4].grid, 16);
    EXPECT_EQ(plan.plans[4].grid, drawn.plans[4].grid);
    EXPECT_FALSE(plan.plans[4].rim);
    EXPECT_FALSE(plan.plans[4].small_apart);
}

TEST(BatchGhosts, FillsTheBufferInOrderAndKeepsLargeGhostsAlone) {
    std::vector<GhostPlan> plans(4);
    plans[0] = {true, 9, 1};   // 100 vertices
    plans[1] = {true, 9, 1};
    plans[2] = {true, 19, 1};  // 400: over the buffer alone
    plans[3] = {true, 4, 1};   // 25
    const auto batches = batch_ghosts({0, 1, 2, 3}, plans, 250, false);
    ASSERT_EQ(batches.size(), 3u);
    ASSERT_EQ(batches[0].size(), 2u);
    EXPECT_EQ(batches[0][1].ghost, 1u);
    EXPECT_EQ(batches[0][1].first_vertex, 100u);
    EXPECT_EQ(batches[0][1].first_index, 12u * 9 * 9);  // after ghost 0's 81 cells, in two lists (splits_interior)
    ASSERT_EQ(batches[1].size(), 1u);
    EXPECT_EQ(batches[1][0].ghost, 2u);
    EXPECT_EQ(batches[2][0].ghost, 3u);
    EXPECT_EQ(batches[2][0].first_vertex, 0u);
    EXPECT_EQ(batches[2][0].first_index, 0u);
    EXPECT_EQ(batch_ghosts({0, 1, 3}, plans, 250, true).size(), 3u);
    EXPECT_TRUE(batch_ghosts({}, plans, 250, false).empty());
}

// A point-sampled ghost without a rim pass keeps its triangles in two lists (the interior ones apart); one with a
// rim pass (which reads which are rasterised there) or a faint one in one; one with area coverage in none.
TEST(BatchGhosts, InteriorTrianglesApartOnlyWithoutARimPassAndNotFaint) {
    const GhostPlan alone{.draw = true, .grid = 9, .reduce = 2};
    const GhostPlan with_rim{.draw = true, .grid = 9, .reduce = kRimReduce};
    const GhostPlan faint{.draw = true, .grid = 9, .reduce = 2, .rim = false, .small_apart = false, .faint = true};
    const GhostPlan area{.draw = true, .grid = 9, .reduce = 1, .area_coverage = true};
    EXPECT_TRUE(splits_interior(alone));
    EXPECT_EQ(triangle_indices(alone), 12u * 81);
    EXPECT_FALSE(splits_interior(with_rim));
    EXPECT_EQ(triangle_indices(with_rim), 6u * 81);
    EXPECT_FALSE(splits_interior(faint));
    EXPECT_EQ(triangle_indices(faint), 6u * 81);
    EXPECT_FALSE(splits_interior(area));
    EXPECT_EQ(triangle_indices(area), 0u);
}

// Faint ghosts in chunks that fit the vertex buffer, each chunk's runs of one grid and level ordered by level,
// then grid (each level's target bound once a chunk), their jobs, vertices and triangle indices (6 a cell)
// one run after another; later bands draw only the full-size ones.
TEST(BatchFaint, RunsOfOneGridAndLevelByLevelInChunksThatFit) {
    std::vector<GhostPlan> plans(6);
    plans[0] = {true, 8, 16};  // 81 vertices, 64 cells
    plans[1] = {true, 9, 4};   // 100 vertices, 81 cells
    plans[2] = {true, 8, 16};
    plans[3] = {true, 8, 4};
    plans[4] = {true, 9, 4};
    plans[5] = {true, 19, 1};  // 400: over the buffer alone
    const auto chunks = batch_faint({0, 1, 2, 3, 4, 5}, plans, 350, 0);
    ASSERT_EQ(chunks.size(), 3u);
    // Level 1/1, then 1/4 (grid 8, then 9), then 1/16, split where the next ghost would overflow.
    ASSERT_EQ(chunks[0].size(), 1u);
    EXPECT_EQ(chunks[0][0].ghosts, std::vector<std::size_t>{5});
    ASSERT_EQ(chunks[1].size(), 2u);
    EXPECT_EQ(chunks[1][0].ghosts, std::vector<std::size_t>{3});
    EXPECT_EQ(chunks[1][0].reduce, 4);
    EXPECT_EQ(chunks[1][1].ghosts, (std::vector<std::size_t>{1, 4}));
    EXPECT_EQ(chunks[1][1].grid, 9);
    EXPECT_EQ(chunks[1][1].first_job, 1u);
    EXPECT_EQ(chunks[1][1].first_vertex, 81u);
    EXPECT_EQ(chunks[1][1].first_index, 6u * 64u);
    ASSERT_EQ(chunks[2].size(), 1u);  // 81 + 200 + 81 > 350
    EXPECT_EQ(chunks[2][0].ghosts, (std::vector<std::size_t>{0, 2}));
    EXPECT_EQ(chunks[2][0].first_vertex, 0u);
    const auto later = batch_faint({0, 1, 2, 3, 4, 5}, plans, 350, 1);
    ASSERT_EQ(later.size(), 1u);
    EXPECT_EQ(later[0][0].ghosts, std::vector<std::size_t>{5});
    EXPECT_TRUE(batch_faint({}, plans, 350, 0).empty());
}

TEST(FullTargetBands, CoverEveryRowOnceWithinTheLimit) {
    const FullBands one = full_target_bands(7680, 4320, 400e6, false);
    EXPECT_EQ(one.count, 2);
    int covered = 0;
    for (int b = 0; b < one.count; ++b) {
        EXPECT_EQ(one.first(b), covered);
        covered = one.end(b);
        EXPECT_LE(16.0 * 7680 * one.rows_drawn(b), 400e6 + 16.0 * 7680 * 2 * FullBands::kMargin);
        EXPECT_LE(one.rows_drawn(b), one.target_rows());
    }
    EXPECT_EQ(covered, 4320);
    EXPECT_EQ(full_target_bands(7680, 4320, 400e6, true).count, 1);
    EXPECT_EQ(full_target_bands(640, 480, 400e6, false).count, 1);
}

TEST(PassTotals, SumEveryLightsDrawnGhosts) {
    std::vector<LightEstimates> lights(2);
    for (LightEstimates& l : lights) l.pass.assign(2, std::vector<GhostEstimate>(3));
    lights[0].pass[0][0].power = 1.0;
    lights[1].pass[0][0].power = 2.0;
    lights[1].pass[0][2].power = 4.0;  // not drawn
    lights[0].pass[1][1].power = 8.0;
    const std::vector<double> totals = pass_totals(lights, 2, {1, 1, 0});
    EXPECT_EQ(totals, (std::vector<double>{3.0, 8.0}));
}

// The trace and shade steps' tests' light: (3, 2) degrees at 550 nm.
FlareView step_view() {
    FlareView view;
    view.angle_x_deg = 3.0;
    view.angle_y_deg = 2.0;
    view.wavelength_nm = 550.0;
    return view;
}

// The trace step alone: the Cooke triplet's 1,7 ghost over its entrance square, traced on the GPU (float),
// lands where the CPU tracer (double) puts the same rays, with the same transmission and the same rays failing.
TEST(TraceStep, OneGhostMatchesTheCpuTracer) {
    const optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    const FlareView view = step_view();
    const optics::TraceSystem traced(system, 550.0);
    const PupilRect square = entrance_square(traced, view);
    const std::vector<Ghost> ghosts = optics::enumerate_ghosts(system);
    const auto ghost = std::find_if(ghosts.begin(), ghosts.end(), [](const Ghost& g) { return g.first == 6 && g.second == 0; });
    ASSERT_NE(ghost, ghosts.end());

    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    constexpr int kGrid = 32;
    const std::vector<float> vertices = renderer.trace_ghost(system, view, {0, 6}, kGrid, square);
    ASSERT_EQ(vertices.size(), static_cast<std::size_t>((kGrid + 1) * (kGrid + 1) * 12));
    int both = 0, disagree = 0;
    for (int iy = 0; iy <= kGrid; ++iy)
        for (int ix = 0; ix <= kGrid; ++ix) {
            const double x = square.x0 + (square.x1 - square.x0) * ix / kGrid;
            const double y = square.y0 + (square.y1 - square.y0) * iy / kGrid;
            const optics::Ray ray = optics::collimated_ray(view.angle_x_deg, view.angle_y_deg, x, y, 0.0);
            const TraceResult cpu = optics::trace(traced, ray, ghost->path);
            const float* v = vertices.data() + static_cast<std::size_t>(iy * (kGrid + 1) + ix) * 12;
            const bool gpu_ok = v[10] > 0.5f;
            if (gpu_ok != cpu.ok()) {
                ++disagree;
                continue;
            }
            if (!gpu_ok) continue;
            ++both;
            EXPECT_NEAR(v[0], cpu.position.x, 1e-3) << ix << "," << iy;
            EXPECT_NEAR(v[1], cpu.position.y, 1e-3) << ix << "," << iy;
            EXPECT_NEAR(v[2], cpu.r_rel, 1e-3) << ix << "," << iy;
            EXPECT_NEAR(v[3], cpu.transmission, 0.01 * cpu.transmission + 1e-7) << ix << "," << iy;
        }
    EXPECT_GT(both, 100);  // of 33 x 33 over the entrance square: about a fifth get through
    EXPECT_LE(disagree, kGrid);  // rays at a surface's edge may go either way in float
    EXPECT_THROW(renderer.trace_ghost(system, view, {0, 99}, kGrid, square), std::invalid_argument);
}

// The shade step's mark that a vertex's triangles lie inside the iris (bit 64 of its valid flag), by which the
// indexed draw skips their pixels' iris look-ups: wherever it is set, every point of the triangles round the
// vertex lies inside the iris (the exact CPU SDF) at each stop crossing; and it is set for most of the vertices
// of a ghost a six-bladed iris cuts, but not for those along the cut.
TEST(ShadeStep, InsideIrisMarkOnlyWhereTheTrianglesAreInside) {
    optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    system.aperture.blades = 6;
    const FlareView view = step_view();
    const PupilRect square = entrance_square(optics::TraceSystem(system, 550.0), view);
    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    constexpr int kGrid = 48;
    const std::vector<float> vertices = renderer.trace_ghost(system, view, {0, 6}, kGrid, square);
    ASSERT_EQ(vertices.size(), static_cast<std::size_t>((kGrid + 1) * (kGrid + 1) * 12));
    auto at = [&](int ix, int iy) { return vertices.data() + static_cast<std::size_t>(iy * (kGrid + 1) + ix) * 12; };
    auto valid = [](const float* v) { return v[10] > 0.5f; };
    auto marked = [](const float* v) { return (static_cast<int>(std::lround((v[10] - 1.0f) * 1024.0f)) & 64) != 0; };
    const optics::IrisSdf sdf(system.aperture);
    int inside = 0, cut = 0, marks = 0;
    for (int iy = 0; iy <= kGrid; ++iy)
        for (int ix = 0; ix <= kGrid; ++ix) {
            const float* me = at(ix, iy);
            if (!valid(me)) continue;
            bool fan_inside = true;  // every point of the segments to the valid neighbours, at each crossing
            for (int ny = std::max(iy - 1, 0); ny <= std::min(iy + 1, kGrid); ++ny)
                for (int nx = std::max(ix - 1, 0); nx <= std::min(ix + 1, kGrid); ++nx) {
                    const float* n = at(nx, ny);
                    if (!valid(n)) continue;
                    for (int c = 0; c < 3; ++c)
                        for (int k = 0; k <= 8; ++k) {
                            const double t = k / 8.0;
                            const double u = std::lerp(double{me[4 + 2 * c]}, double{n[4 + 2 * c]}, t);
                            const double w = std::lerp(double{me[5 + 2 * c]}, double{n[5 + 2 * c]}, t);
                            if (!(sdf(u, w) < 0.0)) fan_inside = false;
                        }
                }
            if (marked(me)) {
                ++marks;
                EXPECT_TRUE(fan_inside) << "marked inside the iris at " << ix << "," << iy;
            }
            (fan_inside ? inside : cut) += 1;
        }
    EXPECT_GT(cut, 0);                // the iris cuts this ghost
    EXPECT_GT(marks, inside / 2);     // and the mark spares most of the inside its look-ups
}

// A visibility map over a width x height frame under which every ghost whose peak is known is faint and none
// is culled: each cell shows only huge additions, and the budget is 0. Every such ghost is then far under what
// the frame shows: Faint with veil_ratio 0, a Veil with kVeilRatio.
std::shared_ptr<VisibilityMap> everything_faint(int width, int height, double veil_ratio = 0.0) {
    auto map = std::make_shared<VisibilityMap>();
    map->width = width;
    map->height = height;
    map->cols = (width + map->cell - 1) / map->cell;
    map->rows = (height + map->cell - 1) / map->cell;
    map->visible.assign(static_cast<std::size_t>(map->cols) * static_cast<std::size_t>(map->rows) * 3, 1e30f);
    map->budget = 0.0;
    map->veil_ratio = veil_ratio;
    return map;
}
// A faint ghost is drawn at the most reduced level that keeps 64 of its level's pixels across it: 1/32 from 2048
// pixels across (its fragments at 1/16 were most of its cost), 1/16 below. Drawn (not faint), the same ghost
// keeps the smooth ghosts' 1/16.
TEST(PlanPass, FaintGhostsAtLeast2048PixelsAcrossAreDrawnAtOneThirtySecond) {
    const double pixel_mm = 0.01;
    std::vector<GhostEstimate> e = five_estimates(pixel_mm);  // ghost 0: smooth, 2100 px across
    const GhostSelection selection = five_ghosts();
    const DetailSettings detail = detail_32(pixel_mm);
    const std::vector<SceneVerdict> verdicts = {SceneVerdict::Faint, SceneVerdict::Draw, SceneVerdict::Draw,
                                                SceneVerdict::Cull, SceneVerdict::Faint};
    EXPECT_EQ(plan_pass(e, 0.0, verdicts, selection, detail, 0).plans[0].reduce, 32);
    EXPECT_EQ(plan_pass(e, 0.0, {}, selection, detail, 0).plans[0].reduce, 16);
    e[0].extent_mm = 2000 * pixel_mm;
    EXPECT_EQ(plan_pass(e, 0.0, verdicts, selection, detail, 0).plans[0].reduce, 16);
    e[0].extent_mm = 1000 * pixel_mm;
    EXPECT_EQ(plan_pass(e, 0.0, verdicts, selection, detail, 0).plans[0].reduce, 8);
}

// A Veil (far under what the frame shows) is drawn coarser than a Faint ghost: at the most reduced level that
// keeps 16 (not 64) of its level's pixels across it, and on 8 cells even where its outline has failed rays.
// Batched with the faint ghosts, not rim-drawn, its small triangles left out.
TEST(PlanPass, VeilsAreDrawnCoarserThanFaintGhosts) {
    const double pixel_mm = 0.01;
    std::vector<GhostEstimate> e = five_estimates(pixel_mm);
    const GhostSelection selection = five_ghosts();
    const DetailSettings detail = detail_32(pixel_mm);
    e[0].extent_mm = 600 * pixel_mm;
    e[0].failed_edge = 2.0;  // the outline rule refines a Faint ghost's grid
    e[0].area_cv = 0.05;
    e[4].extent_mm = 100 * pixel_mm;
    e[4].area_cv = 0.05;
    const std::vector<SceneVerdict> faint = {SceneVerdict::Faint, SceneVerdict::Draw, SceneVerdict::Draw, SceneVerdict::Cull,
                                             SceneVerdict::Faint};
    const std::vector<SceneVerdict> veil = {SceneVerdict::Veil, SceneVerdict::Draw, SceneVerdict::Draw, SceneVerdict::Cull,
                                            SceneVerdict::Veil};
    const PassPlan f = plan_pass(e, 0.0, faint, selection, detail, 0);
    const PassPlan v = plan_pass(e, 0.0, veil, selection, detail, 0);
    EXPECT_EQ(f.plans[0].reduce, 8);   // 600 px: 75 at 1/8; 37.5 at 1/16 is under 64
    EXPECT_EQ(v.plans[0].reduce, 32);  // 18.75 px at 1/32
    EXPECT_EQ(f.plans[4].reduce, 1);   // 100 px: under 128
    EXPECT_EQ(v.plans[4].reduce, 4);   // 25 px at 1/4; 12.5 at 1/8 is under 16
    EXPECT_GT(f.plans[0].grid, 8);
    EXPECT_EQ(v.plans[0].grid, 8);
    EXPECT_EQ(v.batched, f.batched);
    EXPECT_EQ(v.batched, (std::vector<std::size_t>{0, 4}));
    EXPECT_EQ(v.faint, 2);
    for (const std::size_t g : v.batched) {
        EXPECT_TRUE(v.plans[g].faint);
        EXPECT_FALSE(v.plans[g].rim);
        EXPECT_FALSE(v.plans[g].small_apart);
    }
    // A Veil with caustics keeps a Faint ghost's grid, on which its spike factor was measured: kMinGrid (16), or
    // the outline rule's where its outline has failed rays.
    e[0].area_cv = 2.0;
    EXPECT_EQ(plan_pass(e, 0.0, veil, selection, detail, 0).plans[0].grid, plan_pass(e, 0.0, faint, selection, detail, 0).plans[0].grid);
    e[0].failed_edge = 0.0;
    EXPECT_EQ(plan_pass(e, 0.0, veil, selection, detail, 0).plans[0].grid, 16);
}

// The largest difference between two images of the same size, value by value.
double largest_difference(const std::vector<float>& a, const std::vector<float>& b) {
    double largest = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) largest = std::max(largest, static_cast<double>(std::abs(a[i] - b[i])));
    return largest;
}

// The cooke triplet at 320 x 200 with every ghost faint (everything_faint): a renderer and its options, and the
// image render_add makes of some lights with them.
struct FaintTriplet {
    const optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    FlareView view = [] {
        FlareView v;
        v.width = 320;
        v.height = 200;
        return v;
    }();
    const Context context{Platform::Surfaceless};
    FlareRenderer renderer{context};
    GpuFlareOptions options = [this] {
        GpuFlareOptions o;
        o.visibility = everything_faint(view.width, view.height);
        return o;
    }();

    std::vector<float> image(const std::vector<ScaledLight>& lights) {
        std::vector<float> rgb(static_cast<std::size_t>(view.width * view.height * 3), 0.0f);
        renderer.render_add(system, view, lights, options, rgb);
        return rgb;
    }
};

// The shade step's interior list (GpuFlareOptions::split_interior), whose triangles are drawn without the cuts: each
// is in one list only, its provoking vertex (the last corner, GL's default) carries the inside-the-iris mark by which
// the indexed draw would skip the iris there, and r_rel, linear over it, is at least half a pixel inside 1 at every
// corner, so that the rim's share of each of its pixels is 1. A ghost that both the rims and a six-bladed iris cut,
// 15 degrees off axis, on a grid of 48 (its cells a few pixels across); a good part of its triangles is interior.
TEST(ShadeStep, InteriorTrianglesNoCutReaches) {
    optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    system.aperture.blades = 6;
    FlareView view = step_view();
    view.angle_x_deg = -15.0;
    view.angle_y_deg = 5.0;
    const PupilRect square = entrance_square(optics::TraceSystem(system, 550.0), view);
    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    constexpr int kGrid = 48;
    std::vector<std::uint32_t> indices;
    const std::vector<float> vertices = renderer.trace_ghost(system, view, {0, 6}, kGrid, square, &indices);
    constexpr std::size_t kCells = std::size_t{kGrid} * kGrid;
    ASSERT_EQ(indices.size(), 12 * kCells);
    const double px_x = view.width / view.sensor_width_mm, px_y = view.height / view.sensor_height_mm;
    auto vertex = [&](std::uint32_t i) { return vertices.data() + std::size_t{i} * 12; };
    auto marked = [](const float* v) { return (static_cast<int>(std::lround((v[10] - 1.0f) * 1024.0f)) & 64) != 0; };
    auto listed = [](const std::uint32_t* t) { return !(t[0] == t[1] && t[1] == t[2]); };
    // The distance in pixels of corner k to where r_rel, linear over the triangle, is 1 (positive inside).
    auto rim_distance = [&](const std::uint32_t* t, int k) {
        const float *p0 = vertex(t[0]), *p1 = vertex(t[1]), *p2 = vertex(t[2]);
        const double e1x = double{p1[0] - p0[0]} * px_x, e1y = double{p1[1] - p0[1]} * px_y;
        const double e2x = double{p2[0] - p0[0]} * px_x, e2y = double{p2[1] - p0[1]} * px_y;
        const double det = e1x * e2y - e1y * e2x;
        const double f0 = double{p0[2]} - 1.0, f1 = double{p1[2]} - 1.0, f2 = double{p2[2]} - 1.0;
        const double gx = ((f1 - f0) * e2y - (f2 - f0) * e1y) / det, gy = ((f2 - f0) * e1x - (f1 - f0) * e2x) / det;
        const double f = k == 0 ? f0 : k == 1 ? f1 : f2;
        return -f / std::hypot(gx, gy);
    };
    int edge = 0, interior = 0, cut_by_rim = 0;
    for (std::size_t c = 0; c < kCells; ++c)
        for (std::size_t t = 0; t < 2; ++t) {
            const std::uint32_t* first = indices.data() + 6 * c + 3 * t;
            const std::uint32_t* inner = first + 6 * kCells;
            edge += listed(first);
            if (listed(first) && (vertex(first[0])[2] > 1.0f || vertex(first[1])[2] > 1.0f || vertex(first[2])[2] > 1.0f))
                ++cut_by_rim;
            if (!listed(inner)) continue;
            ++interior;
            EXPECT_FALSE(listed(first)) << "cell " << c << " triangle " << t << " in both lists";
            EXPECT_TRUE(marked(vertex(inner[2]))) << "cell " << c << " triangle " << t << ": provoking vertex not inside the iris";
            for (int k = 0; k < 3; ++k) EXPECT_GE(rim_distance(inner, k), 0.5) << "cell " << c << " triangle " << t;
        }
    EXPECT_GT(cut_by_rim, 0);         // the rims cut this ghost
    EXPECT_GT(4 * interior, interior + edge);  // and a good part of its triangles are interior
}

// Reduced targets read back whole and widened on two threads, half the rows each, make the image the banded
// read-back on one thread makes, bit for bit: faint ghosts at 1/2 .. 1/32 of a frame 200 rows high (split at row
// 100, through the Mitchell taps' reach), two lights, the full-size target in bands beside them.
TEST(SplitReadBack, SameImageAsBandsOnOneThread) {
    FaintTriplet t;
    t.options.full_target_bytes = 16.0 * t.view.width * t.view.height / 3.0;
    const std::vector<ScaledLight> lights = {{3.0, 2.0, {1.0, 0.8, 0.6}}, {-6.0, 1.0, {0.3, 0.3, 0.5}}};
    const std::vector<float> split = t.image(lights);
    EXPECT_GT(t.renderer.last_stats().ghosts_reduced, 10);
    t.options.split_read_back = false;
    const std::vector<float> bands = t.image(lights);
    ASSERT_GT(*std::max_element(bands.begin(), bands.end()), 0.0f);
    EXPECT_EQ(split, bands);
}

// The triangles no cut reaches, drawn apart by a shader without the cuts (GpuFlareOptions::split_interior), make
// the image the one list drawn with the cuts makes: every ghost drawn as its level of detail plans it (most
// point-sampled without a rim pass, at full size and reduced), two lights, one 20 degrees off axis for the lens's
// rims to cut its ghosts, a styled ghost (gain and offset), the full-size target whole or in bands. A triangle
// taken for interior where a rim or the iris reaches it shows there uncut (it fails so with the rim's margin
// below zero, or with the iris left out of the split).
class InteriorTriangles : public ::testing::TestWithParam<bool> {};
TEST_P(InteriorTriangles, SameImageAsOneListWithTheCuts) {
    FaintTriplet t;
    GpuFlareOptions& options = t.options;
    options.visibility = nullptr;  // no ghost faint
    if (GetParam()) options.full_target_bytes = 16.0 * t.view.width * t.view.height / 3.0;  // three bands
    options.styles = {{0, 6, {2.0, 0.5, 1.0}, {1.5, -1.0}}};
    const std::vector<ScaledLight> lights = {{3.0, 2.0, {1.0, 0.8, 0.6}}, {-20.0, 8.0, {0.3, 0.3, 0.5}}};
    const std::vector<float> split = t.image(lights);
    EXPECT_GT(t.renderer.last_stats().ghosts_reduced, 5);
    options.split_interior = false;
    const std::vector<float> one_list = t.image(lights);
    const float peak = *std::max_element(one_list.begin(), one_list.end());
    ASSERT_GT(peak, 0.0f);
    EXPECT_LE(largest_difference(split, one_list), 1e-5 * static_cast<double>(peak));  // the order of the additions only
}
INSTANTIATE_TEST_SUITE_P(WholeOrBands, InteriorTriangles, ::testing::Bool());

// The batched draw of faint ghosts (per grid and level one trace, one shade and one indexed draw) makes the
// image their one-by-one draws make: two lights, a styled ghost (gain and offset), the full-size target in bands,
// the sharp iris and its ringing (the batched draw reads the iris only at each ghost's stop crossings); the
// ghosts Faint, or all Veils (coarser levels, 8 cells).
class BatchedFaintGhosts : public ::testing::TestWithParam<std::tuple<bool, bool>> {};
TEST_P(BatchedFaintGhosts, SameImageAsOneDrawEach) {
    FaintTriplet t;
    GpuFlareOptions& options = t.options;
    const auto [ringing, veils] = GetParam();
    if (veils) options.visibility = everything_faint(t.view.width, t.view.height, kVeilRatio);
    options.full_target_bytes = 16.0 * t.view.width * t.view.height / 3.0;  // three bands
    options.styles = {{0, 6, {2.0, 0.5, 1.0}, {1.5, -1.0}}};
    options.ringing = ringing;
    options.merge_faint = false;  // drawn one by one, no ghost is merged
    const std::vector<ScaledLight> lights = {{3.0, 2.0, {1.0, 0.8, 0.6}}, {-6.0, 1.0, {0.3, 0.3, 0.5}}};
    const std::vector<float> batched = t.image(lights);
    const RenderStats stats = t.renderer.last_stats();
    options.batch_faint = false;
    const std::vector<float> alone = t.image(lights);
    const FlareRenderer& renderer = t.renderer;
    EXPECT_GT(stats.ghosts_faint, 10);
    EXPECT_EQ(stats.ghosts_drawn, renderer.last_stats().ghosts_drawn);
    EXPECT_EQ(stats.ghosts_reduced, renderer.last_stats().ghosts_reduced);
    const float peak = *std::max_element(alone.begin(), alone.end());
    ASSERT_GT(peak, 0.0f);
    EXPECT_LE(largest_difference(batched, alone), 1e-5 * static_cast<double>(peak));  // the order of the additions only
}
INSTANTIATE_TEST_SUITE_P(SharpAndRingingFaintAndVeils, BatchedFaintGhosts, ::testing::Combine(::testing::Bool(), ::testing::Bool()));

// Three passes (R, G, B) of three ghosts, all drawn batched at 1/8 of a frame of 0.01-mm pixels: ghost 0 lands
// in R and B within kMergeShiftPx of its level's pixels of G (the middle pass, its host), so G draws it once
// with R's and B's weights times its power there over its power in G; ghost 1's B box lies a pixel further,
// so B keeps it; ghost 2 is culled in G (not batched there), so R (the next pass from the middle) hosts it and
// B's share, and G adds nothing.
TEST(MergeFaintPasses, AGhostDrawnOnceWhereItsPassesLandTogether) {
    const double pixel_mm = 0.01;
    const std::vector<SpectralPass> passes = {{610.0, {1.0, 0.0, 0.0}}, {550.0, {0.0, 1.0, 0.0}}, {465.0, {0.0, 0.0, 1.0}}};
    const std::array<double, 3> light = {2.0, 1.0, 4.0};  // estimate_light scales each pass's powers by these
    const double shift = kMergeShiftPx * 8 * pixel_mm;    // the most a box may move at 1/8
    LightEstimates estimates;
    const std::array<double, 3> power = {0.3, 0.2, 0.1};  // per unit of the light, R G B
    for (std::size_t p = 0; p < 3; ++p) {
        std::vector<GhostEstimate> e(3);
        for (std::size_t g = 0; g < 3; ++g) {
            e[g].power = power[p] * light[p] * static_cast<double>(g + 1);
            e[g].sensor = {-1.0, -0.5, 1.0, 0.5};
        }
        estimates.pass.push_back(e);
    }
    estimates.pass[0][0].sensor.x0 -= 0.9 * shift;  // ghost 0 in R and B within the shift of G
    estimates.pass[2][0].sensor.y1 += 0.9 * shift;
    estimates.pass[2][1].sensor.x1 += 1.1 * shift;  // ghost 1 in B beyond it
    std::vector<PassPlan> plans(3);
    for (std::size_t p = 0; p < 3; ++p) {
        plans[p].plans.assign(3, GhostPlan{});
        for (GhostPlan& plan : plans[p].plans) plan.reduce = 8;
        plans[p].batched = p == 1 ? std::vector<std::size_t>{0, 1} : std::vector<std::size_t>{0, 1, 2};
    }
    const MergedFaint merged = merge_faint_passes(plans, estimates, passes, light, pixel_mm);
    EXPECT_EQ(merged.merged, 4);  // ghost 0 from R and B, ghost 1 from R, ghost 2 from B
    EXPECT_EQ(plans[0].batched, (std::vector<std::size_t>{2}));
    EXPECT_EQ(plans[1].batched, (std::vector<std::size_t>{0, 1}));
    EXPECT_EQ(plans[2].batched, (std::vector<std::size_t>{1}));
    for (std::size_t c = 0; c < 3; ++c) {
        EXPECT_NEAR(merged.weight[1][0][c], power[c] / power[1], 1e-12) << c;  // G draws ghost 0 for all three
        EXPECT_NEAR(merged.weight[0][2][c], c == 1 ? 0.0 : power[c] / power[0], 1e-12) << c;  // R hosts ghost 2
    }
    EXPECT_EQ(merged.weight[1][1], (std::array<double, 3>{power[0] / power[1], 1.0, 0.0}));
    EXPECT_EQ(merged.weight[2][1], passes[2].weight);  // B draws its own
}

// A ghost's faint light is hosted by the pass that draws it most finely (a Faint R pass of a ghost that is a Veil
// in G and B: a finer level, more cells), so the others merge into it; where no pass draws it at least as finely
// as every other (R at a finer level but on fewer cells), or where the finer pass draws it at full size and the
// others reduced, the middle pass hosts it and R keeps its own.
TEST(MergeFaintPasses, AGhostIsHostedByThePassDrawingItMostFinely) {
    const double pixel_mm = 0.01;
    const std::vector<SpectralPass> passes = {{610.0, {1.0, 0.0, 0.0}}, {550.0, {0.0, 1.0, 0.0}}, {465.0, {0.0, 0.0, 1.0}}};
    const std::array<double, 3> light = {1.0, 1.0, 1.0};
    LightEstimates estimates;
    for (std::size_t p = 0; p < 3; ++p) {
        std::vector<GhostEstimate> e(1);
        e[0].power = 0.1;
        e[0].sensor = {-1.0, -0.5, 1.0, 0.5};
        estimates.pass.push_back(e);
    }
    auto veils_but_red = [](int red_reduce, int red_grid) {
        std::vector<PassPlan> plans(3);
        for (std::size_t p = 0; p < 3; ++p) {
            plans[p].plans.assign(1, GhostPlan{});
            plans[p].plans[0].reduce = 32;  // as G and B draw it: a Veil
            plans[p].plans[0].grid = 8;
            plans[p].batched = {0};
        }
        plans[0].plans[0].reduce = red_reduce;
        plans[0].plans[0].grid = red_grid;
        return plans;
    };
    std::vector<PassPlan> finer = veils_but_red(8, 16);  // R: Faint, finer in level and grid
    const MergedFaint into_red = merge_faint_passes(finer, estimates, passes, light, pixel_mm);
    EXPECT_EQ(into_red.merged, 2);  // G and B into R
    EXPECT_EQ(finer[0].batched, (std::vector<std::size_t>{0}));
    EXPECT_TRUE(finer[1].batched.empty());
    EXPECT_TRUE(finer[2].batched.empty());
    EXPECT_EQ(into_red.weight[0][0], (std::array<double, 3>{1.0, 1.0, 1.0}));
    std::vector<PassPlan> mixed = veils_but_red(8, 4);  // R: a finer level on fewer cells
    const MergedFaint into_green = merge_faint_passes(mixed, estimates, passes, light, pixel_mm);
    EXPECT_EQ(into_green.merged, 1);  // B into G; R drawn apart
    EXPECT_EQ(mixed[0].batched, (std::vector<std::size_t>{0}));
    EXPECT_TRUE(mixed[2].batched.empty());
    EXPECT_EQ(into_green.weight[1][0], (std::array<double, 3>{0.0, 1.0, 1.0}));
    EXPECT_EQ(into_green.weight[0][0], passes[0].weight);
    // R at full size: a reduced faint ghost is drawn with the first band only, so a full-size host would lose G's and
    // B's light in a banded frame's later bands: G hosts B, R keeps its own.
    std::vector<PassPlan> full_red = veils_but_red(1, 16);
    const MergedFaint banded = merge_faint_passes(full_red, estimates, passes, light, pixel_mm);
    EXPECT_EQ(banded.merged, 1);
    EXPECT_EQ(full_red[0].batched, (std::vector<std::size_t>{0}));
    EXPECT_EQ(full_red[1].batched, (std::vector<std::size_t>{0}));
    EXPECT_TRUE(full_red[2].batched.empty());
    EXPECT_EQ(banded.weight[0][0], passes[0].weight);
}

// Merged, the faint ghosts of a render add up to the light their passes drawn apart add in each channel, where
// it lands (the cooke triplet, everything faint), and each merged ghost is one draw fewer.
TEST(MergeFaintPasses, MergedFaintGhostsKeepEachChannelsLight) {
    FaintTriplet t;
    const std::vector<ScaledLight> lights = {{3.0, 2.0, {1.0, 0.8, 0.6}}};
    const std::vector<float> merged = t.image(lights);
    const RenderStats stats = t.renderer.last_stats();
    t.options.merge_faint = false;
    const std::vector<float> apart = t.image(lights);
    const FlareRenderer& renderer = t.renderer;
    EXPECT_GT(stats.ghosts_merged, 10);
    EXPECT_EQ(stats.ghosts_drawn + stats.ghosts_merged, renderer.last_stats().ghosts_drawn);
    EXPECT_EQ(renderer.last_stats().ghosts_merged, 0);
    for (std::size_t c = 0; c < 3; ++c) {
        double sum_merged = 0.0, sum_apart = 0.0, diff = 0.0;
        for (std::size_t i = c; i < merged.size(); i += 3) {
            sum_merged += static_cast<double>(merged[i]);
            sum_apart += static_cast<double>(apart[i]);
            diff += std::abs(static_cast<double>(merged[i]) - static_cast<double>(apart[i]));
        }
        ASSERT_GT(sum_apart, 0.0) << c;
        // The channel's light, within what the coarse estimates the ratios come from hold (R 1.5% more, B
        // 3.2% less when written), and where it lands.
        EXPECT_NEAR(sum_merged / sum_apart, 1.0, 0.05) << c;
        EXPECT_LT(diff / sum_apart, 0.1) << c;
    }
}

// render_add at a level (for ghosts the caller blurs): an image of the view reduced by that level, holding what
// the full-size render holds averaged over each level pixel's block, with no ghost drawn finer (a ghost drawn
// at full size there would be a logic error); the same light in all, and a level that is no power of 2 refused.
TEST(RenderAddReduced, HoldsTheFullRendersBlockMeansAtThatLevel) {
    const optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    FlareView view;
    view.width = 324;  // not a multiple of 8: the last column of blocks is partly outside
    view.height = 200;
    const Context context(Platform::Surfaceless);
    FlareRenderer renderer(context);
    const GpuFlareOptions options;
    const std::vector<ScaledLight> lights = {{6.0, 3.0, {1.0, 0.8, 0.6}}};
    std::vector<float> full(static_cast<std::size_t>(view.width * view.height * 3), 0.0f);
    renderer.render_add(system, view, lights, options, full);
    const int level = 8, w = flare::reduced_side(view.width, level), h = flare::reduced_side(view.height, level);
    std::vector<float> reduced(static_cast<std::size_t>(w * h * 3), 0.0f);
    renderer.render_add(system, view, lights, options, reduced, level);
    EXPECT_GT(renderer.last_stats().ghosts_drawn, 10);
    EXPECT_EQ(renderer.last_stats().ghosts_reduced, renderer.last_stats().ghosts_drawn);
    std::vector<float> expected(reduced.size(), 0.0f);
    flare::reduce_area(flare::RgbView{expected.data(), 0, 0, w, h}, flare::ConstRgbView{full.data(), 0, 0, view.width, view.height}, level);
    double sum_full = 0.0, sum_reduced = 0.0, err = 0.0, norm = 0.0;
    for (std::size_t i = 0; i < reduced.size(); ++i) {
        sum_full += static_cast<double>(expected[i]);
        sum_reduced += static_cast<double>(reduced[i]);
        err += std::abs(static_cast<double>(reduced[i] - expected[i]));
        norm += static_cast<double>(expected[i]);
    }
    ASSERT_GT(sum_full, 0.0);
    EXPECT_NEAR(sum_reduced / sum_full, 1.0, 0.03);  // the same light
    EXPECT_LT(err / norm, 0.25);                     // where it lands, within the level's blur
    std::vector<float> wrong(reduced.size());
    EXPECT_THROW(renderer.render_add(system, view, lights, options, wrong, 3), std::invalid_argument);
    EXPECT_THROW(renderer.render_add(system, view, lights, options, full, 4), std::invalid_argument);  // wrong size
}

// A renderer clears its targets before a render only where the last read-back saw them lit: a render after
// others (a wide one, one of a few ghosts drawn at every level) is bit for bit the image a fresh renderer makes,
// one band or three.
TEST(FlareRenderer, ARenderAfterOthersIsTheImageOfAFreshRenderer) {
    const optics::System system = optics::realize(optics::load_lens("cooke-triplet"));
    FlareView view;
    view.width = 320;
    view.height = 200;
    const Context context(Platform::Surfaceless);
    const std::vector<ScaledLight> wide = {{3.0, 2.0, {1.0, 0.8, 0.6}}, {-6.0, 1.0, {0.3, 0.3, 0.5}}};
    const std::vector<ScaledLight> one = {{-9.0, -4.0, {2.0, 2.0, 2.0}}};
    GpuFlareOptions few;
    few.draw_only = {{6, 0}, {4, 1}, {5, 3}};
    auto image = [&](FlareRenderer& renderer, std::span<const ScaledLight> lights, const GpuFlareOptions& options) {
        std::vector<float> rgb(static_cast<std::size_t>(view.width * view.height * 3), 0.0f);
        renderer.render_add(system, view, lights, options, rgb);
        return rgb;
    };
    for (const double full_target_bytes : {GpuFlareOptions{}.full_target_bytes, 16.0 * view.width * view.height / 3.0}) {
        GpuFlareOptions all;
        all.full_target_bytes = few.full_target_bytes = full_target_bytes;
        FlareRenderer fresh_one(context), fresh_few(context), reused(context);
        const std::vector<float> one_alone = image(fresh_one, one, all), few_alone = image(fresh_few, wide, few);
        ASSERT_GT(fresh_one.last_stats().ghosts_reduced, 0);
        ASSERT_GT(fresh_few.last_stats().ghosts_drawn, 0);
        image(reused, wide, all);
        EXPECT_EQ(image(reused, one, all), one_alone);
        EXPECT_EQ(image(reused, wide, few), few_alone);
        EXPECT_EQ(image(reused, one, all), one_alone);
    }
}

}  // namespace
}  // namespace lensfx::gpu
