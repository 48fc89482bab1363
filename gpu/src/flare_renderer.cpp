// GPU ghost renderer: CPU side (ghost sequences, coating tables, pupil bounds) and the GL passes.
#include <gpu/flare_renderer.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include <epoxy/gl.h>
#include <fmt/core.h>
#include <optics/coating.h>
#include <optics/paraxial.h>

#include <gpu/gl.h>

#include "flare_shaders.h"

namespace lensfx::gpu {
namespace {

constexpr int kTableSize = 256;        // Fresnel/coating factor samples over cos(incidence) in [0, 1]
constexpr int kIrisSize = 512;         // iris SDF texture side
constexpr double kIrisExtent = 1.25;   // the texture spans [-extent, extent]^2 stop radii
constexpr double kSplatArea = 1.0;     // grid triangles under this many pixels are drawn as point splats

struct StepData {
    float geom[4];
    float media[4];
};

}  // namespace

struct FlareRenderer::State {
    Program trace{"ghost_trace.comp", {{ShaderStage::Type::Compute, shaders::ghost_trace_comp}}};
    Program raster{"ghost_raster",
                   {{ShaderStage::Type::Vertex, std::string(shaders::ghost_grid_glsl) + shaders::ghost_raster_vert},
                    {ShaderStage::Type::Fragment, shaders::ghost_raster_frag}}};
    Program splat{"ghost_splat",
                  {{ShaderStage::Type::Vertex, std::string(shaders::ghost_grid_glsl) + shaders::ghost_splat_vert},
                   {ShaderStage::Type::Fragment, shaders::ghost_splat_frag}}};
    GlObject vao = GlObject::vertex_array();
    GlObject steps = GlObject::buffer();
    GlObject tables = GlObject::buffer();
    GlObject vertices = GlObject::buffer();
    std::size_t vertices_bytes = 0;
    GlObject iris = GlObject::texture();
    std::optional<Aperture> iris_for;  // the aperture the texture currently holds

    void upload_iris(const Aperture& aperture) {
        if (iris_for && iris_for->blades == aperture.blades && iris_for->rotation_deg == aperture.rotation_deg &&
            iris_for->blade_curvature == aperture.blade_curvature) {
            return;
        }
        std::vector<float> sdf(static_cast<std::size_t>(kIrisSize) * kIrisSize);
        for (int j = 0; j < kIrisSize; ++j) {
            for (int i = 0; i < kIrisSize; ++i) {
                const double u = kIrisExtent * (2.0 * (i + 0.5) / kIrisSize - 1.0);
                const double v = kIrisExtent * (2.0 * (j + 0.5) / kIrisSize - 1.0);
                sdf[static_cast<std::size_t>(j) * kIrisSize + static_cast<std::size_t>(i)] =
                    static_cast<float>(aperture_sdf(aperture, u, v));
            }
        }
        iris = GlObject::texture();
        glTextureStorage2D(iris.get(), 1, GL_R32F, kIrisSize, kIrisSize);
        glTextureSubImage2D(iris.get(), 0, 0, 0, kIrisSize, kIrisSize, GL_RED, GL_FLOAT, sdf.data());
        glTextureParameteri(iris.get(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTextureParameteri(iris.get(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTextureParameteri(iris.get(), GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(iris.get(), GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        check_gl("uploading the iris SDF texture");
        iris_for = aperture;
    }
};

FlareRenderer::FlareRenderer(const Context& context) {
    context.make_current();
    state_ = std::make_unique<State>();
}

FlareRenderer::~FlareRenderer() = default;

namespace {

// Every ghost's interface sequence at one wavelength, concatenated: what the trace shader reads.
struct GhostSequences {
    std::vector<StepData> steps;
    std::vector<float> tables;            // kTableSize factors (R or T over cos incidence) per step
    std::vector<int> offset;              // first step of each ghost
    std::vector<int> count;               // steps of each ghost
    std::vector<int> stop_crossings;      // of each ghost
};

GhostSequences build_sequences(const TraceSystem& traced, const std::vector<Ghost>& ghosts) {
    GhostSequences out;
    for (const Ghost& ghost : ghosts) {
        out.offset.push_back(static_cast<int>(out.steps.size()));
        out.count.push_back(static_cast<int>(ghost.path.size()));
        int crossings = 0;
        for (const optics::Step& step : ghost.path) {
            const optics::TraceInterface& surface = traced.interfaces()[static_cast<std::size_t>(step.interface)];
            const double n_in = step.forward ? surface.n_before : surface.n_after;
            const double n_out = step.forward ? surface.n_after : surface.n_before;
            const int kind = surface.is_stop ? 2 : (step.reflect ? 1 : 0);
            out.steps.push_back({{static_cast<float>(surface.z), static_cast<float>(surface.curvature),
                                  static_cast<float>(surface.conic), static_cast<float>(surface.semi_diameter)},
                                 {static_cast<float>(n_in), static_cast<float>(n_out), static_cast<float>(kind),
                                  step.forward ? 1.0f : 0.0f}});
            if (kind == 2) {
                ++crossings;
                out.tables.insert(out.tables.end(), kTableSize, 1.0f);
                continue;
            }
            for (int i = 0; i < kTableSize; ++i) {
                const double cos_i = static_cast<double>(i) / (kTableSize - 1);
                const optics::Reflectance rt =
                    optics::coated_reflectance(surface.coating, n_in, n_out, cos_i, traced.wavelength_nm(), step.forward);
                out.tables.push_back(static_cast<float>(step.reflect ? rt.R : rt.T));
            }
        }
        out.stop_crossings.push_back(crossings);
    }
    return out;
}

// Where a ghost's coarse rays got through, from the coarse pass's vertices.
struct CoarseResult {
    PupilRect rect;
    double power = 0.0;  // estimated power on the sensor plane (unclipped by the image frame)
};

CoarseResult coarse_bounds(const float* vertices, int res, const PupilRect& square, int stop_crossings,
                           const Aperture& aperture, double cos_angle) {
    const double dx = (square.x1 - square.x0) / res;
    const double dy = (square.y1 - square.y0) / res;
    CoarseResult out;
    PupilRect box{1e300, 1e300, -1e300, -1e300};
    bool any = false;
    for (int iy = 0; iy <= res; ++iy) {
        for (int ix = 0; ix <= res; ++ix) {
            const float* v = vertices + (static_cast<std::size_t>(iy) * static_cast<std::size_t>(res + 1) +
                                         static_cast<std::size_t>(ix)) * 12;
            if (v[10] < 0.5f || v[2] > 1.0f) continue;
            bool inside = true;
            for (int k = 0; k < std::min(stop_crossings, 3) && inside; ++k) {
                inside = aperture_sdf(aperture, static_cast<double>(v[4 + 2 * k]), static_cast<double>(v[5 + 2 * k])) <= 0.0;
            }
            if (!inside) continue;
            any = true;
            out.power += static_cast<double>(v[3]) * dx * dy * cos_angle;
            const double x = square.x0 + dx * ix;
            const double y = square.y0 + dy * iy;
            box = {std::min(box.x0, x), std::min(box.y0, y), std::max(box.x1, x), std::max(box.y1, y)};
        }
    }
    if (any) {
        out.rect = {std::max(square.x0, box.x0 - dx), std::max(square.y0, box.y0 - dy),
                    std::min(square.x1, box.x1 + dx), std::min(square.y1, box.y1 + dy)};
    }
    return out;
}

}  // namespace

FlareImage FlareRenderer::render(const System& system, const FlareView& view, const GpuFlareOptions& options) {
    if (options.grid < 2 || options.grid > 2048) {
        throw std::invalid_argument(fmt::format("ghost grid {} outside 2..2048", options.grid));
    }
    if (system.stop < 0) throw std::invalid_argument(fmt::format("{}: the system has no aperture stop", system.name));
    State& s = *state_;
    const std::vector<Ghost> ghosts = selected_ghosts(system, view);
    FloatTarget target(view.width, view.height);
    target.bind();
    target.clear();
    s.upload_iris(system.aperture);

    const int grid = options.grid;
    const std::size_t dense_bytes = static_cast<std::size_t>(grid + 1) * static_cast<std::size_t>(grid + 1) * 12 * sizeof(float);
    if (dense_bytes != s.vertices_bytes) {
        s.vertices = GlObject::buffer();
        glNamedBufferStorage(s.vertices.get(), static_cast<GLsizeiptr>(dense_bytes), nullptr, 0);
        s.vertices_bytes = dense_bytes;
    }

    glBindVertexArray(s.vao.get());
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE);
    glBindTextureUnit(0, s.iris.get());
    glEnable(GL_PROGRAM_POINT_SIZE);

    const optics::Ray axis = optics::collimated_ray(view.angle_x_deg, view.angle_y_deg, 0.0, 0.0, 0.0);
    const double cos_angle = std::abs(axis.direction.z);
    const double pixel_area = view.pixel_area_mm2();
    const std::size_t pixels = static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height);
    std::vector<GhostPower> powers(ghosts.size());
    for (std::size_t g = 0; g < ghosts.size(); ++g) powers[g] = {ghosts[g].first, ghosts[g].second, {}};
    std::vector<double> accumulated;  // per-ghost mode: the image summed on the CPU
    if (options.per_ghost_power) accumulated.assign(pixels * 3, 0.0);

    auto dispatch_trace = [&](int res, const PupilRect& rect, int first_step, int step_count, GLuint vertex_offset) {
        glUseProgram(s.trace.get());
        glUniform1i(s.trace.uniform("step_offset"), first_step);
        glUniform1i(s.trace.uniform("step_count"), step_count);
        glUniform1ui(s.trace.uniform("vertex_offset"), vertex_offset);
        glUniform1i(s.trace.uniform("grid"), res);
        glUniform4f(s.trace.uniform("rect"), static_cast<float>(rect.x0), static_cast<float>(rect.y0),
                    static_cast<float>(rect.x1), static_cast<float>(rect.y1));
        glUniform3f(s.trace.uniform("direction"), static_cast<float>(axis.direction.x),
                    static_cast<float>(axis.direction.y), static_cast<float>(axis.direction.z));
        glUniform1i(s.trace.uniform("table_size"), kTableSize);
        const GLuint groups = static_cast<GLuint>((res + 1 + 7) / 8);
        glDispatchCompute(groups, groups, 1);
    };

    for (const auto& [wavelength, mask] : view.passes()) {
        const TraceSystem traced(system, wavelength);
        for (std::size_t k = 0; k < traced.interfaces().size(); ++k) {
            if (traced.interfaces()[k].has_aspheric) {
                throw std::runtime_error(fmt::format(
                    "{}: surface {} is aspheric; the GPU ghost renderer traces spheres and conics only",
                    system.name, k + 1));
            }
        }
        if (ghosts.empty()) break;
        const GhostSequences seq = build_sequences(traced, ghosts);
        s.steps = GlObject::buffer();
        glNamedBufferStorage(s.steps.get(), static_cast<GLsizeiptr>(seq.steps.size() * sizeof(StepData)), seq.steps.data(), 0);
        s.tables = GlObject::buffer();
        glNamedBufferStorage(s.tables.get(), static_cast<GLsizeiptr>(seq.tables.size() * sizeof(float)), seq.tables.data(), 0);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, s.steps.get());
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, s.tables.get());
        glUseProgram(s.trace.get());
        glUniform1f(s.trace.uniform("sensor_z"), static_cast<float>(traced.sensor_z()));

        // Coarse pass over the whole entrance square, all ghosts in batches: which part of the pupil each
        // ghost's light gets through, and roughly how much. At least 8 coarse rays span the entrance pupil.
        const PupilRect square = entrance_square(traced, view);
        const double side = std::max(square.x1 - square.x0, square.y1 - square.y0);
        const double epd = optics::paraxial(system, wavelength).entrance_pupil_diameter_mm;
        const double spacing = std::min(side / 48.0, std::max(epd, 1e-3) / 8.0);
        const int res = std::clamp(static_cast<int>(std::ceil(side / spacing)), 48, 320);
        const std::size_t coarse_vertices = static_cast<std::size_t>(res + 1) * static_cast<std::size_t>(res + 1);
        const std::size_t batch = std::max<std::size_t>(1, (std::size_t{48} << 20) / (coarse_vertices * 48));
        std::vector<CoarseResult> coarse(ghosts.size());
        std::vector<float> readback;
        for (std::size_t first = 0; first < ghosts.size(); first += batch) {
            const std::size_t n = std::min(batch, ghosts.size() - first);
            GlObject coarse_buffer = GlObject::buffer();
            glNamedBufferStorage(coarse_buffer.get(), static_cast<GLsizeiptr>(n * coarse_vertices * 48), nullptr,
                                 GL_MAP_READ_BIT);
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, coarse_buffer.get());
            for (std::size_t g = first; g < first + n; ++g) {
                dispatch_trace(res, square, seq.offset[g], seq.count[g], static_cast<GLuint>((g - first) * coarse_vertices));
            }
            glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
            readback.resize(n * coarse_vertices * 12);
            glGetNamedBufferSubData(coarse_buffer.get(), 0, static_cast<GLsizeiptr>(readback.size() * sizeof(float)),
                                    readback.data());
            check_gl("the coarse ghost pass");
            for (std::size_t g = first; g < first + n; ++g) {
                coarse[g] = coarse_bounds(readback.data() + (g - first) * coarse_vertices * 12, res, square,
                                          seq.stop_crossings[g], system.aperture, cos_angle);
            }
        }
        double total_estimate = 0.0;
        for (const CoarseResult& c : coarse) total_estimate += c.power;

        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, s.vertices.get());
        for (std::size_t g = 0; g < ghosts.size(); ++g) {
            const Ghost& ghost = ghosts[g];
            const PupilRect& rect = coarse[g].rect;
            if (rect.empty()) continue;
            // Intensity LOD: ghosts holding 1% of the estimated total or more get the full grid; dimmer
            // ones a grid whose ray count scales with their power (at least 16 x 16 cells).
            const double share = total_estimate > 0.0 ? coarse[g].power / total_estimate : 1.0;
            const int ghost_grid = std::clamp(static_cast<int>(std::ceil(grid * std::sqrt(share / 0.01))),
                                              std::min(16, grid), grid);
            dispatch_trace(ghost_grid, rect, seq.offset[g], seq.count[g], 0);
            glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
            check_gl(fmt::format("tracing ghost {},{}", ghost.second, ghost.first));

            const double cell_area = (rect.x1 - rect.x0) * (rect.y1 - rect.y0) / (static_cast<double>(ghost_grid) * ghost_grid);
            // Triangles of a pixel or more are rasterised; smaller ones become bilinear 2 x 2-pixel splats.
            for (const Program* program : {&s.raster, &s.splat}) {
                glUseProgram(program->get());
                glUniform1i(program->uniform("grid"), ghost_grid);
                glUniform2f(program->uniform("half_sensor"), static_cast<float>(view.sensor_width_mm / 2),
                            static_cast<float>(view.sensor_height_mm / 2));
                glUniform1f(program->uniform("triangle_flux"), static_cast<float>(0.5 * cell_area * cos_angle));
                glUniform1f(program->uniform("pixel_area"), static_cast<float>(pixel_area));
                glUniform1f(program->uniform("splat_area"), static_cast<float>(kSplatArea));
                glUniform2f(program->uniform("viewport"), static_cast<float>(view.width), static_cast<float>(view.height));
                glUniform1i(program->uniform("iris_sdf"), 0);
                glUniform1f(program->uniform("iris_extent"), static_cast<float>(kIrisExtent));
                glUniform1i(program->uniform("stop_crossings"), seq.stop_crossings[g]);
                glUniform4f(program->uniform("channels"), mask[0] ? 1.0f : 0.0f, mask[1] ? 1.0f : 0.0f,
                            mask[2] ? 1.0f : 0.0f, 0.0f);
            }
            glUseProgram(s.raster.get());
            glDrawArrays(GL_TRIANGLES, 0, 6 * ghost_grid * ghost_grid);
            glUseProgram(s.splat.get());
            glDrawArrays(GL_POINTS, 0, 2 * ghost_grid * ghost_grid);
            check_gl(fmt::format("rasterising ghost {},{}", ghost.second, ghost.first));

            if (options.per_ghost_power) {
                const std::vector<float> rgba = target.read_rgba();
                for (std::size_t i = 0; i < pixels; ++i) {
                    for (std::size_t c = 0; c < 3; ++c) {
                        const double value = rgba[i * 4 + c];
                        accumulated[i * 3 + c] += value;
                        powers[g].power[c] += value * pixel_area;
                    }
                }
                target.clear();
            }
        }
    }

    FlareImage out;
    out.width = view.width;
    out.height = view.height;
    out.rgb.resize(pixels * 3);
    const std::vector<float> rgba = options.per_ghost_power ? std::vector<float>{} : target.read_rgba();
    for (int y = 0; y < view.height; ++y) {
        const std::size_t src_row = static_cast<std::size_t>(view.height - 1 - y);  // GL rows run bottom-up
        for (int x = 0; x < view.width; ++x) {
            const std::size_t src = src_row * static_cast<std::size_t>(view.width) + static_cast<std::size_t>(x);
            const std::size_t dst = static_cast<std::size_t>(y) * static_cast<std::size_t>(view.width) +
                                    static_cast<std::size_t>(x);
            for (std::size_t c = 0; c < 3; ++c) {
                out.rgb[dst * 3 + c] = options.per_ghost_power ? static_cast<float>(accumulated[src * 3 + c])
                                                               : rgba[src * 4 + c];
            }
        }
    }
    if (options.per_ghost_power) out.ghosts = std::move(powers);
    glUseProgram(0);
    glBindVertexArray(0);
    return out;
}

}  // namespace lensfx::gpu
