// GPU ghost renderer: CPU side (ghost sequences, coating tables, pupil bounds) and the GL passes.
#include <gpu/flare_renderer.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>

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

struct StepData {
    float geom[4];
    float media[4];
};

}  // namespace

struct FlareRenderer::State {
    Program trace{"ghost_trace.comp", {{ShaderStage::Type::Compute, shaders::ghost_trace_comp}}};
    Program raster{"ghost_raster", {{ShaderStage::Type::Vertex, shaders::ghost_raster_vert},
                                    {ShaderStage::Type::Fragment, shaders::ghost_raster_frag}}};
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
    const std::size_t vertex_count = static_cast<std::size_t>(grid + 1) * static_cast<std::size_t>(grid + 1);
    const std::size_t bytes = vertex_count * 3 * 4 * sizeof(float);
    if (bytes != s.vertices_bytes) {
        s.vertices = GlObject::buffer();
        glNamedBufferStorage(s.vertices.get(), static_cast<GLsizeiptr>(bytes), nullptr, 0);
        s.vertices_bytes = bytes;
    }

    glBindVertexArray(s.vao.get());
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, s.steps.get());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, s.vertices.get());
    glBindTextureUnit(0, s.iris.get());

    const optics::Ray axis = optics::collimated_ray(view.angle_x_deg, view.angle_y_deg, 0.0, 0.0, 0.0);
    const double pixel_area = view.pixel_area_mm2();
    const std::size_t pixels = static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height);
    std::vector<GhostPower> powers(ghosts.size());
    for (std::size_t g = 0; g < ghosts.size(); ++g) powers[g] = {ghosts[g].first, ghosts[g].second, {}};
    std::vector<double> accumulated;  // per-ghost mode: the image summed on the CPU
    if (options.per_ghost_power) accumulated.assign(pixels * 3, 0.0);

    for (const auto& [wavelength, mask] : view.passes()) {
        const TraceSystem traced(system, wavelength);
        for (std::size_t k = 0; k < traced.interfaces().size(); ++k) {
            if (traced.interfaces()[k].has_aspheric) {
                throw std::runtime_error(fmt::format(
                    "{}: surface {} is aspheric; the GPU ghost renderer traces spheres and conics only",
                    system.name, k + 1));
            }
        }
        const double epd = optics::paraxial(system, wavelength).entrance_pupil_diameter_mm;
        for (std::size_t g = 0; g < ghosts.size(); ++g) {
            const Ghost& ghost = ghosts[g];
            const PupilRect rect = ghost_pupil_bounds(traced, ghost, system.aperture, view, epd);
            if (rect.empty()) continue;

            std::vector<StepData> steps;
            std::vector<float> table(ghost.path.size() * kTableSize, 1.0f);
            int stop_crossings = 0;
            for (std::size_t k = 0; k < ghost.path.size(); ++k) {
                const optics::Step& step = ghost.path[k];
                const optics::TraceInterface& surface = traced.interfaces()[static_cast<std::size_t>(step.interface)];
                const double n_in = step.forward ? surface.n_before : surface.n_after;
                const double n_out = step.forward ? surface.n_after : surface.n_before;
                const int kind = surface.is_stop ? 2 : (step.reflect ? 1 : 0);
                if (surface.is_stop) ++stop_crossings;
                steps.push_back({{static_cast<float>(surface.z), static_cast<float>(surface.curvature),
                                  static_cast<float>(surface.conic), static_cast<float>(surface.semi_diameter)},
                                 {static_cast<float>(n_in), static_cast<float>(n_out), static_cast<float>(kind),
                                  step.forward ? 1.0f : 0.0f}});
                if (kind == 2) continue;
                for (int i = 0; i < kTableSize; ++i) {
                    const double cos_i = static_cast<double>(i) / (kTableSize - 1);
                    const optics::Reflectance rt =
                        optics::coated_reflectance(surface.coating, n_in, n_out, cos_i, wavelength, step.forward);
                    table[k * kTableSize + static_cast<std::size_t>(i)] = static_cast<float>(step.reflect ? rt.R : rt.T);
                }
            }
            s.steps = GlObject::buffer();
            glNamedBufferStorage(s.steps.get(), static_cast<GLsizeiptr>(steps.size() * sizeof(StepData)), steps.data(), 0);
            s.tables = GlObject::buffer();
            glNamedBufferStorage(s.tables.get(), static_cast<GLsizeiptr>(table.size() * sizeof(float)), table.data(), 0);
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, s.steps.get());
            glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, s.tables.get());

            glUseProgram(s.trace.get());
            glUniform1i(s.trace.uniform("step_count"), static_cast<GLint>(steps.size()));
            glUniform1i(s.trace.uniform("grid"), grid);
            glUniform4f(s.trace.uniform("rect"), static_cast<float>(rect.x0), static_cast<float>(rect.y0),
                        static_cast<float>(rect.x1), static_cast<float>(rect.y1));
            glUniform3f(s.trace.uniform("direction"), static_cast<float>(axis.direction.x),
                        static_cast<float>(axis.direction.y), static_cast<float>(axis.direction.z));
            glUniform1f(s.trace.uniform("sensor_z"), static_cast<float>(traced.sensor_z()));
            glUniform1i(s.trace.uniform("table_size"), kTableSize);
            const GLuint groups = static_cast<GLuint>((grid + 1 + 7) / 8);
            glDispatchCompute(groups, groups, 1);
            glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
            check_gl(fmt::format("tracing ghost {},{}", ghost.second, ghost.first));

            const double cell_area = (rect.x1 - rect.x0) * (rect.y1 - rect.y0) / (static_cast<double>(grid) * grid);
            glUseProgram(s.raster.get());
            glUniform1i(s.raster.uniform("grid"), grid);
            glUniform2f(s.raster.uniform("half_sensor"), static_cast<float>(view.sensor_width_mm / 2),
                        static_cast<float>(view.sensor_height_mm / 2));
            glUniform1f(s.raster.uniform("triangle_flux"),
                        static_cast<float>(0.5 * cell_area * std::abs(axis.direction.z)));
            glUniform1i(s.raster.uniform("iris_sdf"), 0);
            glUniform1f(s.raster.uniform("iris_extent"), static_cast<float>(kIrisExtent));
            glUniform1i(s.raster.uniform("stop_crossings"), stop_crossings);
            glUniform4f(s.raster.uniform("channels"), mask[0] ? 1.0f : 0.0f, mask[1] ? 1.0f : 0.0f,
                        mask[2] ? 1.0f : 0.0f, 0.0f);
            glDrawArrays(GL_TRIANGLES, 0, 6 * grid * grid);
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
