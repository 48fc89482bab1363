// The coarse pass's estimate of one ghost from its traced grid (gpu/coarse_estimate.h): each vertex's fate, the
// passing rays' bounds and power, the cells' peak and spread, the outline's cells, and a veil's cells.
#include <gpu/coarse_estimate.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iterator>
#include <vector>

#include <optics/aperture.h>

namespace lensfx::gpu {
namespace {

// A coarse pass's (res + 1)^2 traced vertices (12 floats each, ghost_trace_comp) over `square` of the
// entrance plane, and the light's cos(angle): cell (ix, iy) spans dx x dy from (x0 + ix dx, y0 + iy dy).
struct CoarseGrid {
    const float* vertices;
    int res;
    PupilRect square;
    double cos_angle;
    double dx = (square.x1 - square.x0) / res;
    double dy = (square.y1 - square.y0) / res;
    std::size_t stride = static_cast<std::size_t>(res + 1);

    std::size_t index(int ix, int iy) const { return static_cast<std::size_t>(iy) * stride + static_cast<std::size_t>(ix); }
    const float* vertex(std::size_t index) const { return vertices + index * 12; }
    // The power (mm^2 per unit irradiance) through one cell's entrance area, or one vertex's share, at `transmission`.
    double cell_power(double transmission) const { return transmission * dx * dy * cos_angle; }
};

// What each coarse ray did.
enum VertexFate : char { kBlocked = 0, kIrisBlocked = 1, kPasses = 2, kFailed = 3, kRimBlocked = 4 };

// The coarse vertices sorted by fate, and what the passing ones span: on the entrance plane (`box`, and the
// grid indices [ix0, ix1] x [iy0, iy1]) and on the sensor.
struct CoarseFates {
    std::vector<char> fate;
    bool any = false;
    PupilRect box{1e300, 1e300, -1e300, -1e300};
    PupilRect sensor{1e300, 1e300, -1e300, -1e300};
    int ix0 = 0, iy0 = 0, ix1 = 0, iy1 = 0;
};

// Whether a vertex's ray is inside the iris at each of its (at most three) stop crossings.
bool inside_iris(const float* v, int stop_crossings, const optics::IrisSdf& iris_sdf) {
    for (int k = 0; k < std::min(stop_crossings, 3); ++k)
        if (!(iris_sdf(static_cast<double>(v[4 + 2 * k]), static_cast<double>(v[5 + 2 * k])) <= 0.0)) return false;
    return true;
}

// A vertex's fate: its ray failed, was clipped by a lens's rim, landed beyond sensor_radius_mm of the
// centre (the circle round the sensor, the same for every azimuth of the light), was blocked by the iris at
// one of its stop crossings, or passes.
VertexFate fate_of(const float* v, int stop_crossings, const optics::IrisSdf& iris_sdf, double sensor_radius_mm) {
    if (v[10] < 0.5f) return kFailed;
    if (v[2] > 1.0f) return kRimBlocked;
    if (std::hypot(static_cast<double>(v[0]), static_cast<double>(v[1])) > sensor_radius_mm) return kBlocked;
    return inside_iris(v, stop_crossings, iris_sdf) ? kPasses : kIrisBlocked;
}

// Every vertex's fate, the passing rays' bounds, and their power added to out.power.
CoarseFates sort_vertices(const CoarseGrid& grid, int stop_crossings, const Aperture& aperture, double sensor_radius_mm,
                          GhostEstimate& out) {
    const optics::IrisSdf iris_sdf(aperture);
    CoarseFates f{std::vector<char>(grid.stride * grid.stride, kBlocked)};
    f.ix0 = f.iy0 = grid.res;
    for (int iy = 0; iy <= grid.res; ++iy) {
        for (int ix = 0; ix <= grid.res; ++ix) {
            const std::size_t index = grid.index(ix, iy);
            const float* v = grid.vertex(index);
            f.fate[index] = fate_of(v, stop_crossings, iris_sdf, sensor_radius_mm);
            if (f.fate[index] != kPasses) continue;
            f.any = true;
            out.power += grid.cell_power(static_cast<double>(v[3]));
            const double x = grid.square.x0 + grid.dx * ix;
            const double y = grid.square.y0 + grid.dy * iy;
            f.box = {std::min(f.box.x0, x), std::min(f.box.y0, y), std::max(f.box.x1, x), std::max(f.box.y1, y)};
            f.ix0 = std::min(f.ix0, ix);
            f.iy0 = std::min(f.iy0, iy);
            f.ix1 = std::max(f.ix1, ix);
            f.iy1 = std::max(f.iy1, iy);
            const auto sx = static_cast<double>(v[0]);
            const auto sy = static_cast<double>(v[1]);
            f.sensor = {std::min(f.sensor.x0, sx), std::min(f.sensor.y0, sy), std::max(f.sensor.x1, sx), std::max(f.sensor.y1, sy)};
        }
    }
    return f;
}

// The passing share of the coarse vertices within the passing box grown by a cell.
double passing_share(const CoarseGrid& grid, const CoarseFates& f) {
    const int ix0 = std::max(0, f.ix0 - 1), iy0 = std::max(0, f.iy0 - 1);
    const int ix1 = std::min(grid.res, f.ix1 + 1), iy1 = std::min(grid.res, f.iy1 + 1);
    int passing = 0;
    for (int iy = iy0; iy <= iy1; ++iy)
        for (int ix = ix0; ix <= ix1; ++ix) passing += f.fate[grid.index(ix, iy)] == kPasses;
    return static_cast<double>(passing) / ((ix1 - ix0 + 1) * (iy1 - iy0 + 1));
}

// A whole cell's sensor area (mm^2, shoelace over the quadrilateral of its corners' landing points).
double cell_sensor_area(const CoarseGrid& grid, const std::size_t (&corner)[4]) {
    double twice = 0.0;
    for (int k = 0; k < 4; ++k) {
        const float* p = grid.vertex(corner[k]);
        const float* q = grid.vertex(corner[(k + 1) % 4]);
        twice += static_cast<double>(p[0]) * static_cast<double>(q[1]) - static_cast<double>(q[0]) * static_cast<double>(p[1]);
    }
    return 0.5 * std::abs(twice);
}

// A cell's irradiance on the sensor from its power and sensor area, at most kMaxPeak; kMaxPeak where it is folded
// flat (no area: a caustic, which cull_item takes as not known).
double cell_irradiance(double power, double area) { return area > 0.0 ? std::min(power / area, kMaxPeak) : kMaxPeak; }

// An outline cell's irradiance had it passed whole (its passing corners' mean transmission), and that times its
// width on the sensor (area over its longest side: its power per length, which a fold inside it leaves alone),
// into out.edge_peak and out.edge_line.
void measure_outline_cell(const CoarseGrid& grid, const std::vector<char>& fate, const std::size_t (&corner)[4], GhostEstimate& out) {
    const double area = cell_sensor_area(grid, corner);
    double transmission = 0.0, longest = 0.0;
    int passing = 0;
    for (int k = 0; k < 4; ++k) {
        const float* p = grid.vertex(corner[k]);
        const float* q = grid.vertex(corner[(k + 1) % 4]);
        longest = std::max(longest, std::hypot(static_cast<double>(q[0]) - static_cast<double>(p[0]), static_cast<double>(q[1]) - static_cast<double>(p[1])));
        if (fate[corner[k]] != kPasses) continue;
        transmission += static_cast<double>(p[3]);
        ++passing;
    }
    if (!(longest > 0.0)) return;  // all four corners on one point: no width to weigh
    const double power = grid.cell_power(transmission / passing);
    out.edge_peak = std::max(out.edge_peak, cell_irradiance(power, area));
    out.edge_line = std::max(out.edge_line, std::min(power / longest, kMaxPeak));  // irradiance x width (area / longest)
}

// From the cells: the peak irradiance and the spread of the sensor areas of the cells whose four corners all
// pass, the outline's cells (some corners pass) with a corner whose ray failed or the iris blocked, and the rim
// ring of those with no failed corner (measure_outline_cell).
void measure_cells(const CoarseGrid& grid, const std::vector<char>& fate, GhostEstimate& out) {
    double sum = 0.0, sum2 = 0.0;
    int cells = 0, touched = 0, iris_cut = 0, failed_cut = 0, rim_cut = 0;
    for (int iy = 0; iy < grid.res; ++iy) {
        for (int ix = 0; ix < grid.res; ++ix) {
            const std::size_t a = grid.index(ix, iy);
            const std::size_t corner[4] = {a, a + 1, a + grid.stride + 1, a + grid.stride};
            int pass = 0;
            bool iris = false, failed = false, rim = false;
            for (std::size_t c : corner) {
                pass += fate[c] == kPasses;
                iris = iris || fate[c] == kIrisBlocked;
                failed = failed || fate[c] == kFailed;
                rim = rim || fate[c] == kRimBlocked;
            }
            if (pass == 0) continue;
            ++touched;
            if (pass < 4) {
                iris_cut += iris;
                failed_cut += failed;
                rim_cut += rim;
                if (!failed) measure_outline_cell(grid, fate, corner, out);
                continue;
            }
            const double area = cell_sensor_area(grid, corner);
            double transmission = 0.0;
            for (std::size_t c : corner) transmission += 0.25 * static_cast<double>(grid.vertex(c)[3]);
            out.peak = std::max(out.peak, cell_irradiance(grid.cell_power(transmission), area));
            sum += area;
            sum2 += area * area;
            ++cells;
        }
    }
    if (touched > 0) {
        out.failed_edge = failed_cut / std::sqrt(static_cast<double>(touched));
        out.iris_edge = iris_cut / std::sqrt(static_cast<double>(touched));
        out.rim_edge = rim_cut / std::sqrt(static_cast<double>(touched));
    }
    if (cells > 1 && sum > 0.0) {
        const double mean = sum / cells;
        out.area_cv = std::sqrt(std::max(0.0, sum2 / cells - mean * mean)) / mean;
    } else {
        out.area_cv = 1e9;  // too few whole cells to judge: treat as sharp
    }
}

// A veil larger than the frame: a ghost none of whose cells has four corners within the circle round the sensor
// (measure_cells found no peak) may still cover the sensor with cells whose rays get through but land around it,
// and the renderer draws those within its rectangle (the passing rays' box grown by a cell: the cells [ix0 - 1, ix1]
// x [iy0 - 1, iy1]). Its peak is the brightest such cell whose sensor bounds reach the square round that circle (its
// corners passing, or beyond the circle but through: neither the iris nor a rim blocks them), and its sensor box
// theirs, within that square (the ghost's own frame: a style's offset moves it after, cull_item). Without this a
// veil's peak was unknown and scene culling drew it whole, at full size with area coverage: nikon-80-200 on the 1080p
// stage frame, 65 draws, 2.2 s of its 2.5 s of drawing. A ghost cut by the iris or a rim in every cell (a sliver of
// the pupil) stays unknown: the bounds of cells it lights only in part would misstate its size to the level of detail.
void measure_veil_cells(const CoarseGrid& grid, const CoarseFates& f, int stop_crossings, const Aperture& aperture,
                        double sensor_radius_mm, GhostEstimate& out) {
    const std::vector<char>& fate = f.fate;
    const optics::IrisSdf iris_sdf(aperture);
    // A corner left out only by the circle (kBlocked: fate_of looked at the ray and the rims first) is through
    // where the iris passes it too.
    const auto through = [&](std::size_t c) {
        return fate[c] == kPasses || (fate[c] == kBlocked && inside_iris(grid.vertex(c), stop_crossings, iris_sdf));
    };
    const double r = sensor_radius_mm;
    PupilRect box{1e300, 1e300, -1e300, -1e300};
    double peak = 0.0;
    for (int iy = std::max(f.iy0 - 1, 0); iy <= std::min(f.iy1, grid.res - 1); ++iy) {
        for (int ix = std::max(f.ix0 - 1, 0); ix <= std::min(f.ix1, grid.res - 1); ++ix) {
            const std::size_t a = grid.index(ix, iy);
            const std::size_t corner[4] = {a, a + 1, a + grid.stride + 1, a + grid.stride};
            if (!std::all_of(std::begin(corner), std::end(corner), through)) continue;
            PupilRect cell{1e300, 1e300, -1e300, -1e300};
            double transmission = 0.0;
            for (std::size_t c : corner) {
                const float* v = grid.vertex(c);
                const auto x = static_cast<double>(v[0]), y = static_cast<double>(v[1]);
                cell = {std::min(cell.x0, x), std::min(cell.y0, y), std::max(cell.x1, x), std::max(cell.y1, y)};
                transmission += 0.25 * static_cast<double>(v[3]);
            }
            if (cell.x1 < -r || cell.x0 > r || cell.y1 < -r || cell.y0 > r) continue;  // beside the sensor
            peak = std::max(peak, cell_irradiance(grid.cell_power(transmission), cell_sensor_area(grid, corner)));
            box = {std::min(box.x0, std::max(cell.x0, -r)), std::min(box.y0, std::max(cell.y0, -r)), std::max(box.x1, std::min(cell.x1, r)),
                   std::max(box.y1, std::min(cell.y1, r))};
        }
    }
    if (!(peak > 0.0)) return;
    out.peak = peak;
    out.sensor = {std::min(out.sensor.x0, box.x0), std::min(out.sensor.y0, box.y0), std::max(out.sensor.x1, box.x1),
                  std::max(out.sensor.y1, box.y1)};
    out.extent_mm = std::max(out.sensor.x1 - out.sensor.x0, out.sensor.y1 - out.sensor.y0);
}

}  // namespace

GhostEstimate coarse_estimate(const float* vertices, int res, const PupilRect& square, int stop_crossings,
                              const Aperture& aperture, double cos_angle, double sensor_radius_mm) {
    const CoarseGrid grid{vertices, res, square, cos_angle};
    GhostEstimate out;
    const CoarseFates f = sort_vertices(grid, stop_crossings, aperture, sensor_radius_mm, out);
    if (!f.any) return out;
    out.rect = {std::max(square.x0, f.box.x0 - grid.dx), std::max(square.y0, f.box.y0 - grid.dy),
                std::min(square.x1, f.box.x1 + grid.dx), std::min(square.y1, f.box.y1 + grid.dy)};
    out.extent_mm = std::max(f.sensor.x1 - f.sensor.x0, f.sensor.y1 - f.sensor.y0);
    out.sensor = f.sensor;
    out.fill = passing_share(grid, f);
    measure_cells(grid, f.fate, out);
    if (!(out.peak > 0.0)) measure_veil_cells(grid, f, stop_crossings, aperture, sensor_radius_mm, out);
    return out;
}

void learn_peak(GhostEstimate& coarse, const GhostEstimate& fine) {
    if (!(fine.peak > 0.0) || fine.sensor.x1 < fine.sensor.x0 || fine.sensor.y1 < fine.sensor.y0) return;
    coarse.peak = fine.peak;
    coarse.edge_peak = std::max(coarse.edge_peak, fine.edge_peak);
    coarse.edge_line = std::max(coarse.edge_line, fine.edge_line);
    coarse.sensor = {std::min(coarse.sensor.x0, fine.sensor.x0), std::min(coarse.sensor.y0, fine.sensor.y0),
                     std::max(coarse.sensor.x1, fine.sensor.x1), std::max(coarse.sensor.y1, fine.sensor.y1)};
}

}  // namespace lensfx::gpu
