// How much of its ghosts a lens draws at most, and the fit of its ghosts to both that count and a memory budget.
#pragma once

#include <cstddef>
#include <vector>

#include <gpu/flare_renderer.h>

namespace lensfx::gpu {

// Interface steps the drawn ghosts of a lens take at most, summed over them: the brightest ghosts by
// power along the axis are drawn up to it. Each step is traced at every vertex of a ghost's grid, so the
// draw time follows this sum. The largest real lens of presets/ (34 surfaces, 528 ghosts) takes under half
// of it; a generated lens of 300 surfaces (44,253 ghosts) still drew after 12 minutes with its 1024
// brightest ghosts, and draws 217 under this cap.
inline constexpr std::size_t kMaxLensGhostSteps = 65536;

// ghosts_within_budget with a cap of `max_steps` summed interface steps: all of them when their data fits
// half the budget and their steps the cap, else the brightest by power along the axis, in that order,
// until the next one would not fit the budget or the cap.
GhostFit ghosts_within(const System& system, std::vector<Ghost> ghosts, std::size_t passes, const MemoryBudget& budget,
                       std::size_t max_steps);

// Interface steps of these ghosts, summed.
std::size_t summed_steps(const std::vector<Ghost>& ghosts);

// Whether a fit's ghost data is over half the budget (ghosts were left out for memory, not only the count).
bool fit_over_budget(const GhostFit& fit, const MemoryBudget& budget);

}  // namespace lensfx::gpu
