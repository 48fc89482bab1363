// The GPU ghost renderer (flare paper section 4.1/4.3): per ghost and wavelength a regular grid of rays
// over the ghost's entrance-pupil bounds is traced through the ghost's fixed interface sequence in a
// compute shader (float); the grid's triangles are rasterised on the sensor with irradiance = flux /
// sensor area, clipped where the interpolated r_rel > 1, shaded by the iris SDF texture at the
// interpolated stop coordinates and the per-ray Fresnel/coating factor, and added in an RGBA32F target.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include <gpu/acceleration.h>
#include <gpu/context.h>
#include <gpu/flare_model.h>
#include <optics/flare_look.h>
#include <optics/memory_budget.h>

namespace lensfx::gpu {

using optics::GhostStyle;  // per-ghost colour, gain and offset (optics/flare_look.h)

struct GpuFlareOptions {
    int grid = 16;                 // base cells per side of each ghost's ray grid (the adaptive grid scales it)
    bool per_ghost_power = false;  // fill FlareImage::ghosts (reads back after every ghost: slower)
    // The full-size RGBA32F target is drawn in horizontal bands of at most this many bytes (1 GB for one
    // 8K target: five bands); each band re-traces the ghosts drawn at full size. Per-ghost power draws it
    // whole. (llvmpipe keeps most of a released target's memory, so the band is held for the whole run.)
    double full_target_bytes = 256e6;
    Acceleration accel;            // all on by default; fixed grid per ghost with every one off
    // High quality: ghosts are shaded by the iris with its ringing (the fractional Fourier transform of
    // order eq. 5 at each pass's wavelength and the lens's f-number) instead of the sharp iris.
    bool ringing = false;
    std::vector<GhostStyle> styles;  // ghosts not listed keep their physical look
    MemoryBudget memory;             // the per-lens tables are sized against it (check_ghost_tables)
    // Scene culling (issue 17): what the frame shows where the ghosts land; null: every ghost the level of
    // detail keeps is drawn. Ignored with per_ghost_power.
    std::shared_ptr<VisibilityMap> visibility;  // its per-cell budget is spent by every render that uses it
    GhostSpread spread;  // how the caller spreads each ghost after it is drawn (a footprint), for culling
    // Draw only these ghosts ((Ghost::first, Ghost::second); empty: all). Unlike FlareView::only_ghosts the
    // renderer keeps the whole lens's ghost list, so the groups of an extended light share one bounds table,
    // one set of sequences and one coarse estimate per light.
    std::vector<std::pair<int, int>> draw_only;
    // The faint ghosts of a pass (scene culling) traced and drawn together, by grid and level; false: one
    // draw each, as every other ghost (the same image; for tests).
    bool batch_faint = true;
    // A faint ghost whose passes land within kMergeShiftPx (2) pixels of its level of each other drawn once
    // for all of them (merge_faint_passes); false: once per pass (for tests and measurements).
    bool merge_faint = true;
    // Reduced targets whose lit windows take at most 16 MiB (a 1080p frame's) read back whole and widened into
    // the image on two threads, half its rows each; false: a band of rows at a time on the drawing thread
    // (the same image, bit for bit; for tests and measurements).
    bool split_read_back = true;
    // A ghost drawn by its triangle indices without a rim pass has the triangles no cut reaches (a lens's rim, the
    // iris) drawn apart by a shader that does not look at the cuts (splits_interior): a third of the work a pixel
    // there; false: every triangle by the shader with the cuts (the same image but for the order of the additions;
    // for tests and measurements).
    bool split_interior = true;
};

// Bytes of the GL render targets at most held while drawing a width x height flare: the full-size
// target's band (GpuFlareOptions::full_target_bytes) and the reduced targets (1/2 ... 1/32).
double render_target_bytes(int width, int height, double full_target_bytes = GpuFlareOptions{}.full_target_bytes);

// Bytes of the per-lens tables the renderer builds for `system` at `passes` wavelengths: the ghost list,
// every ghost's interface sequence and its Fresnel/coating tables, on the CPU and in GL buffers. Ghosts
// grow with the square of the surfaces and their sequences with the surfaces, so a lens of a few hundred
// surfaces asks for tens of GB; this is known before any of it is made.
double ghost_table_bytes(const System& system, std::size_t passes);
// Throws MemoryLimitError naming the lens, its surfaces and ghosts when not even what cannot be made
// smaller fits `budget`: the ghost list and the brightest ghost's data (ghosts_within_budget draws fewer
// ghosts when all of them do not fit).
void check_ghost_tables(const System& system, std::size_t passes, const MemoryBudget& budget);

// The ghosts drawn of a lens under a memory budget: all of them when their data fits half the budget
// and they number at most kMaxLensGhosts (gpu/ghost_cap.h), else the brightest by power along the axis
// that fit and are within that count (a lens of hundreds of surfaces), with the share of the power left
// out. Throws MemoryLimitError when not one fits.
struct GhostFit {
    std::vector<Ghost> ghosts;
    std::size_t total = 0;        // ghosts before fitting
    double bytes_needed = 0.0;    // for all of them
    double power_left_out = 0.0;  // share of the ghosts' summed axial power not drawn
};
GhostFit ghosts_within_budget(const System& system, std::vector<Ghost> ghosts, std::size_t passes, const MemoryBudget& budget);

// One light of a frame for render_add: its direction (as FlareView's angles) and the factor per channel its
// ghosts are added with.
struct ScaledLight {
    double angle_x_deg = 0.0;
    double angle_y_deg = 0.0;
    std::array<double, 3> scale{1.0, 1.0, 1.0};
};

// The side (pixels) of the view FlareRenderer::prepare draws into: its targets are made again at a frame's size.
inline constexpr int kWarmUpSide = 16;

class FlareRenderer {
public:
    // Compiles the shaders; the context must stay alive and current while the renderer is used.
    explicit FlareRenderer(const Context& context);
    ~FlareRenderer();
    FlareRenderer(const FlareRenderer&) = delete;
    FlareRenderer& operator=(const FlareRenderer&) = delete;

    FlareImage render(const System& system, const FlareView& view, const GpuFlareOptions& options = {});
    // Gets ready to render `system` through views like `view` (their size and light aside): every pass's ghost
    // sequences built and uploaded, and every program used once on a few tiny ghosts into small targets, since a
    // software rasteriser compiles a shader at its first use. The filter has this done on a worker thread while
    // the first frame is read and its lights found; a render does whatever was not.
    void prepare(const System& system, const FlareView& view, const GpuFlareOptions& options);
    // The ghosts of several lights seen through the same view (its angles ignored) added into rgb (view.width x
    // view.height, top row first), each light's scaled: the targets are cleared and read back once for all.
    // With level 2, 4, 8 or 16, rgb is the view reduced by level (flare::reduced_side; its pixel i covers the
    // view's pixels [i level, (i + 1) level)) and no ghost is drawn finer: for ghosts the caller blurs anyway.
    void render_add(const System& system, const FlareView& view, std::span<const ScaledLight> lights,
                    const GpuFlareOptions& options, std::vector<float>& rgb, int level = 1);
    const RenderStats& last_stats() const;  // of the last render or render_add (summed over its lights)
    // Frees the render targets (made again by the next render): a large frame's (at 8K over 1 GB) are
    // then not held while the frame is stored and written.
    void release_targets();
    // The trace step alone (for tests): ghost (first, second)'s (grid + 1)^2 ray grid over `rect` on the
    // entrance plane, at the view's light and first pass, read back as ghost_trace_comp writes it (12 floats a
    // vertex: sensor x, y (mm), r_rel, factor, three stop crossings' uv, valid (> 0.5), the shade step's
    // irradiance; row by row from rect's (x0, y0) corner). With `indices`, also the triangle indices the shade step
    // wrote, drawn at full size: 6 a cell (cell by cell, row by row; a point (a, a, a) for a triangle not in the
    // list) for the triangles a cut may reach, then 6 a cell for the interior ones (GpuFlareOptions::split_interior).
    std::vector<float> trace_ghost(const System& system, const FlareView& view, std::pair<int, int> ghost, int grid,
                                   const PupilRect& rect, std::vector<std::uint32_t>* indices = nullptr);

private:
    // The ghosts of `view` that fit the budget (ghosts_within_budget), warning once when some are left out.
    std::vector<Ghost> fitted_ghosts(const System& system, const FlareView& view, const MemoryBudget& budget);
    // The steps of a render (flare_renderer.cpp): estimate the lights, cull, plan, trace and raster each batch,
    // read back.
    class Drawing;
    Drawing start_drawing(const System& system, const FlareView& view, std::span<const ScaledLight> lights,
                          const GpuFlareOptions& options);
    void draw(const System& system, const FlareView& view, std::span<const ScaledLight> lights,
              const GpuFlareOptions& options, std::vector<float>& rgb, std::vector<GhostPower>* ghost_powers, int level = 1);
    struct State;
    std::unique_ptr<State> state_;
};

}  // namespace lensfx::gpu
