// GPU ghost renderer: CPU side (ghost sequences, coating tables, pupil bounds) and the GL passes.
#include <gpu/flare_renderer.h>
#include <gpu/ghost_cap.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cstdint>
#include <cstdio>
#include <future>
#include <map>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <epoxy/gl.h>
#include <fmt/core.h>
#include <optics/coating.h>
#include <optics/ghosts.h>
#include <optics/paraxial.h>
#include <optics/ringing.h>

#include <gpu/acceleration.h>
#include <gpu/coarse_estimate.h>
#include <gpu/draw_plan.h>
#include <gpu/gl.h>
#include <gpu/render_resources.h>

#include <flare/image_ops.h>

#include "flare_shaders.h"

namespace lensfx::gpu {
namespace {

// Texture units: the iris's SDF and ringing (0, 1), then the buffers the shaders read by texel fetches, which
// llvmpipe makes far cheaper than storage-buffer loads (a loop over the lanes, a branch per lane and component): the
// trace's steps and factor tables (UploadedSequences), the traced vertices, the jobs (as integers and as floats),
// the triangle indices and the small triangles' lists (DrawBuffers).
enum TexelUnit : int { kStepUnit = 2, kFactorUnit, kVertexUnit, kJobIntUnit, kJobFloatUnit, kIndexUnit, kSmallUnit };
// What a pass's storage-buffer writes need before the next reads them: as storage buffers and as texel fetches.
constexpr GLbitfield kWrittenForReading = GL_SHADER_STORAGE_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT;
constexpr int kTableSize = 256;        // Fresnel/coating factor samples over cos(incidence) in [0, 1]
constexpr int kPeakGrid = 32;          // cells per side of the finer pass over a ghost the coarse pass found no peak of
// A point-sampled ghost's triangles under kSmallAreaPx pixels of its level, or under kSliverAreaPx pixels and
// thinner than kSliverPx pixels across their longest edge, are small: drawn apart with area coverage
// (shaders::ghost_raster_vert). Measured on CandleGlass.exr (dgauss.50mm, the large ghost's rim against a
// 256-cell grid, and its run time):
// - kSliverPx 2, not 1: at 1 the rim's bright line still stepped where its slivers were rasterised;
// - kSliverAreaPx 16: as smooth as any area (8 broke the line in places, 4 stepped it), for 8% more CPU than
//   point splats rather than 23%. Long slivers also span folds a coarsened (Spiky) ghost's 8-cell grid does not
//   resolve: drawn flat they made lines 4x too bright (StillLife.exr, itoh-zoom, --gain 20: 6 codes against
//   --no-scene-cull); with none small it lacked the sharp ghost's lines (nikon-80-200 at --gain 20: 5 codes).
constexpr double kSmallAreaPx = 1.0;
constexpr double kSliverPx = 2.0;
constexpr double kSliverAreaPx = 16.0;
constexpr std::size_t kVertexBytes = 12 * sizeof(float);  // a traced grid vertex (ghost_trace_comp)
constexpr std::size_t kDrawCommandBytes = 4 * sizeof(GLuint);  // DrawArraysIndirectCommand
constexpr std::size_t kBatchBytes = std::size_t{16} << 20;  // vertices traced before a batch is drawn

struct StepData {
    float geom[4];
    float media[4];
};
static_assert(sizeof(StepData) == 32);  // two RGBA32F texels (view_buffer_texels)

// A ghost of a batched draw: four texels of the jobs' buffer textures (shaders::ghost_job_glsl's job_steps, job_rect,
// job_channels, job_flux).
struct GhostJob {
    std::int32_t steps[4];  // first step, step count, first vertex, stop crossings
    float rect[4];          // entrance-plane rectangle (mm)
    float channels[4];      // what it adds to R, G, B
    float flux[4];          // triangle flux, offset x, offset y (mm), 0
};
static_assert(sizeof(GhostJob) == 64);

// A shader's source with `text` inserted after its #version line.
std::string after_version(const std::string& source, const std::string& text) {
    const std::size_t line_end = source.find('\n', source.find("#version"));
    return source.substr(0, line_end + 1) + text + source.substr(line_end + 1);
}

// A shader's source with the batched draw's job readers declared after its #version line.
std::string with_jobs(const std::string& source) { return after_version(source, shaders::ghost_job_glsl); }

// The work groups of 64 vertices, one after another (grid_vertex), of a grid of res cells a side.
GLuint vertex_groups(int res) {
    const auto side = static_cast<GLuint>(res + 1);
    return (side * side + 63) / 64;
}

// A compute pass's source with the job buffer and the vertex numbering (grid_vertex) declared.
std::string compute_with_jobs(const std::string& source) {
    return after_version(source, std::string{shaders::ghost_job_glsl} + shaders::grid_vertex_glsl);
}

// The grid raster's two stages (shaders::ghost_raster_vert and ghost_raster_frag), point-sampled or, with
// `define` "#define AREA_COVERAGE\n", with area coverage.
std::vector<ShaderStage> raster_stages(const std::string& define) {
    return {{ShaderStage::Type::Vertex,
             after_version(with_jobs(shaders::ghost_grid_glsl), define) + shaders::pixel_coverage_glsl + shaders::ghost_raster_vert},
            {ShaderStage::Type::Fragment, "#version 430\n" + define + shaders::pixel_coverage_glsl + shaders::ghost_raster_frag}};
}

// Every ghost's interface sequence at one wavelength, concatenated: what the trace shader reads.
struct GhostSequences {
    std::vector<StepData> steps;
    std::vector<float> tables;            // kTableSize factors (R or T over cos incidence) per distinct table
    std::vector<int> offset;              // first step of each ghost
    std::vector<int> count;               // steps of each ghost
    std::vector<int> stop_crossings;      // of each ghost
};

}  // namespace

namespace {

// The vertices a pass's batches hold at once: all its ghosts' grids up to a batch's (kBatchBytes), and at
// least its largest ghost's (alone in a batch).
std::size_t vertices_to_draw(const PassPlan& plan) {
    std::size_t total = 0, largest = 0;
    for (const std::vector<std::size_t>* ghosts : {&plan.todo, &plan.batched})
        for (const std::size_t g : *ghosts) {
            const auto side = static_cast<std::size_t>(plan.plans[g].grid + 1);
            total += side * side;
            largest = std::max(largest, side * side);
        }
    return std::max(largest, std::min(total, kBatchBytes / kVertexBytes));
}

// The renderer's shader programs: the trace and shade compute passes and the raster draws (point-sampled, with
// area coverage, or a point-sampled ghost's small triangles with area coverage).
struct GhostPrograms {
    Program trace{"ghost_trace.comp", {{ShaderStage::Type::Compute, compute_with_jobs(shaders::ghost_trace_comp)}}};
    Program shade{"ghost_shade.comp", {{ShaderStage::Type::Compute, compute_with_jobs(shaders::ghost_shade_comp)}}};
    Program raster{"ghost_raster", raster_stages("")};
    Program area{"ghost_raster_area", raster_stages("#define AREA_COVERAGE\n")};
    Program indexed{"ghost_raster_indexed", raster_stages("#define INDEXED\n")};  // no rim pass: a vertex shaded once
    // A faint ghost's (GhostPlan::faint), its cuts taken at pixel centres.
    Program faint{"ghost_raster_faint", raster_stages("#define INDEXED\n#define SHARP_CUTS\n")};
    Program small{"ghost_raster_small", raster_stages("#define AREA_COVERAGE\n#define SMALL_TRIANGLES\n")};
    // An indexed draw's interior triangles (ghost_shade_comp's split_interior), which no cut reaches.
    Program interior{"ghost_raster_interior", raster_stages("#define INDEXED\n#define INTERIOR\n")};
    // Those that draw a ghost's triangles and share its uniforms.
    std::array<const Program*, 6> drawing() const { return {&raster, &area, &indexed, &faint, &small, &interior}; }

    // Each program's buffer textures named by their units, once (those a program lacks are ignored).
    GhostPrograms() {
        for (const Program* program : {&trace, &shade, &raster, &area, &indexed, &faint, &small, &interior})
            for (const auto& [name, unit] : {std::pair{"step_texels", kStepUnit}, {"factor_texels", kFactorUnit},
                                             {"vertex_texels", kVertexUnit}, {"job_ints", kJobIntUnit}, {"job_floats", kJobFloatUnit},
                                             {"index_texels", kIndexUnit}, {"small_texels", kSmallUnit}})
                glProgramUniform1i(program->get(), program->uniform(name), unit);
    }
    // The one that draws a ghost's triangles as planned, in ghost_raster_frag's rim_mode (0: no rim pass).
    const Program& triangles(const GhostPlan& plan, int rim_mode) const {
        return plan.area_coverage ? area : rim_mode != 0 ? raster : plan.faint ? faint : indexed;
    }
    // Whether a program draws a ghost's grid by the triangle indices its shade pass wrote (each vertex shaded
    // once), not each triangle's corners alone.
    bool by_indices(const Program& program) const { return &program == &indexed || &program == &faint; }
};

// The buffer texture a buffer is read through, its texels' format and size, and the buffer's name in an error.
struct TexelView {
    GlObject* texels = nullptr;  // none: the buffer is not read by texel fetches
    unsigned format = 0;
    std::size_t texel_bytes = 4;
    const char* what = "";
};

// The buffers the passes read and write: the vertex array, the traced vertices (grown as passes ask for them,
// never shrunk) and a batched draw's GhostJobs and triangle indices (grown likewise).
struct DrawBuffers {
    GlObject vao = GlObject::vertex_array();
    GlObject vertices = GlObject::buffer();
    GlObject vertex_texels = GlObject::buffer_texture();  // the same buffer, read by texel fetches
    std::size_t vertices_bytes = 0;
    GlObject jobs = GlObject::buffer();
    GlObject job_ints = GlObject::buffer_texture();    // the jobs' steps, read by texel fetches
    GlObject job_floats = GlObject::buffer_texture();  // and their rectangles, channels and flux
    GlObject indices = GlObject::buffer();  // the rasterised triangles (ghost_shade_comp's write_cell_indices)
    GlObject index_texels = GlObject::buffer_texture();
    std::size_t indices_bytes = 0;
    // A batch's small triangles and the commands that draw them (ghost_shade_comp's list_small_triangles)
    GlObject small_list = GlObject::buffer();
    GlObject small_texels = GlObject::buffer_texture();
    std::size_t small_list_bytes = 0;
    GlObject small_commands = GlObject::buffer();
    std::size_t small_commands_bytes = 0;

    // Room for `count` traced vertices: grown (never shrunk) to twice what it held, or more where asked, up
    // to a batch's (kBatchBytes) unless one ghost needs more. A render asks for what its pass draws, so a
    // frame of a few ghosts touches a megabyte or two, not the 16 MB a batch may take (made and cleared at
    // the first render, it was 35 ms of canon-70-200's run on the 1080p stage frame, glFinish timers).
    void reserve_vertices(std::size_t count) {
        const std::size_t bytes = count * kVertexBytes;
        if (bytes <= vertices_bytes) return;
        reserve(vertices, vertices_bytes, std::max(bytes, std::min(2 * vertices_bytes, kBatchBytes)),
                {&vertex_texels, GL_RGBA32F, 16, "the traced vertices"});
    }
    // The vertices bound for the passes: written as a storage buffer, read as a buffer texture.
    void bind_vertices() const {
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, vertices.get());
        glBindTextureUnit(kVertexUnit, vertex_texels.get());
    }
    void reserve_indices(std::size_t bytes) { reserve(indices, indices_bytes, bytes, {&index_texels, GL_R32UI, 4, "the triangle indices"}); }
    void reserve_small(std::size_t slots, std::size_t commands) {
        reserve(small_list, small_list_bytes, slots * sizeof(GLuint), {&small_texels, GL_R32UI, 4, "the small triangles' lists"});
        reserve(small_commands, small_commands_bytes, commands * kDrawCommandBytes);
    }
    // The jobs given their data, and their texel views checked against the GL's limit for this size (a view
    // follows its buffer's data store when that is specified again).
    void upload_jobs(const void* data, std::size_t bytes) {
        glNamedBufferData(jobs.get(), static_cast<GLsizeiptr>(bytes), data, GL_STREAM_DRAW);
        view_buffer_texels(job_ints, GL_RGBA32I, jobs, bytes / 16, "the faint ghosts' jobs");
        view_buffer_texels(job_floats, GL_RGBA32F, jobs, bytes / 16, "the faint ghosts' jobs");
        glBindTextureUnit(kJobIntUnit, job_ints.get());
        glBindTextureUnit(kJobFloatUnit, job_floats.get());
    }
    // The triangle indices and small triangles' lists bound for the passes: written as storage buffers, read by
    // the draws as buffer textures.
    void bind_lists() const {
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, indices.get());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, small_list.get());
        glBindTextureUnit(kIndexUnit, index_texels.get());
        glBindTextureUnit(kSmallUnit, small_texels.get());
    }

private:
    // `buffer` made anew with `bytes` where it holds less (its contents are not kept), with its view: nothing is
    // changed where the view would pass the GL's limit (view_buffer_texels throws first).
    static void reserve(GlObject& buffer, std::size_t& held, std::size_t bytes, const TexelView& view = {}) {
        bytes = std::max<std::size_t>(bytes, 1);
        if (bytes <= held) return;
        GlObject made = GlObject::buffer();
        glNamedBufferStorage(made.get(), static_cast<GLsizeiptr>(bytes), nullptr, 0);
        if (view.texels) view_buffer_texels(*view.texels, view.format, made, bytes / view.texel_bytes, view.what);
        buffer = std::move(made);
        held = bytes;
    }
};

// Where a batch's ghost lists its small triangles (ghost_shade_comp's list_small_triangles): 128 slots and one
// draw command per work group of its shade dispatch, from these on.
struct SmallList {
    std::size_t first_slot = 0;
    std::size_t first_command = 0;
    GLuint groups = 0;  // 0: the ghost draws none apart
};

// A batch's SmallList per job (those of ghosts drawn point-sampled with their small triangles apart, one after
// another) and the slots and commands they take together.
struct SmallLists {
    std::vector<SmallList> jobs;
    std::size_t slots = 0, commands = 0;
};
SmallLists small_lists(const std::vector<BatchJob>& batch, const std::vector<GhostPlan>& plans) {
    SmallLists out;
    out.jobs.resize(batch.size());
    for (std::size_t j = 0; j < batch.size(); ++j) {
        const GhostPlan& plan = plans[batch[j].ghost];
        if (!plan.small_apart || plan.area_coverage) continue;
        out.jobs[j] = {out.slots, out.commands, vertex_groups(plan.grid)};
        out.slots += 128 * std::size_t{out.jobs[j].groups};
        out.commands += out.jobs[j].groups;
    }
    return out;
}


// A pass's ghost sequences on the CPU and in the GL buffers the trace shader reads.
struct UploadedSequences {
    GhostSequences seq;
    GlObject steps;
    GlObject tables;
    GlObject step_texels;
    GlObject factor_texels;
};

// What the renderer learns of a lens and keeps between renders: the ghost sequences per ghost selection and
// wavelength, and the bounds tables (loaded from or saved to the cache folder).
struct LensCaches {
    std::map<std::pair<std::uint64_t, double>, UploadedSequences> sequences;  // per system/ghosts key and wavelength
    std::map<std::uint64_t, BoundsTable> bounds_tables;                         // in memory, per key
    // A table's estimates at a light's field angle, its unknown peaks traced again (find_unknown_peaks_at): per
    // table key, pass and angle, so an extended light's footprint groups and a still light's next frames, drawn at
    // the same angle, trace them once (canon-70-200 on the 1080p stage frame: 54 such passes a frame, 6 distinct).
    std::map<std::tuple<std::uint64_t, std::size_t, double>, std::vector<GhostEstimate>> table_estimates;
};

// What the renderer tells of its renders: the last render's figures, and whether the user was told that the
// memory budget left ghosts out.
struct RenderReport {
    RenderStats stats;
    bool fit_warned = false;
};

}  // namespace

// What a FlareRenderer keeps between renders, in parts of one job each.
struct FlareRenderer::State {
    GhostPrograms programs;
    DrawBuffers buffers;
    IrisTextures iris;
    LensCaches caches;
    RenderTargets targets;
    RenderReport report;
};

FlareRenderer::FlareRenderer(const Context& context) {
    context.make_current();
    state_ = std::make_unique<State>();
}

FlareRenderer::~FlareRenderer() = default;

namespace {

// The steps of all ghosts together: a ghost reflecting at j, then at i < j, visits n + 2 (j - i) interfaces.
double ghost_steps(const System& system) {
    const std::vector<int> reflecting = optics::reflecting_interfaces(system);
    const double n = static_cast<double>(system.interfaces.size());
    double steps = 0.0;
    for (std::size_t a = 0; a < reflecting.size(); ++a)
        for (std::size_t b = a + 1; b < reflecting.size(); ++b) steps += n + 2.0 * (reflecting[b] - reflecting[a]);
    return steps;
}

// A surface's coating factors from one side, R and T together (one coated_reflectance gives both), at
// kTableSize cosines of incidence over [0, 1]: its reflect and transmit tables for that side.
using SideSamples = std::vector<optics::Reflectance>;

// The sides of the surfaces (interface, forward) the ghosts cross, in the order they are first met; the
// stop (no coating) left out.
std::vector<std::pair<int, bool>> crossed_sides(const TraceSystem& traced, const std::vector<Ghost>& ghosts) {
    std::vector<std::pair<int, bool>> out;
    std::vector<char> seen(2 * traced.interfaces().size(), 0);
    for (const Ghost& ghost : ghosts)
        for (const optics::Step& step : ghost.path) {
            if (traced.interfaces()[static_cast<std::size_t>(step.interface)].is_stop) continue;
            char& s = seen[2 * static_cast<std::size_t>(step.interface) + (step.forward ? 1 : 0)];
            if (!s) out.emplace_back(step.interface, step.forward);
            s = 1;
        }
    return out;
}

SideSamples side_samples(const TraceSystem& traced, std::pair<int, bool> side) {
    const optics::TraceInterface& surface = traced.interfaces()[static_cast<std::size_t>(side.first)];
    const double n_in = side.second ? surface.n_before : surface.n_after;
    const double n_out = side.second ? surface.n_after : surface.n_before;
    SideSamples out(kTableSize);
    for (int i = 0; i < kTableSize; ++i) {
        const double cos_i = static_cast<double>(i) / (kTableSize - 1);
        out[static_cast<std::size_t>(i)] = optics::coated_reflectance(surface.coating, n_in, n_out, cos_i, traced.wavelength_nm(), side.second);
    }
    return out;
}

// Every crossed side sampled (side_samples), the second half on a worker thread: the complex thin-film sums
// are a first render's largest CPU cost before drawing (canon-70-200: 65 sides a pass, some 11 ms of CPU each).
std::map<std::pair<int, bool>, SideSamples> sampled_sides(const TraceSystem& traced, const std::vector<Ghost>& ghosts) {
    const std::vector<std::pair<int, bool>> sides = crossed_sides(traced, ghosts);
    std::vector<SideSamples> samples(sides.size());
    const std::size_t half = sides.size() / 2;
    auto sample = [&](std::size_t first, std::size_t end) {
        for (std::size_t k = first; k < end; ++k) samples[k] = side_samples(traced, sides[k]);
    };
    std::future<void> second = std::async(std::launch::async, sample, half, sides.size());
    sample(0, half);
    second.get();
    std::map<std::pair<int, bool>, SideSamples> out;
    for (std::size_t k = 0; k < sides.size(); ++k) out.emplace(sides[k], std::move(samples[k]));
    return out;
}

GhostSequences build_sequences(const TraceSystem& traced, const std::vector<Ghost>& ghosts) {
    GhostSequences out;
    const std::map<std::pair<int, bool>, SideSamples> sampled = sampled_sides(traced, ghosts);
    // Ghosts share their surfaces: each (interface, direction, reflect or transmit) table is stored once, and a
    // step names its table in media.z (kind + 4 x table): a lens of many surfaces has millions of steps but a
    // few hundred tables.
    std::map<std::tuple<int, bool, bool>, std::size_t> computed;  // -> its index in out.tables
    auto table_of = [&](const optics::Step& step, const optics::TraceInterface& surface) {
        const auto key = surface.is_stop ? std::make_tuple(-1, true, false) : std::make_tuple(step.interface, step.forward, step.reflect);
        if (const auto it = computed.find(key); it != computed.end()) return it->second;
        const std::size_t index = out.tables.size() / kTableSize;
        computed.emplace(key, index);
        if (surface.is_stop) {
            out.tables.insert(out.tables.end(), kTableSize, 1.0f);
            return index;
        }
        for (const optics::Reflectance& rt : sampled.at({step.interface, step.forward}))
            out.tables.push_back(static_cast<float>(step.reflect ? rt.R : rt.T));
        return index;
    };
    for (const Ghost& ghost : ghosts) {
        out.offset.push_back(static_cast<int>(out.steps.size()));
        out.count.push_back(static_cast<int>(ghost.path.size()));
        int crossings = 0;
        for (const optics::Step& step : ghost.path) {
            const optics::TraceInterface& surface = traced.interfaces()[static_cast<std::size_t>(step.interface)];
            const double n_in = step.forward ? surface.n_before : surface.n_after;
            const double n_out = step.forward ? surface.n_after : surface.n_before;
            const int kind = surface.is_stop ? 2 : (step.reflect ? 1 : 0);
            crossings += kind == 2;
            const std::size_t table = table_of(step, surface);
            out.steps.push_back({{static_cast<float>(surface.z), static_cast<float>(surface.curvature),
                                  static_cast<float>(surface.conic), static_cast<float>(surface.semi_diameter)},
                                 {static_cast<float>(n_in), static_cast<float>(n_out), static_cast<float>(kind + 4 * table),
                                  step.forward ? 1.0f : 0.0f}});
        }
        out.stop_crossings.push_back(crossings);
    }
    return out;
}

// The columns [first, end) of an RGBA row of w texels that hold anything but zeros (any bit set: -0 and NaN
// count); {0, 0} when none do. A render target is cleared to zeros and drawn into by adding, so what a draw
// left untouched is exactly zero.
std::pair<int, int> lit_span(const float* rgba, int w) {
    const std::size_t n = static_cast<std::size_t>(w) * 4;
    std::uint32_t any = 0;
    for (std::size_t i = 0; i < n; ++i) any |= std::bit_cast<std::uint32_t>(rgba[i]);  // vectorised
    if (any == 0) return {0, 0};
    std::size_t first = 0, last = n - 1;
    while (std::bit_cast<std::uint32_t>(rgba[first]) == 0) ++first;
    while (std::bit_cast<std::uint32_t>(rgba[last]) == 0) --last;
    return {static_cast<int>(first / 4), static_cast<int>(last / 4) + 1};
}

// Grows `lit` by the lit columns of GL row `row` of its target.
void add_lit_row(TexelRect& lit, int row, std::pair<int, int> span) {
    if (span.first == span.second) return;
    if (lit.empty()) lit = {span.first, row, span.second, row + 1};
    lit.x0 = std::min(lit.x0, span.first), lit.x1 = std::max(lit.x1, span.second);
    lit.y0 = std::min(lit.y0, row), lit.y1 = std::max(lit.y1, row + 1);
}

constexpr int kBandRows = 64;  // rows of a target read back at a time

// Where a target holds anything but zeros: read back a band of rows at a time; empty when nowhere.
TexelRect lit_rect(const FloatTarget& target) {
    const int w = target.width(), h = target.height();
    std::vector<float> band(static_cast<std::size_t>(w) * static_cast<std::size_t>(std::min(kBandRows, h)) * 4);
    TexelRect lit;
    for (int first = 0; first < h; first += kBandRows) {
        const int rows = std::min(kBandRows, h - first);
        target.read_rgba_rows(first, rows, band.data());
        for (int r = 0; r < rows; ++r) add_lit_row(lit, first + r, lit_span(band.data() + static_cast<std::size_t>(r) * static_cast<std::size_t>(w) * 4, w));
    }
    return lit;
}

// A render target read back a band of rows at a time (RGBA, rows bottom to top as GL stores them), within
// `window` only: what lies outside it reads as zeros (where a read-back found it zero, lit_rect). Rows are asked
// for from the top of the image down, so a band is read ending just above the row asked for.
class BandReader {
public:
    BandReader(const FloatTarget& target, const TexelRect& window) : target_(&target), window_(window) {}
    int width() const { return target_->width(); }
    int height() const { return target_->height(); }
    const TexelRect& window() const { return window_; }
    // Bytes the whole window takes read at once (read_all).
    std::size_t window_bytes() const {
        return static_cast<std::size_t>(width()) * 4 * sizeof(float) * static_cast<std::size_t>(window_.y1 - window_.y0);
    }
    // The whole window read at once: row() then reads nothing more and changes nothing, so threads may share
    // the reader (add_targets' rows split over two).
    void read_all() {
        const auto w4 = static_cast<std::size_t>(width()) * 4;
        zeros_.assign(w4, 0.0f);
        first_ = window_.y0;
        rows_ = window_.y1 - window_.y0;
        band_.assign(w4 * static_cast<std::size_t>(rows_), 0.0f);  // the columns beyond the window stay zero
        target_->read_rgba_rect(window_, band_.data());
    }
    const float* row(int r) {
        const auto w4 = static_cast<std::size_t>(width()) * 4;
        if (r < window_.y0 || r >= window_.y1) {
            if (zeros_.empty()) zeros_.assign(w4, 0.0f);
            return zeros_.data();
        }
        if (r < first_ || r >= first_ + rows_) {
            first_ = std::max(window_.y0, r + 2 - kBandRows);
            rows_ = std::min(kBandRows, window_.y1 - first_);
            // made once: the columns beyond the window are never read into, and stay zero
            if (band_.empty()) band_.assign(w4 * static_cast<std::size_t>(std::min(kBandRows, window_.y1 - window_.y0)), 0.0f);
            target_->read_rgba_rect({window_.x0, first_, window_.x1, first_ + rows_}, band_.data());
        }
        return band_.data() + static_cast<std::size_t>(r - first_) * w4;
    }

private:
    const FloatTarget* target_;
    TexelRect window_;
    std::vector<float> band_, zeros_;
    int first_ = 0, rows_ = 0;
};

// Adds band b of the full-size target into the top-down RGB image w pixels wide, read back a band of rows
// at a time (no copy of the whole target is made), only the lit columns of each row. Returns where the target
// is lit (GL rows, all columns), which is all of it that was read when the image is one band.
TexelRect add_full_band(const FloatTarget& target, std::vector<float>& rgb, int w, const FullBands& bands, int b) {
    BandReader reader(target, {0, 0, target.width(), target.height()});
    const int top = bands.drawn_first(b), rows = bands.rows_drawn(b);
    TexelRect lit;
    for (int y = bands.first(b); y < bands.end(b); ++y) {
        const int row = rows - 1 - (y - top);  // GL rows run bottom-up
        const float* in = reader.row(row);
        const auto [x0, x1] = lit_span(in, w);
        add_lit_row(lit, row, {x0, x1});
        float* out = rgb.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w) * 3;
        for (auto x = static_cast<std::size_t>(x0); x < static_cast<std::size_t>(x1); ++x)
            for (std::size_t c = 0; c < 3; ++c) out[x * 3 + c] += in[x * 4 + c];
    }
    if (!lit.empty()) lit.x0 = 0, lit.x1 = target.width();
    return lit;
}

// The span [first, end) of the image's rows or columns whose Mitchell taps reach [lo, hi) of a target's: the
// others blend only zeros there.
std::pair<int, int> reached(const std::vector<flare::CubicTap>& taps, int lo, int hi) {
    int first = static_cast<int>(taps.size()), end = 0;
    for (std::size_t k = 0; k < taps.size(); ++k)
        for (const int i : taps[k].i)
            if (i >= lo && i < hi) first = std::min(first, static_cast<int>(k)), end = std::max(end, static_cast<int>(k) + 1);
    return {first, end};
}

// A reduced target's rows widened to the image's w columns through the Mitchell cubic (flare::mitchell_taps),
// four held at a time: an output row blends four of them, and the next output row mostly needs the same four.
// Only the columns whose taps reach the target's lit window are widened (the rest would be zero).
class WidenedTarget {
public:
    WidenedTarget(BandReader& readback, int w, int h)
        : readback_(&readback), xs_(flare::mitchell_taps(w, readback.width())), ys_(flare::mitchell_taps(h, readback.height())) {
        for (auto& row : rows_) row.assign(static_cast<std::size_t>(w) * 3, 0.0f);
        const TexelRect& lit = readback.window();
        columns_ = reached(xs_, lit.x0, lit.x1);
        const auto [r0, r1] = reached(ys_, lit.y0, lit.y1);  // ys_ runs bottom-up, as GL rows
        rows_reached_ = {h - r1, h - r0};
    }
    // The taps of image row y (from the top; GL rows run bottom-up).
    const flare::CubicTap& taps_of(int y) const { return ys_[ys_.size() - 1 - static_cast<std::size_t>(y)]; }
    // The image's columns and rows (top down) this target adds to: [first, end).
    std::pair<int, int> columns() const { return columns_; }
    bool reaches_row(int y) const { return y >= rows_reached_.first && y < rows_reached_.second; }
    // Target row `row` widened; a row `needed` names is not evicted for it.
    const float* row(int row, const flare::CubicTap& needed) {
        for (int k = 0; k < 4; ++k)
            if (held_[k] == row) return rows_[k].data();
        int k = 0;
        for (; k < 4; ++k) {
            const int r = held_[k];
            if (r != needed.i[0] && r != needed.i[1] && r != needed.i[2] && r != needed.i[3]) break;
        }
        const float* in = readback_->row(row);
        float* out = rows_[k].data();
        for (auto x = static_cast<std::size_t>(columns_.first); x < static_cast<std::size_t>(columns_.second); ++x) {
            const flare::CubicTap& t = xs_[x];
            for (std::size_t c = 0; c < 3; ++c) {
                float v = 0.0f;
                for (int j = 0; j < 4; ++j) v += t.f[j] * in[static_cast<std::size_t>(t.i[j]) * 4 + c];
                out[x * 3 + c] = v;
            }
        }
        held_[k] = row;
        return out;
    }

private:
    BandReader* readback_;
    std::vector<flare::CubicTap> xs_, ys_;
    std::pair<int, int> columns_, rows_reached_;
    std::vector<float> rows_[4];
    int held_[4] = {-1, -1, -1, -1};
};

// out[i] += max(0, blend of rows a[0..N) by weights f) over [first, end): the blend summed in the order given,
// from zero, exactly as adding each weighted row into a zeroed row would.
template <int N>
void blend_rows(const float* const (&a)[4], const float (&f)[4], float* out, std::size_t first, std::size_t end) {
    for (std::size_t i = first; i < end; ++i) {
        float v = 0.0f;
        for (int k = 0; k < N; ++k) v += f[k] * a[k][i];
        out[i] += std::max(0.0f, v);
    }
}

// Rows [y0, y1) of add_targets' image, each target widened through four rows of its own held here.
void add_target_rows(std::vector<BandReader>& sources, std::vector<float>& rgb, int w, int h, int y0, int y1) {
    std::vector<WidenedTarget> srcs;
    for (BandReader& r : sources) srcs.emplace_back(r, w, h);
    const std::size_t row_values = static_cast<std::size_t>(w) * 3;
    for (int y = y0; y < y1; ++y) {
        float* out = rgb.data() + static_cast<std::size_t>(y) * row_values;
        for (WidenedTarget& src : srcs) {
            if (!src.reaches_row(y)) continue;
            const flare::CubicTap& t = src.taps_of(y);
            const std::size_t first = static_cast<std::size_t>(src.columns().first) * 3, end = static_cast<std::size_t>(src.columns().second) * 3;
            // The four rows' blend, summed from the last tap to the first and skipping zero weights, in one pass.
            const float* a[4];
            float f[4];
            int n = 0;
            for (int j = 3; j >= 0; --j)
                if (t.f[j] != 0.0f) a[n] = src.row(t.i[j], t), f[n++] = t.f[j];
            switch (n) {
                case 4: blend_rows<4>(a, f, out, first, end); break;
                case 3: blend_rows<3>(a, f, out, first, end); break;
                case 2: blend_rows<2>(a, f, out, first, end); break;
                case 1: blend_rows<1>(a, f, out, first, end); break;
                default: blend_rows<0>(a, f, out, first, end); break;
            }
        }
    }
}

// Reduced targets whose lit windows take at most this are read whole and widened on two threads (the 1/2 target
// of a 1080p frame: 8 MB; GpuFlareOptions::split_read_back); larger ones (4K and up) a band at a time on this thread.
constexpr std::size_t kWholeReadBytes = std::size_t{16} << 20;
constexpr int kSplitRows = 128;  // images with fewer rows are not split

// Adds reduced targets (read back in bands) into a top-down RGB image of w x h, enlarged with the Mitchell
// cubic (flare::mitchell_taps: pixel centres aligned, edge pixels repeated beyond the border; what each target
// adds is clamped at 0, so the lobes never darken the plate). Cooke-triplet at (14, 9), 960x640 (bench_flare):
// structure error 0.732, against bilinear's 0.741, Catmull-Rom's 0.733 and the cubic B-spline's 0.771; render
// time the same within noise. Separably, and every target per output row, so the image is read and written
// once: each output row adds, for every target, a blend of four widened rows (a loop the compiler vectorises).
// Only the part of the image each target's lit window reaches is visited: an extended light's groups light a
// few ghosts each. Not flare::add_resized: the targets are read from GL in bands, whole only when small (the 1/2
// target of an 8K frame is 127 MB). Small ones (kWholeReadBytes) are widened on two threads, half the rows each:
// every output row takes each target's blend in the targets' order whichever thread adds it, so the image is
// the same split or not; the GL is read on this thread only (read_all, before the split).
void add_targets(std::vector<BandReader>& sources, std::vector<float>& rgb, int w, int h, bool split) {
    std::size_t bytes = 0;
    for (const BandReader& r : sources) bytes += r.window_bytes();
    if (!split || sources.empty() || bytes > kWholeReadBytes || h < kSplitRows) return add_target_rows(sources, rgb, w, h, 0, h);
    for (BandReader& r : sources) r.read_all();
    flare::split_rows(0, h, kSplitRows, [&](int y0, int y1) { add_target_rows(sources, rgb, w, h, y0, y1); });
}

// One light's pass being drawn: what the trace and raster steps of its batches read.
struct PassDraw {
    const ScaledLight& light;
    const SpectralPass& pass;
    const GhostSequences& seq;
    const std::vector<GhostEstimate>& estimates;
    const std::vector<GhostPlan>& plans;
    double rotation;            // of the ghosts' entrance rectangles (the light's azimuth with a bounds table)
    optics::Vec3 direction;     // of the light
    double cos_angle;
    const std::vector<std::array<double, 3>>* weights = nullptr;  // per ghost, else the pass's (merge_faint_passes)
};

// What one ghost's draw sets besides the level's values: its flux per grid triangle, what it adds to R, G, B,
// its shift (mm, with a band's) and the half height of what the target spans (mm), and the target's pixels.
struct GhostDrawValues {
    double triangle_flux = 0.0;
    std::array<double, 3> channels{};
    std::array<double, 2> offset{};
    double half_height = 0.0;
    int target_w = 0, target_h = 0;
};

}  // namespace

// The finest level (1, 2 ... 16) whose targets the GL holds for a frame of width x height: at full size only the width
// counts (the full-size target is drawn in bands of rows), reduced both. Throws when not even 1/16 fits.
int level_that_fits(int width, int height) {
    GLint max_size = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
    for (int level = 1; level <= 16; level *= 2) {
        const bool fits = flare::reduced_side(width, level) <= max_size && (level == 1 || flare::reduced_side(height, level) <= max_size);
        if (fits) return level;
    }
    throw std::invalid_argument(fmt::format("a {}x{} frame: not even its 1/16 fits the GL's largest texture ({} px)", width, height, max_size));
}

// One FlareRenderer::draw as named steps over what they share (the fitted ghosts and their selection, the
// passes and their traced systems, the full-size bands): set up, estimate the lights, cull against the
// scene, then per band, light and pass plan the ghosts and trace and raster them batch by batch; read back.
class FlareRenderer::Drawing {
public:
    Drawing(State& state, const System& system, const FlareView& view, std::span<const ScaledLight> lights,
            const GpuFlareOptions& options, std::vector<Ghost> ghosts);
    // Every light's ghost estimates (bounds table or coarse pass), then the level of detail's totals.
    void estimate_lights();
    // Scene culling's verdicts for every light's ghosts at once (options.visibility).
    void cull_scene();
    // Band `band` of the full-size target (and in band 0 every reduced target): every light's passes.
    void draw_band(int band, std::vector<float>& rgb);
    // The reduced targets upsampled into rgb (at 1/image_level of the view), or the per-ghost sums and powers.
    void read_back(std::vector<float>& rgb, std::vector<GhostPower>* ghost_powers);
    // The bounds tables this render added entries to, saved to the cache once it has drawn without error; after
    // an error, forgotten (kept neither in memory nor on disk): a render the GL driver failed in (out of memory)
    // may have traced nothing or garbage, and a saved table would hand that to every later run.
    void save_tables();
    void forget_unsaved_tables();
    // Every ghost drawn at 1/level of the view or coarser, and read back into an image of that size.
    void set_image_level(int level) { image_level_ = level; }
    int bands() const { return bands_.count; }
    // The trace step alone on ghost g at the first pass (for tests): the batch's vertices read back.
    std::vector<float> trace_alone(std::pair<int, int> ghost, int grid, const PupilRect& rect, std::vector<std::uint32_t>* indices);
    // Every pass's sequences built and every program used once (FlareRenderer::prepare), for the first light.
    void warm_up();

private:
    State& s_;
    const System& system_;
    const FlareView& view_;
    std::span<const ScaledLight> lights_;
    const GpuFlareOptions& options_;
    std::vector<Ghost> ghosts_;
    GhostSelection selection_;
    std::vector<SpectralPass> passes_;
    std::vector<TraceSystem> traced_;  // per pass
    std::uint64_t key_;                // of the system and ghosts (sequences, bounds table)
    double sensor_radius_;             // rays landing farther from the centre miss the image (5% margin)
    double f_number_;                  // for the iris ringing's order (0 without ringing)
    FullBands bands_;
    int band_ = 0;
    bool drawn_into_[RenderTargets::kSlots] = {};  // targets drawn into (and cleared) by this render
    std::vector<GhostPower> powers_;
    std::vector<double> accumulated_;  // per-ghost mode: the image summed on the CPU
    std::vector<LightEstimates> estimates_;  // per light
    std::vector<double> pass_total_;
    std::vector<std::uint64_t> unsaved_tables_;  // keys of the bounds tables this render added entries to
    LightVerdicts verdicts_;                 // per light, pass, ghost; empty: no scene culling
    std::vector<SmallList> small_lists_;     // the batch being drawn's, per job
    int image_level_ = 1;                    // read back at 1/image_level_ of the view, no ghost drawn finer
    // No ghost drawn finer than this: 1, or for a frame wider than the GL's largest texture (a panorama past 16384 px
    // on llvmpipe) the first level whose targets it holds (the full-size target's bands split rows, not columns).
    int fit_level_ = 1;

    void set_up_gl();
    FloatTarget& full_target() { return s_.targets.full(view_.width, bands_.target_rows()); }
    void bind_full();
    void bind_level(int reduce);
    double level_pixel_area(int reduce) const;
    std::array<int, 2> level_size(int reduce) const;
    std::array<double, 2> level_pixels_per_mm(int reduce) const;
    bool interior_apart(const GhostPlan& plan) const { return options_.split_interior && splits_interior(plan); }
    UploadedSequences& sequences(std::size_t p);
    void dispatch_trace(int res, const PupilRect& rect, double rotation, const optics::Vec3& direction, int first_step,
                        int step_count, std::size_t vertex_offset);
    void dispatch_shade(const GhostPlan& plan, const BatchJob& job, const SmallList& small, int stop_crossings);
    void trace_uniforms(int res, double rotation, const optics::Vec3& direction);
    void shade_uniforms(int res, int reduce, bool area_coverage, bool small_apart);
    void split_interior_uniforms(bool split, std::size_t offset, int reduce);
    void dispatch_batched(const Program& program, const FaintRun& run);
    void raster_faint(const FaintRun& run, const PassDraw& pd);
    std::vector<GhostEstimate> coarse_pass(std::size_t p, const GhostSequences& seq, const FlareView& at, const Aperture& aperture);
    void find_unknown_peaks(std::vector<GhostEstimate>& coarse, const GhostSequences& seq, const optics::Vec3& direction,
                            const Aperture& aperture);
    void find_unknown_peaks_at(std::vector<GhostEstimate>& estimates, const GhostSequences& seq, const FlareView& lit, double theta_deg);
    std::vector<GhostEstimate> table_estimates(const BoundsTable& table, std::size_t p, const GhostSequences& seq, const FlareView& lit,
                                               double theta_deg);
    BoundsTable& bounds_table(const FlareView& lit, const FieldDirection& field);
    LightEstimates estimate_light(const ScaledLight& light);
    PassPlan pass_plan(std::size_t l, std::size_t p) const;
    void draw_light(std::size_t l);
    void draw_pass(std::size_t l, std::size_t p, const PassPlan& plan, const std::vector<std::array<double, 3>>* faint_weights);
    void trace_batch(const std::vector<BatchJob>& batch, const PassDraw& pd);
    void raster_batch(const std::vector<BatchJob>& batch, const PassDraw& pd);
    void draw_triangles(const BatchJob& job, const PassDraw& pd, int reduce, int rim_mode);
    void draw_small_triangles(const SmallList& small);
    GhostDrawValues draw_values(std::size_t g, const PassDraw& pd, int target_reduce) const;
    const Program& ghost_uniforms(const BatchJob& job, const PassDraw& pd, int reduce, int rim_mode);
    void draw_batched(const std::vector<std::size_t>& ghosts, const PassDraw& pd);
    void draw_faint_chunk(const std::vector<FaintRun>& runs, const PassDraw& pd);
    void upload_jobs(const std::vector<FaintRun>& runs, const PassDraw& pd);
    void add_ghost_power(std::size_t g);
};

FlareRenderer::Drawing::Drawing(State& state, const System& system, const FlareView& view, std::span<const ScaledLight> lights,
                                const GpuFlareOptions& options, std::vector<Ghost> ghosts)
    : s_(state), system_(system), view_(view), lights_(lights), options_(options), ghosts_(std::move(ghosts)),
      selection_(GhostSelection::of(ghosts_, options.draw_only, options.styles)), passes_(view.passes()),
      key_(ghosts_key(system, ghosts_)), sensor_radius_(0.525 * std::hypot(view.sensor_width_mm, view.sensor_height_mm)),
      f_number_(options.ringing ? optics::paraxial(system).f_number : 0.0),
      bands_(full_target_bands(view.width, view.height, options.full_target_bytes, options.per_ghost_power)) {
    // The full-size target is made when a ghost is drawn at full size (always per ghost): at 8K it would be
    // 1 GB, so a large frame's is drawn in bands (each band's viewport the rows it draws), and a frame whose
    // ghosts are all drawn reduced never needs it.
    if (options.per_ghost_power) {
        bind_full();
        s_.targets.clear(0);
        drawn_into_[0] = true;
    }
    for (const auto& pass : passes_) {
        traced_.emplace_back(system, pass.wavelength_nm);
        for (std::size_t k = 0; k < traced_.back().interfaces().size(); ++k) {
            if (traced_.back().interfaces()[k].has_aspheric) {
                throw std::runtime_error(fmt::format(
                    "{}: surface {} is aspheric; the GPU ghost renderer traces spheres and conics only",
                    system.name, k + 1));
            }
        }
    }
    set_up_gl();
    powers_.resize(ghosts_.size());
    for (std::size_t g = 0; g < ghosts_.size(); ++g) powers_[g] = {ghosts_[g].first, ghosts_[g].second, {}};
    if (options.per_ghost_power) accumulated_.assign(static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height) * 3, 0.0);
}

// The vertex array, the blend state and the iris texture (the vertex buffer grows with each pass: draw_pass).
void FlareRenderer::Drawing::set_up_gl() {
    glBindVertexArray(s_.buffers.vao.get());
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE);
    glBindTextureUnit(0, s_.iris.sdf(system_.aperture));
    glEnable(GL_PROGRAM_POINT_SIZE);
}

void FlareRenderer::Drawing::bind_full() {
    full_target().bind();
    glViewport(0, 0, view_.width, bands_.rows_drawn(band_));
}

// Draws go into the target at 1/reduce of the image from here on, cleared if this render has not drawn into it yet.
void FlareRenderer::Drawing::bind_level(int reduce) {
    const std::size_t slot = RenderTargets::slot(reduce);
    FloatTarget& t = reduce == 1 ? full_target() : s_.targets.reduced(reduce, view_.width, view_.height);
    if (reduce == 1) bind_full();  // the full-size target holds the band being drawn
    else t.bind();
    if (!drawn_into_[slot]) s_.targets.clear(slot);
    drawn_into_[slot] = true;
}

// The pixels across and down of the target at 1/reduce of the image (rounded up).
std::array<int, 2> FlareRenderer::Drawing::level_size(int reduce) const {
    return {(view_.width + reduce - 1) / reduce, (view_.height + reduce - 1) / reduce};
}

// Pixels per mm of the sensor, across and down, at 1/reduce of the image.
std::array<double, 2> FlareRenderer::Drawing::level_pixels_per_mm(int reduce) const {
    const auto [level_w, level_h] = level_size(reduce);
    return {level_w / view_.sensor_width_mm, level_h / view_.sensor_height_mm};
}

// A pixel's sensor area (mm^2) at 1/reduce of the image, by which a ghost's triangles are sorted into
// rasterised and small (kSmallAreaPx, kSliverPx).
double FlareRenderer::Drawing::level_pixel_area(int reduce) const {
    const auto [level_w, level_h] = level_size(reduce);
    return (view_.sensor_width_mm / level_w) * (view_.sensor_height_mm / level_h);
}

// Ghost sequences and coating tables of pass p, built once per system, ghost selection and wavelength, bound
// for the trace shader.
UploadedSequences& FlareRenderer::Drawing::sequences(std::size_t p) {
    const std::pair<std::uint64_t, double> id{key_, passes_[p].wavelength_nm};
    auto it = s_.caches.sequences.find(id);
    if (it == s_.caches.sequences.end()) {
        if (s_.caches.sequences.size() >= 96) s_.caches.sequences.clear();  // room for an extended light's ghost groups
        UploadedSequences built{build_sequences(traced_[p], ghosts_), GlObject::buffer(), GlObject::buffer(),
                                GlObject::buffer_texture(), GlObject::buffer_texture()};
        glNamedBufferStorage(built.steps.get(), static_cast<GLsizeiptr>(built.seq.steps.size() * sizeof(StepData)),
                             built.seq.steps.data(), 0);
        glNamedBufferStorage(built.tables.get(), static_cast<GLsizeiptr>(built.seq.tables.size() * sizeof(float)),
                             built.seq.tables.data(), 0);
        view_buffer_texels(built.step_texels, GL_RGBA32F, built.steps, 2 * built.seq.steps.size(), "the ghosts' steps");
        view_buffer_texels(built.factor_texels, GL_R32F, built.tables, built.seq.tables.size(), "the coating tables");
        it = s_.caches.sequences.emplace(id, std::move(built)).first;
    }
    glBindTextureUnit(kStepUnit, it->second.step_texels.get());
    glBindTextureUnit(kFactorUnit, it->second.factor_texels.get());
    glUseProgram(s_.programs.trace.get());
    glUniform1f(s_.programs.trace.uniform("sensor_z"), static_cast<float>(traced_[p].sensor_z()));
    return it->second;
}

// The trace program bound with what every dispatch over a (res+1)^2 grid sets: the grid, the entrance
// rectangles' rotation and the light's direction.
void FlareRenderer::Drawing::trace_uniforms(int res, double rotation, const optics::Vec3& direction) {
    const Program& trace = s_.programs.trace;
    glUseProgram(trace.get());
    glUniform1i(trace.uniform("grid"), res);
    glUniform2f(trace.uniform("rect_rotation"), static_cast<float>(std::cos(rotation)), static_cast<float>(std::sin(rotation)));
    glUniform3f(trace.uniform("direction"), static_cast<float>(direction.x), static_cast<float>(direction.y), static_cast<float>(direction.z));
    glUniform1i(trace.uniform("table_size"), kTableSize);
}

// The shade program bound with what every dispatch over a (res+1)^2 grid drawn at 1/reduce of the image sets:
// the grid, which triangles are small at the level's pixels (none with area coverage: every triangle is drawn;
// slivers only where small triangles are drawn apart, `small_apart`: a faint ghost loses what is small), and the iris.
void FlareRenderer::Drawing::shade_uniforms(int res, int reduce, bool area_coverage, bool small_apart) {
    const Program& shade = s_.programs.shade;
    glUseProgram(shade.get());
    glUniform1i(shade.uniform("grid"), res);
    const double pixel_area = level_pixel_area(reduce);
    glUniform1f(shade.uniform("small_area"), area_coverage ? 0.0f : static_cast<float>(kSmallAreaPx * pixel_area));
    const bool slivers = small_apart && !area_coverage;
    glUniform1f(shade.uniform("sliver_height"), slivers ? static_cast<float>(kSliverPx * std::sqrt(pixel_area)) : 0.0f);
    glUniform1f(shade.uniform("sliver_area"), static_cast<float>(kSliverAreaPx * pixel_area));
    glUniform1i(shade.uniform("ringing"), options_.ringing ? 1 : 0);
    glUniform1i(shade.uniform("iris_sdf"), 0);
    glUniform1f(shade.uniform("iris_extent"), static_cast<float>(IrisTextures::kExtent));
}

// One ghost's (res+1)^2 ray grid over `rect` (turned by `rotation`) traced into the bound vertex buffer.
void FlareRenderer::Drawing::dispatch_trace(int res, const PupilRect& rect, double rotation, const optics::Vec3& direction,
                                            int first_step, int step_count, std::size_t vertex_offset) {
    trace_uniforms(res, rotation, direction);
    glUniform1i(s_.programs.trace.uniform("step_offset"), first_step);
    glUniform1i(s_.programs.trace.uniform("step_count"), step_count);
    glUniform1ui(s_.programs.trace.uniform("vertex_offset"), static_cast<GLuint>(vertex_offset));
    glUniform4f(s_.programs.trace.uniform("rect"), static_cast<float>(rect.x0), static_cast<float>(rect.y0),
                static_cast<float>(rect.x1), static_cast<float>(rect.y1));
    glDispatchCompute(vertex_groups(res), 1, 1);
}

// Vertex irradiance for Gouraud shading (ghost_shade_comp), once the batch's trace is done, over the
// triangles that are rasterised at 1/reduce of the image.
// For a ghost drawn at 1/kRimReduce or less it also marks the triangles its rim pass draws; a point-sampled one
// gets its rasterised triangles written as indices, and one drawn by them (no rim pass) its vertices inside the iris marked.
void FlareRenderer::Drawing::dispatch_shade(const GhostPlan& plan, const BatchJob& job, const SmallList& small, int stop_crossings) {
    const int res = plan.grid, reduce = plan.reduce;
    shade_uniforms(res, reduce, plan.area_coverage, plan.small_apart);
    glUniform1i(s_.programs.shade.uniform("list_small"), small.groups > 0 ? 1 : 0);
    glUniform1ui(s_.programs.shade.uniform("small_first"), static_cast<GLuint>(small.first_slot));
    glUniform1ui(s_.programs.shade.uniform("command_first"), static_cast<GLuint>(small.first_command));
    glUniform1ui(s_.programs.shade.uniform("vertex_offset"), static_cast<GLuint>(job.first_vertex));
    glUniform1ui(s_.programs.shade.uniform("first_index"), static_cast<GLuint>(job.first_index));
    glUniform1i(s_.programs.shade.uniform("write_indices"), triangle_indices(plan) > 0 ? 1 : 0);
    glUniform1i(s_.programs.shade.uniform("mark_inside_iris"), triangle_indices(plan) > 0 && !plan.rim_pass() ? 1 : 0);
    split_interior_uniforms(interior_apart(plan), 6 * static_cast<std::size_t>(res) * res, reduce);
    const int rim_target = reduce >= kRimReduce ? reduce / kRimReduce : 0;
    const std::array<double, 2> per_mm = rim_target > 0 ? level_pixels_per_mm(rim_target) : std::array<double, 2>{};
    glUniform2f(s_.programs.shade.uniform("pixels_per_mm"), static_cast<float>(per_mm[0]), static_cast<float>(per_mm[1]));
    glUniform1f(s_.programs.shade.uniform("rim_band"), static_cast<float>(3 * kRimReduce));
    glUniform1i(s_.programs.shade.uniform("stop_crossings"), stop_crossings);
    glDispatchCompute(vertex_groups(res), 1, 1);
}

// Whether the shade pass writes the interior triangles apart (ghost_shade_comp's split_interior), `offset` indices
// after the others, and the pixels per mm of the level they are drawn at (1/reduce of the image).
void FlareRenderer::Drawing::split_interior_uniforms(bool split, std::size_t offset, int reduce) {
    const Program& shade = s_.programs.shade;
    glUniform1i(shade.uniform("split_interior"), split ? 1 : 0);
    glUniform1ui(shade.uniform("interior_offset"), static_cast<GLuint>(offset));
    const std::array<double, 2> per_mm = level_pixels_per_mm(reduce);
    glUniform2f(shade.uniform("level_pixels_per_mm"), static_cast<float>(per_mm[0]), static_cast<float>(per_mm[1]));
}

namespace {

// Traces `count` grids of `vertices` vertices each, in batches whose vertices fit 48 MB of buffer, and reads
// them back: dispatch(i, offset) issues the i-th trace at vertex `offset` of its batch's buffer, take(i, data)
// gets its vertices (12 floats each); `what` names the pass in a GL error.
template <class Dispatch, class Take>
void trace_and_read_back(std::size_t count, std::size_t vertices, const char* what, Dispatch dispatch, Take take) {
    const std::size_t batch = std::max<std::size_t>(1, (std::size_t{48} << 20) / (vertices * kVertexBytes));
    std::vector<float> readback;
    for (std::size_t first = 0; first < count; first += batch) {
        const std::size_t n = std::min(batch, count - first);
        GlObject buffer = GlObject::buffer();
        glNamedBufferStorage(buffer.get(), static_cast<GLsizeiptr>(n * vertices * kVertexBytes), nullptr, GL_MAP_READ_BIT);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, buffer.get());
        for (std::size_t k = 0; k < n; ++k) dispatch(first + k, k * vertices);
        glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
        readback.resize(n * vertices * 12);
        glGetNamedBufferSubData(buffer.get(), 0, static_cast<GLsizeiptr>(readback.size() * sizeof(float)), readback.data());
        check_gl(what);
        for (std::size_t k = 0; k < n; ++k) take(first + k, readback.data() + k * vertices * 12);
    }
}

}  // namespace

// Coarse pass over the whole entrance square of a light direction, all ghosts in batches: which part of the
// pupil each ghost's light gets through, and roughly how much. At least 8 coarse rays span the entrance pupil.
std::vector<GhostEstimate> FlareRenderer::Drawing::coarse_pass(std::size_t p, const GhostSequences& seq, const FlareView& at,
                                                               const Aperture& aperture) {
    const optics::Ray ray = optics::collimated_ray(at.angle_x_deg, at.angle_y_deg, 0.0, 0.0, 0.0);
    const PupilRect square = entrance_square(traced_[p], at);
    const double side = std::max(square.x1 - square.x0, square.y1 - square.y0);
    const double epd = optics::paraxial(system_, passes_[p].wavelength_nm).entrance_pupil_diameter_mm;
    const double spacing = std::min(side / 48.0, std::max(epd, 1e-3) / 8.0);
    const int res = std::clamp(static_cast<int>(std::ceil(side / spacing)), 48, 320);
    const std::size_t coarse_vertices = static_cast<std::size_t>(res + 1) * static_cast<std::size_t>(res + 1);
    std::vector<GhostEstimate> coarse(ghosts_.size());
    trace_and_read_back(
        ghosts_.size(), coarse_vertices, "the coarse ghost pass",
        [&](std::size_t g, std::size_t offset) { dispatch_trace(res, square, 0.0, ray.direction, seq.offset[g], seq.count[g], offset); },
        [&](std::size_t g, const float* vertices) {
            coarse[g] = coarse_estimate(vertices, res, square, seq.stop_crossings[g], aperture, std::abs(ray.direction.z), sensor_radius_);
        });
    find_unknown_peaks(coarse, seq, ray.direction, aperture);
    return coarse;
}

// Ghosts with no whole coarse cell (their light gets through a sliver of the pupil) have no peak, and scene
// culling draws such ghosts whatever their level: a pass of kPeakGrid cells over each one's own rectangle
// finds it (learn_peak).
void FlareRenderer::Drawing::find_unknown_peaks(std::vector<GhostEstimate>& coarse, const GhostSequences& seq,
                                                const optics::Vec3& direction, const Aperture& aperture) {
    std::vector<std::size_t> unknown;
    for (std::size_t g = 0; g < coarse.size(); ++g)
        if (!coarse[g].rect.empty() && !(coarse[g].peak > 0.0)) unknown.push_back(g);
    const std::size_t vertices = static_cast<std::size_t>(kPeakGrid + 1) * static_cast<std::size_t>(kPeakGrid + 1);
    trace_and_read_back(
        unknown.size(), vertices, "the finer pass over ghosts of unknown peak",
        [&](std::size_t k, std::size_t offset) {
            const std::size_t g = unknown[k];
            dispatch_trace(kPeakGrid, coarse[g].rect, 0.0, direction, seq.offset[g], seq.count[g], offset);
        },
        [&](std::size_t k, const float* traced) {
            const std::size_t g = unknown[k];
            learn_peak(coarse[g], coarse_estimate(traced, kPeakGrid, coarse[g].rect, seq.stop_crossings[g], aperture, std::abs(direction.z),
                                                  sensor_radius_));
        });
}

// A bounds table's estimates at the light's field angle whose peak the table does not know (a ghost with light at
// one of the two angles and none at the other, or a sliver at either: BoundsTable::interpolate), traced again at
// that angle as the table's entries are (the light at azimuth 0, a round iris), so scene culling judges them by
// their own light rather than drawing them whole: nikon-80-200 on the 1080p stage frame has 83 such items, veils
// wider than the frame (measure_veil_cells), which made 65 full-size draws that took 2.2 s.
void FlareRenderer::Drawing::find_unknown_peaks_at(std::vector<GhostEstimate>& estimates, const GhostSequences& seq, const FlareView& lit,
                                                   double theta_deg) {
    FlareView at = lit;
    at.angle_x_deg = theta_deg;
    at.angle_y_deg = 0.0;
    const optics::Ray ray = optics::collimated_ray(at.angle_x_deg, at.angle_y_deg, 0.0, 0.0, 0.0);
    Aperture round = system_.aperture;
    round.blades = 0;
    // The table's sensor box of such a ghost says nothing (PupilRect{}): the pass's own box replaces it.
    constexpr PupilRect kNothingYet{1e300, 1e300, -1e300, -1e300};
    for (GhostEstimate& e : estimates)
        if (!e.rect.empty() && !(e.peak > 0.0)) e.sensor = kNothingYet;
    find_unknown_peaks(estimates, seq, ray.direction, round);
    for (GhostEstimate& e : estimates)
        if (!(e.peak > 0.0) && e.sensor.x0 == kNothingYet.x0) e.sensor = PupilRect{};
}

// Pass p's estimates at the light's field angle from its bounds table, their unknown peaks traced again
// (find_unknown_peaks_at), kept per table, pass and angle (LensCaches::table_estimates; cleared past 256 entries).
std::vector<GhostEstimate> FlareRenderer::Drawing::table_estimates(const BoundsTable& table, std::size_t p, const GhostSequences& seq,
                                                                   const FlareView& lit, double theta_deg) {
    auto& kept = s_.caches.table_estimates;
    const auto key = std::tuple{bounds_table_key(key_, passes_, sensor_radius_), p, theta_deg};
    if (const auto it = kept.find(key); it != kept.end()) return it->second;
    std::vector<GhostEstimate> estimates = table.interpolate(static_cast<int>(p), theta_deg);
    find_unknown_peaks_at(estimates, seq, lit, theta_deg);
    if (kept.size() >= 256) kept.clear();
    kept.emplace(key, estimates);
    return estimates;
}

// The bounds table of this lens, ghosts and wavelengths with the entries on either side of the light's field
// angle, computed (and saved) if missing.
BoundsTable& FlareRenderer::Drawing::bounds_table(const FlareView& lit, const FieldDirection& field) {
    const std::uint64_t table_key = bounds_table_key(key_, passes_, sensor_radius_);
    auto it = s_.caches.bounds_tables.find(table_key);
    if (it == s_.caches.bounds_tables.end()) {
        const std::string dir = flare::cache_dir_of(options_.accel.cache_dir);
        it = s_.caches.bounds_tables.emplace(table_key, BoundsTable(table_key, static_cast<int>(passes_.size()),
                                                            static_cast<int>(ghosts_.size()), dir)).first;
        s_.report.stats.table_loaded = it->second.load();
    }
    BoundsTable& table = it->second;
    const int i0 = static_cast<int>(std::floor(field.theta_deg / BoundsTable::step_deg));
    bool computed = false;
    for (int index : {i0, i0 + 1}) {
        if (table.entry(index)) continue;
        FlareView at = lit;
        at.angle_x_deg = index * BoundsTable::step_deg;
        at.angle_y_deg = 0.0;
        Aperture round = system_.aperture;
        round.blades = 0;  // the stop's circle holds any bladed iris: bounds for every iris rotation
        std::vector<std::vector<GhostEstimate>> entry;
        for (std::size_t p = 0; p < passes_.size(); ++p) entry.push_back(coarse_pass(p, sequences(p).seq, at, round));
        table.store(index, std::move(entry));
        ++s_.report.stats.table_computed;
        computed = true;
    }
    if (computed && std::find(unsaved_tables_.begin(), unsaved_tables_.end(), table_key) == unsaved_tables_.end())
        unsaved_tables_.push_back(table_key);
    return table;
}

void FlareRenderer::Drawing::save_tables() {
    for (const std::uint64_t key : unsaved_tables_) {
        try {
            s_.caches.bounds_tables.at(key).save();
        } catch (const std::exception& e) {  // a cache that cannot be written only costs time: said once
            static std::atomic<bool> warned{false};
            if (!warned.exchange(true)) fmt::print(stderr, "lensfx: warning: {} (the cache is not kept this run)\n", e.what());
        }
    }
    unsaved_tables_.clear();
}

void FlareRenderer::Drawing::forget_unsaved_tables() {
    for (const std::uint64_t key : unsaved_tables_) s_.caches.bounds_tables.erase(key);
    unsaved_tables_.clear();
}

// One light's estimates per pass: from the bounds table, a coarse pass, or the whole entrance square; power
// scaled by what the light adds to the pass's channels.
LightEstimates FlareRenderer::Drawing::estimate_light(const ScaledLight& light) {
    const Acceleration& accel = options_.accel;
    FlareView lit = view_;
    lit.angle_x_deg = light.angle_x_deg;
    lit.angle_y_deg = light.angle_y_deg;
    const FieldDirection field = field_direction(lit);
    BoundsTable* table = accel.bounding == Bounding::Table ? &bounds_table(lit, field) : nullptr;
    LightEstimates out;
    if (table) out.rotation = field.phi;
    for (std::size_t p = 0; p < passes_.size(); ++p) {
        const GhostSequences& seq = sequences(p).seq;
        std::vector<GhostEstimate> estimates;
        if (table) {
            estimates = table_estimates(*table, p, seq, lit, field.theta_deg);
        } else if (accel.bounding == Bounding::Coarse || accel.lod || accel.adaptive || accel.reduced) {
            estimates = coarse_pass(p, seq, lit, system_.aperture);
        } else {
            estimates.assign(ghosts_.size(), GhostEstimate{entrance_square(traced_[p], lit), 1.0, 0.0, 0.0});
        }
        if (accel.bounding == Bounding::None) {
            // Ghosts the coarse pass found no light of stay culled; the others cover the whole square.
            const PupilRect square = entrance_square(traced_[p], lit);
            for (GhostEstimate& e : estimates)
                if (!e.rect.empty()) e.rect = square;
        }
        const double weight = pass_light_weight(passes_[p].weight, light.scale);
        for (GhostEstimate& e : estimates) e.power *= weight;
        out.pass.push_back(std::move(estimates));
    }
    return out;
}

// Every light's estimates first: the level of detail weighs each ghost against all the lights' ghosts of its
// pass, so the ghosts of a dim light get fewer rays, or none.
void FlareRenderer::Drawing::estimate_lights() {
    estimates_.resize(lights_.size());
    if (!ghosts_.empty())
        for (std::size_t l = 0; l < lights_.size(); ++l) estimates_[l] = estimate_light(lights_[l]);
    pass_total_ = pass_totals(estimates_, passes_.size(), selection_.drawn);
}

void FlareRenderer::Drawing::cull_scene() {
    verdicts_.assign(lights_.size(), {});
    if (options_.visibility && !options_.per_ghost_power && !ghosts_.empty())
        verdicts_ = cull_lights(estimates_, lights_, passes_, selection_, view_, options_.spread, *options_.visibility);
}

void FlareRenderer::Drawing::draw_band(int band, std::vector<float>& rgb) {
    band_ = band;
    if (band == 0) {  // after the estimates: a frame no level of which fits fails with its bounds tables unsaved
        fit_level_ = level_that_fits(view_.width, view_.height);
        if (fit_level_ > 1 && options_.per_ghost_power)
            throw std::invalid_argument(fmt::format("per-ghost power needs the full-size target, and a {}x{} frame is wider than the GL's "
                                                    "largest texture", view_.width, view_.height));
    }
    if (!ghosts_.empty())
        for (std::size_t l = 0; l < lights_.size(); ++l)
            draw_light(l);
    if (options_.per_ghost_power || !drawn_into_[0]) return;
    if (image_level_ > 1) throw std::logic_error(fmt::format("a ghost drawn at full size for an image at 1/{}", image_level_));
    const TexelRect lit = add_full_band(full_target(), rgb, view_.width, bands_, band);
    if (bands_.count == 1) s_.targets.lit_within(0, lit);  // read whole: the next render clears only that
    drawn_into_[0] = false;  // the next band clears it
}

// Light l's passes planned, each faint ghost merged into its host pass (the nearest the middle that draws it, or
// a finer one) where its dispersion is under what its level shows (merge_faint_passes; not with ringing, whose
// iris differs by wavelength), then drawn.
void FlareRenderer::Drawing::draw_light(std::size_t l) {
    std::vector<PassPlan> plans;
    for (std::size_t p = 0; p < passes_.size(); ++p) plans.push_back(pass_plan(l, p));
    MergedFaint merged;
    if (!options_.ringing && options_.merge_faint)
        merged = merge_faint_passes(plans, estimates_[l], passes_, lights_[l].scale, view_.sensor_width_mm / view_.width);
    s_.report.stats.ghosts_merged += band_ == 0 ? merged.merged : 0;
    for (std::size_t p = 0; p < passes_.size(); ++p) draw_pass(l, p, plans[p], merged.merged > 0 ? &merged.weight[p] : nullptr);
}

// Light l's plan at pass p (plan_pass), counted in the stats.
PassPlan FlareRenderer::Drawing::pass_plan(std::size_t l, std::size_t p) const {
    const DetailSettings detail{options_.accel,        options_.grid,        view_.sensor_width_mm / view_.width,
                                options_.per_ghost_power, options_.batch_faint,
                                std::max({spread_level(options_.spread), image_level_, fit_level_})};
    return plan_pass(estimates_[l].pass[p], pass_total_[p], verdicts_[l].empty() ? std::vector<SceneVerdict>{} : verdicts_[l][p],
                     selection_, detail, band_);
}

// Light l's ghosts at pass p as planned: traced in batches into one vertex buffer and drawn grouped by
// target: a barrier or a change of target makes a software rasteriser finish everything it has queued, so
// there is one of each per batch rather than per ghost. Per-ghost power reads the target after every ghost,
// so there each ghost is a batch. faint_weights: the batched ghosts' R, G, B weights (merged), else the pass's.
void FlareRenderer::Drawing::draw_pass(std::size_t l, std::size_t p, const PassPlan& plan, const std::vector<std::array<double, 3>>* faint_weights) {
    const ScaledLight& light = lights_[l];
    const SpectralPass& pass = passes_[p];
    const optics::Ray axis = optics::collimated_ray(light.angle_x_deg, light.angle_y_deg, 0.0, 0.0, 0.0);
    for (const Program* program : s_.programs.drawing()) {
        glUseProgram(program->get());
        glUniform1i(program->uniform("ringing"), options_.ringing ? 1 : 0);
        glUniform1i(program->uniform("iris_ringing"), 1);
        glUniform1i(program->uniform("rim_mode"), 0);  // the small triangles' for good; ghost_uniforms sets the others'
    }
    if (options_.ringing)
        glBindTextureUnit(1, s_.iris.ringing(system_.aperture, optics::ringing_order(pass.wavelength_nm, f_number_)));
    const GhostSequences& seq = sequences(p).seq;
    const std::vector<GhostEstimate>& estimates = estimates_[l].pass[p];
    s_.report.stats.ghosts_skipped += plan.skipped;
    s_.report.stats.ghosts_culled += plan.culled;
    s_.report.stats.ghosts_faint += plan.faint;
    // Only the channels this pass adds to are written (one of R, G, B in RGB mode; never alpha): a software
    // rasteriser blends and stores less.
    glColorMaski(0, pass.weight[0] != 0.0, pass.weight[1] != 0.0, pass.weight[2] != 0.0, GL_FALSE);
    const PassDraw pd{light, pass, seq, estimates, plan.plans, estimates_[l].rotation, axis.direction, std::abs(axis.direction.z)};
    s_.buffers.reserve_vertices(vertices_to_draw(plan));
    for (const std::vector<BatchJob>& batch :
         batch_ghosts(plan.todo, plan.plans, s_.buffers.vertices_bytes / kVertexBytes, options_.per_ghost_power)) {
        trace_batch(batch, pd);
        raster_batch(batch, pd);
    }
    PassDraw faint = pd;
    if (faint_weights) {  // the faint ghosts add to every channel the passes merged into them give them
        std::array<bool, 3> written{};
        for (const std::size_t g : plan.batched)
            for (std::size_t c = 0; c < 3; ++c) written[c] = written[c] || (*faint_weights)[g][c] != 0.0;
        glColorMaski(0, written[0], written[1], written[2], GL_FALSE);
        faint.weights = faint_weights;
    }
    draw_batched(plan.batched, faint);
}

// The batch's ray grids traced and shaded into the vertex buffer, their rasterised triangles into the index buffer.
void FlareRenderer::Drawing::trace_batch(const std::vector<BatchJob>& batch, const PassDraw& pd) {
    const BatchJob& last = batch.back();
    s_.buffers.reserve_indices((last.first_index + triangle_indices(pd.plans[last.ghost])) * sizeof(GLuint));
    SmallLists small = small_lists(batch, pd.plans);
    s_.buffers.reserve_small(small.slots, small.commands);
    small_lists_ = std::move(small.jobs);
    s_.buffers.bind_vertices();
    s_.buffers.bind_lists();
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, s_.buffers.small_commands.get());
    for (const BatchJob& job : batch) {
        const std::size_t g = job.ghost;
        const int grid = pd.plans[g].grid;
        s_.report.stats.ghosts_drawn += band_ == 0;
        s_.report.stats.rays += band_ == 0 ? static_cast<long long>(grid + 1) * (grid + 1) : 0;
        dispatch_trace(grid, pd.estimates[g].rect, pd.rotation, pd.direction, pd.seq.offset[g], pd.seq.count[g], job.first_vertex);
    }
    glMemoryBarrier(kWrittenForReading);
    glUseProgram(s_.programs.shade.get());
    for (std::size_t j = 0; j < batch.size(); ++j)
        dispatch_shade(pd.plans[batch[j].ghost], batch[j], small_lists_[j], pd.seq.stop_crossings[batch[j].ghost]);
    glMemoryBarrier(kWrittenForReading | GL_ELEMENT_ARRAY_BARRIER_BIT | GL_COMMAND_BARRIER_BIT);
    check_gl(fmt::format("tracing {} ghosts at {} nm", batch.size(), pd.pass.wavelength_nm));
}

// The batch's traced grids rasterised (their small triangles apart) level by level, then the reduced ghosts' rims at
// kRimReduce times their level's resolution (ghost_raster_frag's rim_mode 2), grouped by target. Later bands
// draw only into the full-size target.
void FlareRenderer::Drawing::raster_batch(const std::vector<BatchJob>& batch, const PassDraw& pd) {
    glVertexArrayElementBuffer(s_.buffers.vao.get(), s_.buffers.indices.get());
    for (const int reduce : {32, 16, 8, 4, 2, 1}) {
        if (band_ > 0 && reduce > 1) continue;  // the reduced targets are drawn with the first band
        bool bound = false;
        for (std::size_t j = 0; j < batch.size(); ++j) {
            const BatchJob& job = batch[j];
            const std::size_t g = job.ghost;
            const GhostPlan& plan = pd.plans[g];
            if (plan.reduce != reduce) continue;
            if (!bound) bind_level(reduce);
            bound = true;
            if (reduce > 1) ++s_.report.stats.ghosts_reduced;
            draw_triangles(job, pd, reduce, plan.rim_pass() ? 1 : 0);
            draw_small_triangles(small_lists_[j]);
            check_gl(fmt::format("rasterising ghost {},{}", ghosts_[g].second, ghosts_[g].first));
            if (options_.per_ghost_power) add_ghost_power(g);
        }
    }
    for (const int level : {1, 2, 4}) {
        if (band_ > 0 && level > 1) continue;  // only the full-size rims have rows in later bands
        bool bound = false;
        for (const BatchJob& job : batch) {
            const GhostPlan& plan = pd.plans[job.ghost];
            if (!plan.rim_pass() || plan.reduce / kRimReduce != level) continue;
            if (!bound) bind_level(level);
            bound = true;
            draw_triangles(job, pd, plan.reduce, 2);
            check_gl(fmt::format("the rim of ghost {},{}", ghosts_[job.ghost].second, ghosts_[job.ghost].first));
        }
    }
    glVertexArrayElementBuffer(s_.buffers.vao.get(), 0);
}

// A ghost's small triangles (those its shade pass listed), with area coverage: one command per work group of
// that pass, most of them empty. Its uniforms are ghost_uniforms'.
void FlareRenderer::Drawing::draw_small_triangles(const SmallList& small) {
    if (small.groups == 0) return;
    const Program& program = s_.programs.small;
    glUseProgram(program.get());
    glUniform1ui(program.uniform("small_first"), static_cast<GLuint>(small.first_slot));
    glBindBuffer(GL_DRAW_INDIRECT_BUFFER, s_.buffers.small_commands.get());
    glMultiDrawArraysIndirect(GL_TRIANGLES, reinterpret_cast<const void*>(small.first_command * kDrawCommandBytes),
                              static_cast<GLsizei>(small.groups), 0);
    glBindBuffer(GL_DRAW_INDIRECT_BUFFER, 0);
}

// A ghost's triangles drawn at 1/reduce of the image in ghost_raster_frag's rim_mode: without a rim pass (0) by
// the indices its shade pass wrote, each grid vertex shaded once; else each triangle's corners shaded alone, as
// the rim's values (ghost_raster_vert's v_bary, v_outer) are the triangle's own.
void FlareRenderer::Drawing::draw_triangles(const BatchJob& job, const PassDraw& pd, int reduce, int rim_mode) {
    const GhostPlan& plan = pd.plans[job.ghost];
    const Program& program = ghost_uniforms(job, pd, reduce, rim_mode);
    const auto corners = 6 * plan.grid * plan.grid;  // two triangles a cell
    if (!s_.programs.by_indices(program)) {
        glDrawArrays(GL_TRIANGLES, 0, corners);
        return;
    }
    glDrawElements(GL_TRIANGLES, corners, GL_UNSIGNED_INT, reinterpret_cast<const void*>(job.first_index * sizeof(GLuint)));
    if (!interior_apart(plan)) return;
    // then its interior triangles, after the others in the index buffer (splits_interior)
    glUseProgram(s_.programs.interior.get());
    glDrawElements(GL_TRIANGLES, corners, GL_UNSIGNED_INT,
                   reinterpret_cast<const void*>((job.first_index + static_cast<std::size_t>(corners)) * sizeof(GLuint)));
}

// Ghost g's own draw values into a target at 1/target_reduce of the image (the full-size one in bands).
GhostDrawValues FlareRenderer::Drawing::draw_values(std::size_t g, const PassDraw& pd, int target_reduce) const {
    const int ghost_grid = pd.plans[g].grid;
    const PupilRect& rect = pd.estimates[g].rect;
    const double cell_area = (rect.x1 - rect.x0) * (rect.y1 - rect.y0) / (static_cast<double>(ghost_grid) * ghost_grid);
    const bool full = target_reduce == 1;
    GhostDrawValues v;
    v.triangle_flux = 0.5 * cell_area * pd.cos_angle;
    v.target_w = (view_.width + target_reduce - 1) / target_reduce;
    v.target_h = full ? bands_.rows_drawn(band_) : (view_.height + target_reduce - 1) / target_reduce;
    const optics::GhostStyle* style = selection_.style[g];
    const std::array<double, 3> gain = style ? style->gain : std::array<double, 3>{1.0, 1.0, 1.0};
    const std::array<double, 3>& weight = pd.weights ? (*pd.weights)[g] : pd.pass.weight;
    for (std::size_t c = 0; c < 3; ++c) v.channels[c] = weight[c] * gain[c] * pd.light.scale[c];
    v.offset = style ? style->offset_mm : std::array<double, 2>{};
    // A band of the full-size image: its rows' span of clip space stretched over the viewport.
    v.half_height = view_.sensor_height_mm / 2;
    if (full) {
        const double top = bands_.drawn_first(band_), bottom = bands_.drawn_end(band_);
        v.offset[1] -= (1.0 - (top + bottom) / view_.height) * v.half_height;
        v.half_height *= (bottom - top) / view_.height;
    }
    return v;
}

// One ghost's uniforms in the program that draws its triangles, in the small triangles' and, where its interior
// triangles are drawn apart (splits_interior), in the interior program's. Its triangles are
// sorted into rasterised and small by the pixels of its level (1/reduce of the image: the shade pass's);
// rim_mode 2 draws the same triangles at kRimReduce times that resolution. Returns the triangles' program, bound.
const Program& FlareRenderer::Drawing::ghost_uniforms(const BatchJob& job, const PassDraw& pd, int reduce, int rim_mode) {
    const std::size_t g = job.ghost;
    // The rim pass draws at kRimReduce times the level's resolution; the full-size image in bands.
    const int target_reduce = rim_mode == 2 ? reduce / kRimReduce : reduce;
    const GhostDrawValues v = draw_values(g, pd, target_reduce);
    const Program& triangles = s_.programs.triangles(pd.plans[g], rim_mode);
    for (const Program* program : std::array<const Program*, 3>{&triangles, &s_.programs.small, &s_.programs.interior}) {
        if (program == &s_.programs.interior && !interior_apart(pd.plans[g])) continue;
        glUseProgram(program->get());
        glUniform1i(program->uniform("grid"), pd.plans[g].grid);
        glUniform1i(program->uniform("first_vertex"), static_cast<GLint>(job.first_vertex));
        glUniform1ui(program->uniform("first_index"), static_cast<GLuint>(job.first_index));
        glUniform2f(program->uniform("half_sensor"), static_cast<float>(view_.sensor_width_mm / 2), static_cast<float>(v.half_height));
        glUniform1f(program->uniform("triangle_flux"), static_cast<float>(v.triangle_flux));
        glUniform1f(program->uniform("pixel_area"), static_cast<float>(level_pixel_area(reduce)));
        glUniform2f(program->uniform("viewport"), static_cast<float>(v.target_w), static_cast<float>(v.target_h));
        glUniform1i(program->uniform("iris_sdf"), 0);
        glUniform1f(program->uniform("iris_extent"), static_cast<float>(IrisTextures::kExtent));
        glUniform1i(program->uniform("stop_crossings"), pd.seq.stop_crossings[g]);
        glUniform4f(program->uniform("channels"), static_cast<float>(v.channels[0]), static_cast<float>(v.channels[1]),
                    static_cast<float>(v.channels[2]), 0.0f);
        glUniform2f(program->uniform("offset_mm"), static_cast<float>(v.offset[0]), static_cast<float>(v.offset[1]));
    }
    glUseProgram(triangles.get());
    glUniform1i(triangles.uniform("rim_mode"), rim_mode);
    glUniform1f(triangles.uniform("rim_reduce"), static_cast<float>(reduce / target_reduce));
    return triangles;
}

// The faint ghosts of a pass (PassPlan::batched: no rim pass, small triangles left out) in chunks that fit the vertex
// buffer (batch_faint), each chunk's runs of one grid and level traced, then shaded, then drawn: per run one
// trace and one shade dispatch and one indexed draw, where drawn alone each ghost cost two dispatches, a draw
// and its uniforms (on llvmpipe some 2 ms of CPU), and two barriers a chunk, not a run.
void FlareRenderer::Drawing::draw_batched(const std::vector<std::size_t>& ghosts, const PassDraw& pd) {
    for (const std::vector<FaintRun>& chunk : batch_faint(ghosts, pd.plans, s_.buffers.vertices_bytes / kVertexBytes, band_))
        draw_faint_chunk(chunk, pd);
}

// A chunk's runs, their vertices one after another from the buffer's start: traced, shaded (which also writes
// the triangles each ghost draws into the index buffer) and drawn, each ghost's values from its GhostJob.
void FlareRenderer::Drawing::draw_faint_chunk(const std::vector<FaintRun>& runs, const PassDraw& pd) {
    for (const FaintRun& run : runs) {
        const auto n = band_ == 0 ? static_cast<int>(run.ghosts.size()) : 0;  // counted in band 0
        s_.report.stats.ghosts_drawn += n;
        s_.report.stats.rays += static_cast<long long>(run.grid + 1) * (run.grid + 1) * n;
        s_.report.stats.ghosts_reduced += run.reduce > 1 ? n : 0;
    }
    upload_jobs(runs, pd);
    const FaintRun& last = runs.back();
    s_.buffers.reserve_indices((last.first_index + 6 * static_cast<std::size_t>(last.grid) * last.grid * last.ghosts.size()) *
                               sizeof(GLuint));
    s_.buffers.bind_vertices();
    s_.buffers.bind_lists();
    for (const FaintRun& run : runs) {
        trace_uniforms(run.grid, pd.rotation, pd.direction);
        dispatch_batched(s_.programs.trace, run);
    }
    glMemoryBarrier(kWrittenForReading);
    for (const FaintRun& run : runs) {
        shade_uniforms(run.grid, run.reduce, false, false);
        glUniform2f(s_.programs.shade.uniform("pixels_per_mm"), 0.0f, 0.0f);  // no rim pass
        glUniform1i(s_.programs.shade.uniform("write_indices"), 1);       // drawn by its indices, which
        glUniform1i(s_.programs.shade.uniform("mark_inside_iris"), 1);    // skip the iris inside it
        glUniform1i(s_.programs.shade.uniform("list_small"), 0);          // small triangles left out
        glUniform1ui(s_.programs.shade.uniform("first_index"), static_cast<GLuint>(run.first_index));
        split_interior_uniforms(false, 0, run.reduce);  // one list (splits_interior)
        dispatch_batched(s_.programs.shade, run);
    }
    glMemoryBarrier(kWrittenForReading | GL_ELEMENT_ARRAY_BARRIER_BIT);
    glVertexArrayElementBuffer(s_.buffers.vao.get(), s_.buffers.indices.get());
    for (const FaintRun& run : runs) raster_faint(run, pd);
    glVertexArrayElementBuffer(s_.buffers.vao.get(), 0);
    check_gl(fmt::format("drawing {} runs of faint ghosts at {} nm", runs.size(), pd.pass.wavelength_nm));
}

// The bound compute program dispatched over a run's grids in batched mode (vertex_groups work groups each,
// along the grid's vertices: grid_vertex; the work group's z its ghost from the run's first job on).
void FlareRenderer::Drawing::dispatch_batched(const Program& program, const FaintRun& run) {
    glUniform1i(program.uniform("batched"), 1);
    glUniform1i(program.uniform("first_job"), static_cast<GLint>(run.first_job));
    glDispatchCompute(vertex_groups(run.grid), 1, static_cast<GLuint>(run.ghosts.size()));
    glUniform1i(program.uniform("batched"), 0);
}

// A run's traced and shaded grids drawn into its level's target by the indices the shade pass wrote, each grid
// vertex shaded once (ghost_raster_vert's FAINT); the level's values are every ghost's.
void FlareRenderer::Drawing::raster_faint(const FaintRun& run, const PassDraw& pd) {
    bind_level(run.reduce);
    const GhostDrawValues v = draw_values(run.ghosts.front(), pd, run.reduce);
    const Program& raster = s_.programs.faint;
    glUseProgram(raster.get());
    glUniform1i(raster.uniform("batched"), 1);
    glUniform1i(raster.uniform("first_job"), static_cast<GLint>(run.first_job));
    glUniform1i(raster.uniform("first_vertex"), static_cast<GLint>(run.first_vertex));
    glUniform1i(raster.uniform("grid"), run.grid);
    glUniform2f(raster.uniform("half_sensor"), static_cast<float>(view_.sensor_width_mm / 2), static_cast<float>(v.half_height));
    glUniform1i(raster.uniform("iris_sdf"), 0);
    glUniform1f(raster.uniform("iris_extent"), static_cast<float>(IrisTextures::kExtent));
    glUniform1i(raster.uniform("ringing"), options_.ringing ? 1 : 0);
    glUniform1i(raster.uniform("iris_ringing"), 1);
    const std::size_t count = 6 * static_cast<std::size_t>(run.grid) * static_cast<std::size_t>(run.grid) * run.ghosts.size();
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(count), GL_UNSIGNED_INT,
                   reinterpret_cast<const void*>(run.first_index * sizeof(GLuint)));
    glUniform1i(raster.uniform("batched"), 0);
}

// The jobs of a chunk's ghosts into the jobs buffer, bound for the shaders.
void FlareRenderer::Drawing::upload_jobs(const std::vector<FaintRun>& runs, const PassDraw& pd) {
    std::vector<GhostJob> jobs;
    for (const FaintRun& run : runs) {
        const auto side = static_cast<std::size_t>(run.grid + 1);
        for (std::size_t k = 0; k < run.ghosts.size(); ++k) {
            const std::size_t g = run.ghosts[k];
            const GhostDrawValues v = draw_values(g, pd, run.reduce);
            const PupilRect& r = pd.estimates[g].rect;
            const auto first_vertex = static_cast<std::int32_t>(run.first_vertex + k * side * side);
            jobs.push_back({{pd.seq.offset[g], pd.seq.count[g], first_vertex, pd.seq.stop_crossings[g]},
                            {static_cast<float>(r.x0), static_cast<float>(r.y0), static_cast<float>(r.x1), static_cast<float>(r.y1)},
                            {static_cast<float>(v.channels[0]), static_cast<float>(v.channels[1]), static_cast<float>(v.channels[2]), 0.0f},
                            {static_cast<float>(v.triangle_flux), static_cast<float>(v.offset[0]), static_cast<float>(v.offset[1]), 0.0f}});
        }
    }
    s_.buffers.upload_jobs(jobs.data(), jobs.size() * sizeof(GhostJob));
}

// Per-ghost power: the full-size target (drawn whole) read back into the CPU sum and ghost g's power, then cleared.
void FlareRenderer::Drawing::add_ghost_power(std::size_t g) {
    const std::vector<float> rgba = full_target().read_rgba();
    const double pixel_area = view_.pixel_area_mm2();
    for (std::size_t i = 0; i < accumulated_.size() / 3; ++i) {
        for (std::size_t c = 0; c < 3; ++c) {
            const auto value = static_cast<double>(rgba[i * 4 + c]);
            accumulated_[i * 3 + c] += value;
            powers_[g].power[c] += value * pixel_area;
        }
    }
    s_.targets.clear(0);
}

void FlareRenderer::Drawing::read_back(std::vector<float>& rgb, std::vector<GhostPower>* ghost_powers) {
    glColorMaski(0, GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    if (options_.per_ghost_power) {
        const auto width = static_cast<std::size_t>(view_.width);
        for (int y = 0; y < view_.height; ++y) {
            const std::size_t src = static_cast<std::size_t>(view_.height - 1 - y) * width * 3;
            const std::size_t dst = static_cast<std::size_t>(y) * width * 3;
            for (std::size_t i = 0; i < width * 3; ++i) rgb[dst + i] += static_cast<float>(accumulated_[src + i]);
        }
        if (ghost_powers) *ghost_powers = std::move(powers_);
    } else {
        std::vector<BandReader> readbacks;  // the reduced targets' lit parts, read back in bands of rows
        for (int slot = 1; slot < static_cast<int>(RenderTargets::kSlots); ++slot) {
            if (!drawn_into_[slot]) continue;
            if ((1 << slot) < image_level_) throw std::logic_error(fmt::format("a ghost drawn at 1/{} for an image at 1/{}", 1 << slot, image_level_));
            const FloatTarget& t = s_.targets.reduced(1 << slot, view_.width, view_.height);
            const TexelRect lit = lit_rect(t);
            s_.targets.lit_within(static_cast<std::size_t>(slot), lit);
            if (!lit.empty()) readbacks.emplace_back(t, lit);
        }
        add_targets(readbacks, rgb, flare::reduced_side(view_.width, image_level_), flare::reduced_side(view_.height, image_level_),
                    options_.split_read_back);
    }
    glUseProgram(0);
    glBindVertexArray(0);
}

std::vector<float> FlareRenderer::Drawing::trace_alone(std::pair<int, int> ghost, int grid, const PupilRect& rect,
                                                      std::vector<std::uint32_t>* indices) {
    const auto found = std::find_if(ghosts_.begin(), ghosts_.end(), [&](const Ghost& gh) {
        return gh.first == std::max(ghost.first, ghost.second) && gh.second == std::min(ghost.first, ghost.second);
    });
    if (found == ghosts_.end())
        throw std::invalid_argument(fmt::format("{}: no ghost {},{}", system_.name, ghost.first, ghost.second));
    const auto g = static_cast<std::size_t>(found - ghosts_.begin());
    const GhostSequences& seq = sequences(0).seq;
    std::vector<GhostEstimate> estimates(ghosts_.size());
    estimates[g].rect = rect;
    std::vector<GhostPlan> plans(ghosts_.size());
    plans[g] = {true, grid, 1};
    const optics::Ray axis = optics::collimated_ray(view_.angle_x_deg, view_.angle_y_deg, 0.0, 0.0, 0.0);
    const ScaledLight light{view_.angle_x_deg, view_.angle_y_deg, {1.0, 1.0, 1.0}};
    const PassDraw pd{light, passes_[0], seq, estimates, plans, 0.0, axis.direction, std::abs(axis.direction.z)};
    s_.buffers.reserve_vertices(static_cast<std::size_t>(grid + 1) * static_cast<std::size_t>(grid + 1));
    trace_batch({{g, 0, 0}}, pd);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    std::vector<float> vertices(static_cast<std::size_t>(grid + 1) * static_cast<std::size_t>(grid + 1) * 12);
    glGetNamedBufferSubData(s_.buffers.vertices.get(), 0, static_cast<GLsizeiptr>(vertices.size() * sizeof(float)), vertices.data());
    if (indices) {
        indices->resize(triangle_indices(plans[g]));
        glGetNamedBufferSubData(s_.buffers.indices.get(), 0, static_cast<GLsizeiptr>(indices->size() * sizeof(GLuint)), indices->data());
    }
    check_gl("reading the traced vertices back");
    glUseProgram(0);
    glBindVertexArray(0);
    return vertices;
}

// The first light's passes drawn as four ghosts planned to use every program: indexed with its small triangles
// apart, with area coverage, reduced with a rim pass at full size, and faint (batched). Each is a 2 x 2 grid over
// a square millimetre at the pupil's centre, and the light carries no power: nothing is added to the targets.
void FlareRenderer::Drawing::warm_up() {
    constexpr std::size_t kWarmGhosts = 4;
    if (ghosts_.size() < kWarmGhosts || lights_.empty()) return;
    GhostEstimate small;
    small.rect = {-0.5, -0.5, 0.5, 0.5};
    estimates_.assign(1, LightEstimates{std::vector<std::vector<GhostEstimate>>(passes_.size(), std::vector<GhostEstimate>(ghosts_.size(), small))});
    PassPlan plan;
    plan.plans.assign(ghosts_.size(), GhostPlan{});
    plan.plans[0] = {.draw = true, .grid = 2, .reduce = 1, .rim = false};
    plan.plans[1] = {.draw = true, .grid = 2, .reduce = 1, .rim = false, .area_coverage = true};
    plan.plans[2] = {.draw = true, .grid = 2, .reduce = kRimReduce, .rim = true};
    plan.plans[3] = {.draw = true, .grid = 2, .reduce = 2, .rim = false, .small_apart = false, .faint = true};
    plan.todo = {0, 1, 2};
    plan.batched = {3};
    for (std::size_t p = 0; p < passes_.size(); ++p) draw_pass(0, p, plan, nullptr);
    glColorMaski(0, GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);  // as a read-back leaves them, for whoever draws next
    glUseProgram(0);
    glBindVertexArray(0);
    glFinish();  // compiled here, on this thread, before the context is handed on
}

void FlareRenderer::prepare(const System& system, const FlareView& view, const GpuFlareOptions& options) {
    FlareView small = view;
    small.width = kWarmUpSide;
    small.height = kWarmUpSide;
    const ScaledLight dark{0.0, 0.0, {0.0, 0.0, 0.0}};
    GpuFlareOptions plain = options;
    plain.visibility = nullptr;
    plain.per_ghost_power = false;
    // No ringing texture: it is planned with FFTW, whose planner must not run beside the caller's (the
    // filter's starburst, on its own thread while this runs on the context's worker). Its use is a uniform.
    plain.ringing = false;
    Drawing drawing = start_drawing(system, small, std::span(&dark, 1), plain);
    drawing.warm_up();
    state_->report.stats = {};
}

void FlareRenderer::draw(const System& system, const FlareView& view, std::span<const ScaledLight> lights,
                         const GpuFlareOptions& options, std::vector<float>& rgb, std::vector<GhostPower>* ghost_powers, int level) {
    Drawing drawing = start_drawing(system, view, lights, options);
    try {
        drawing.set_image_level(level);
        drawing.estimate_lights();
        drawing.cull_scene();
        for (int band = 0; band < drawing.bands(); ++band) drawing.draw_band(band, rgb);
        drawing.read_back(rgb, ghost_powers);
    } catch (...) {
        drawing.forget_unsaved_tables();
        throw;
    }
    drawing.save_tables();
}

// Checks the inputs, fits the ghosts to the memory budget (aperture culling leaves out those crossing the stop
// three times) and sets up the drawing.
FlareRenderer::Drawing FlareRenderer::start_drawing(const System& system, const FlareView& view, std::span<const ScaledLight> lights,
                                                    const GpuFlareOptions& options) {
    if (options.grid < 2 || options.grid > 2048) {
        throw std::invalid_argument(fmt::format("ghost grid {} outside 2..2048", options.grid));
    }
    if (system.stop < 0) throw std::invalid_argument(fmt::format("{}: the system has no aperture stop", system.name));
    check_ghost_tables(system, view.passes().size(), options.memory);
    state_->report.stats = {};
    std::vector<Ghost> ghosts = fitted_ghosts(system, view, options.memory);
    if (options.accel.aperture_culling)
        std::erase_if(ghosts, [](const Ghost& g) { return g.crosses_stop_three_times; });
    return Drawing(*state_, system, view, lights, options, std::move(ghosts));
}

std::vector<float> FlareRenderer::trace_ghost(const System& system, const FlareView& view, std::pair<int, int> ghost, int grid,
                                              const PupilRect& rect, std::vector<std::uint32_t>* indices) {
    const ScaledLight light{view.angle_x_deg, view.angle_y_deg, {1.0, 1.0, 1.0}};
    const GpuFlareOptions options;
    Drawing drawing = start_drawing(system, view, std::span(&light, 1), options);
    return drawing.trace_alone(ghost, grid, rect, indices);
}

FlareImage FlareRenderer::render(const System& system, const FlareView& view, const GpuFlareOptions& options) {
    FlareImage out;
    out.width = view.width;
    out.height = view.height;
    out.rgb.assign(static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height) * 3, 0.0f);
    const ScaledLight light{view.angle_x_deg, view.angle_y_deg, {1.0, 1.0, 1.0}};
    draw(system, view, std::span(&light, 1), options, out.rgb, options.per_ghost_power ? &out.ghosts : nullptr);
    return out;
}

void FlareRenderer::render_add(const System& system, const FlareView& view, std::span<const ScaledLight> lights,
                               const GpuFlareOptions& options, std::vector<float>& rgb, int level) {
    if (options.per_ghost_power) throw std::invalid_argument("render_add: per-ghost power needs one light (render)");
    if (level != 1 && level != 2 && level != 4 && level != 8 && level != 16)
        throw std::invalid_argument(fmt::format("render_add: level {} is not 1, 2, 4, 8 or 16", level));
    const int w = flare::reduced_side(view.width, level), h = flare::reduced_side(view.height, level);
    if (rgb.size() != static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3)
        throw std::invalid_argument(fmt::format("render_add: the image holds {} values, {}x{} RGB expected", rgb.size(), w, h));
    draw(system, view, lights, options, rgb, nullptr, level);
}

const RenderStats& FlareRenderer::last_stats() const { return state_->report.stats; }

void FlareRenderer::release_targets() {
    state_->targets.release();
}

namespace {

// Bytes of the ghost list (every ghost and its path), made before anything is drawn.
double ghost_list_bytes(const System& system) {
    return static_cast<double>(optics::ghost_count(system)) * (sizeof(Ghost) + 4.0 * sizeof(int)) +
           ghost_steps(system) * sizeof(optics::Step);
}

// Bytes one pass set of a drawn ghost's steps holds: its StepData per pass, on the CPU and in a GL buffer.
double drawn_step_bytes(std::size_t passes) { return 2.0 * static_cast<double>(passes) * sizeof(StepData); }

// The factor tables: per surface four (reflected or transmitted, either way) and the stop's, per pass, twice.
double factor_table_bytes(const System& system, std::size_t passes) {
    return 2.0 * static_cast<double>(passes) * (4.0 * static_cast<double>(system.interfaces.size()) + 1.0) * kTableSize * sizeof(float);
}

std::string lens_ghosts_text(const System& system, std::size_t passes) {
    return fmt::format("lens {}: the ghost data of its {} surfaces ({} ghosts, {} wavelengths)", system.name,
                       system.interfaces.size(), optics::ghost_count(system), passes);
}

}  // namespace

double render_target_bytes(int width, int height, double full_target_bytes) {
    const FullBands bands = full_target_bands(width, height, full_target_bytes, false);
    double bytes = 16.0 * width * bands.target_rows();
    for (int reduce : {2, 4, 8, 16, 32}) bytes += 16.0 * ((width + reduce - 1) / reduce) * ((height + reduce - 1) / reduce);
    return bytes;
}

double ghost_table_bytes(const System& system, std::size_t passes) {
    return ghost_list_bytes(system) + ghost_steps(system) * drawn_step_bytes(passes) + factor_table_bytes(system, passes);
}

void check_ghost_tables(const System& system, std::size_t passes, const MemoryBudget& budget) {
    if (!budget.limited()) return;
    // What nothing can shrink, against the half of the budget the ghost data may take: the list of ghosts
    // (ghosts_within_budget draws fewer of them when the rest does not fit) and the brightest ghost's data.
    // Checked before the list is made: for 1000 surfaces it alone is some 10 GB.
    const double longest = 2.0 * static_cast<double>(system.interfaces.size());
    const double bytes = ghost_list_bytes(system) + longest * drawn_step_bytes(passes) + factor_table_bytes(system, passes);
    if (bytes > static_cast<double>(budget.limit) / 2.0)
        throw MemoryLimitError(fmt::format("lens {}: even the list of the {} ghosts of its {} surfaces needs {}, over half the memory "
                                           "limit of {} (the other half is for frames and flare images; --memory-limit)",
                                           system.name, optics::ghost_count(system), system.interfaces.size(), format_bytes(bytes),
                                           format_bytes(static_cast<double>(budget.limit))));
}

namespace {

// The ghosts' indices from the brightest down by their power along the axis (at the d line), and each
// one's power (0 where it is not finite).
std::vector<std::pair<double, std::size_t>> brightest_first(const System& system, const std::vector<Ghost>& ghosts) {
    const optics::TraceSystem traced(system, optics::kLambdaD_nm);
    std::vector<std::pair<double, std::size_t>> order;
    for (std::size_t g = 0; g < ghosts.size(); ++g) {
        const double power = optics::ghost_axial_factor(traced, ghosts[g]);
        order.emplace_back(std::isfinite(power) ? power : 0.0, g);
    }
    std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    return order;
}

// The warning when fit left ghosts out: why, how many are drawn and the share of the power left out.
std::string fit_warning(const System& system, std::size_t passes, const GhostFit& fit, const MemoryBudget& budget) {
    const std::string why =
        fit_over_budget(fit, budget) ? fmt::format("needs {}, over half the memory limit of {}", format_bytes(fit.bytes_needed),
                                      format_bytes(static_cast<double>(budget.limit)))
                        : fmt::format("takes more than the {} interface steps a lens's ghosts are drawn with", kMaxLensGhostSteps);
    return fmt::format("lensfx: warning: {} {}: drawing its {} brightest ghosts (by power along the axis); the {} left out "
                       "carry {:.2g}% of that power\n",
                       lens_ghosts_text(system, passes), why, fit.ghosts.size(), fit.total - fit.ghosts.size(), 100.0 * fit.power_left_out);
}

}  // namespace

bool fit_over_budget(const GhostFit& fit, const MemoryBudget& budget) {
    return budget.limited() && fit.bytes_needed > static_cast<double>(budget.limit) / 2.0;
}

GhostFit ghosts_within_budget(const System& system, std::vector<Ghost> ghosts, std::size_t passes, const MemoryBudget& budget) {
    return ghosts_within(system, std::move(ghosts), passes, budget, kMaxLensGhostSteps);
}

std::size_t summed_steps(const std::vector<Ghost>& ghosts) {
    std::size_t steps = 0;
    for (const Ghost& g : ghosts) steps += g.path.size();
    return steps;
}

GhostFit ghosts_within(const System& system, std::vector<Ghost> ghosts, std::size_t passes, const MemoryBudget& budget,
                       std::size_t max_steps) {
    GhostFit fit;
    fit.total = ghosts.size();
    double need = factor_table_bytes(system, passes);
    for (const Ghost& g : ghosts) need += static_cast<double>(g.path.size()) * drawn_step_bytes(passes);
    fit.bytes_needed = need + ghost_list_bytes(system);
    // Half of the budget for the ghost data: frames, flare images and GL targets need the rest.
    const double room = budget.limited() ? static_cast<double>(budget.limit) / 2.0 - ghost_list_bytes(system) - factor_table_bytes(system, passes)
                                         : std::numeric_limits<double>::infinity();
    if (!fit_over_budget(fit, budget) && summed_steps(ghosts) <= max_steps) {
        fit.ghosts = std::move(ghosts);
        return fit;
    }
    double used = 0.0, kept_power = 0.0, total_power = 0.0;
    std::size_t steps = 0;
    bool full = false;
    std::vector<char> keep(ghosts.size(), 0);
    for (const auto& [power, g] : brightest_first(system, ghosts)) {
        total_power += power;
        const double bytes = static_cast<double>(ghosts[g].path.size()) * drawn_step_bytes(passes);
        full = full || used + bytes > room || steps + ghosts[g].path.size() > max_steps;
        if (full) continue;
        used += bytes;
        steps += ghosts[g].path.size();
        kept_power += power;
        keep[g] = 1;
    }
    for (std::size_t g = 0; g < ghosts.size(); ++g)
        if (keep[g]) fit.ghosts.push_back(std::move(ghosts[g]));
    if (fit.ghosts.empty())
        throw MemoryLimitError(fmt::format("{} needs {}: not even its brightest ghost fits half the memory limit of {} "
                                           "beside its ghost list (--memory-limit)",
                                           lens_ghosts_text(system, passes), format_bytes(fit.bytes_needed), format_bytes(static_cast<double>(budget.limit))));
    fit.power_left_out = total_power > 0.0 ? 1.0 - kept_power / total_power : 0.0;
    return fit;
}

std::vector<Ghost> FlareRenderer::fitted_ghosts(const System& system, const FlareView& view, const MemoryBudget& budget) {
    GhostFit fit = ghosts_within_budget(system, selected_ghosts(system, view), view.passes().size(), budget);
    if (fit.ghosts.size() < fit.total && !state_->report.fit_warned) {
        state_->report.fit_warned = true;  // once per renderer: every frame draws the same ghosts
        fmt::print(stderr, "{}", fit_warning(system, view.passes().size(), fit, budget));
    }
    return std::move(fit.ghosts);
}

}  // namespace lensfx::gpu
