// `lensfx flare`: the ghosts of one collimated light of irradiance 1 on black, in sensor irradiance,
// rendered on the GPU (or by the dense CPU reference with --reference), written as a float EXR, with an
// optional tone-mapped PNG preview and a per-ghost power listing.
#include <algorithm>
#include <array>
#include <chrono>
#include <limits>
#include <cmath>
#include <numbers>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <random>
#include <thread>
#include <vector>

#include <fmt/core.h>
#include <filter/colour.h>
#include <filter/flare_controls.h>
#include <filter/flare_stage.h>
#include <filter/output_files.h>
#include <filter/image_io.h>
#include <filter/ghost_options.h>
#include <filter/pupil_options.h>
#include <gpu/acceleration.h>
#include <gpu/address_space.h>
#include <gpu/band_filter.h>
#include <gpu/context.h>
#include <flare/direct_power.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <measured/model_file.h>
#include <optics/lens_file.h>
#include <optics/flare_look.h>
#include <optics/paraxial.h>
#include <optics/starburst.h>
#include <optics/system.h>
#include <optics/stopwatch.h>
#include <optics/text_pairs.h>

#include <filter/option_checks.h>
#include "commands.h"

namespace lensfx::filter {
namespace {

struct FlareArgs : LensChoice {  // --lens, --zoom, --fstop, --blades, --coating, --coating-spread: as the filter's
    std::string angle;
    std::string sensor = "36";  // as the filter's (FlareSettings): the width, the height from the image's aspect
    std::string size;
    std::optional<double> wavelength;
    int bands = 0;
    bool band_filter = false;
    std::vector<std::string> ghosts;
    bool list = false;
    std::string output;
    std::string preview;
    std::optional<double> preview_exposure;
    bool reference = false;
    int rays = 512;
    int grid = gpu::GpuFlareOptions{}.grid;
    AccelerationSettings accel;
    std::string parts = "ghosts,starburst";  // as the filter's (FlareSettings)
    double starburst_scale = 1.0;
    double ghost_gain = 1.0;
    double starburst_gain = 1.0;
    PupilSettings pupil;
    int threads = 0;  // as the filter's: 0 = one per core
    std::string memory_limit;  // empty: default_memory_budget()
    std::string gpu = "auto";
    bool ringing = false;
    std::string flare_look;
    std::optional<double> iso, shutter;  // a measured lens's target (paper equation 2)
    double background = 0.0, noise = 0.0;  // a synthetic capture's black level and sensor noise
    std::uint64_t seed = 1;
};

std::pair<double, double> parse_pair(const std::string& text, char sep, const char* option) {
    const auto ab = parse_pair_of<double>(text, sep);
    if (!ab || !std::isfinite((*ab)[0]) || !std::isfinite((*ab)[1]))
        throw std::invalid_argument(fmt::format("{} {}: expected two numbers separated by '{}'", option, text, sep));
    return {(*ab)[0], (*ab)[1]};
}

// --angle "AX,AY": each within (-90, 90) degrees, a light in front of the lens (the direction is taken through
// tan, which wraps past 90: --angle 1e308,0 rendered a light from nowhere and exited 0).
std::pair<double, double> parse_angle(const std::string& text) {
    const auto [ax, ay] = parse_pair(text, ',', "--angle");
    if (!(std::fabs(ax) < 90.0 && std::fabs(ay) < 90.0))
        throw std::invalid_argument(fmt::format("--angle {}: each angle within -90..90 degrees (a light in front of the lens)", text));
    return {ax, ay};
}

void write_exr(const flare::FlareImage& image, const std::string& path) {
    WriteOptions options;
    options.compression = "zip";
    write_image(image_frame(image.width, image.height, 3, PixelType::float32, image.rgb.data()), path, options);
}

// Ghosts are some 1e-3 .. 1e-6 of the light: without --preview-exposure the exposure puts the 99.5th
// percentile of the lit pixels' brightest channel at scene value 1.
void write_preview(const flare::FlareImage& image, const std::string& path, std::optional<double> exposure_ev) {
    std::vector<float> rgb = image.rgb;
    double ev = 0.0;
    if (exposure_ev) {
        ev = *exposure_ev;
    } else {
        std::vector<float> lit;
        for (std::size_t i = 0; i + 2 < rgb.size(); i += 3) {
            const float m = std::max({rgb[i], rgb[i + 1], rgb[i + 2]});
            if (m > 0.0f) lit.push_back(m);
        }
        if (!lit.empty()) {
            auto nth = lit.begin() + static_cast<std::ptrdiff_t>(static_cast<double>(lit.size() - 1) * 0.995);
            std::nth_element(lit.begin(), nth, lit.end());
            if (*nth > 0.0f) ev = -std::log2(static_cast<double>(*nth));
        }
    }
    colour::ColourOptions options;
    options.colorspace = std::string(colour::builtin::lin_rec709);
    options.exposure_ev = ev;
    const colour::ColourPipeline pipeline(colour::ColourConfig::builtin_config(), options, std::nullopt);
    colour::PixelSpan span{rgb.data(), static_cast<std::size_t>(image.width), static_cast<std::size_t>(image.height), 3, 0};
    pipeline.to_display().apply(span);
    WriteOptions write;
    write.dither = colour::Dither::Ordered;
    write_image(image_frame(image.width, image.height, 3, PixelType::float32, rgb.data()), path, write);
    fmt::print(stderr, "lensfx flare: preview {} at exposure {:+.2f} EV\n", path, ev);
}

// The light's direction, the sensor and the image size of the command line.
// --size WxH: two whole numbers 1..16384; throws naming the option.
std::pair<int, int> flare_image_size(const std::string& text) {
    const auto [w, h] = parse_pair(text, 'x', "--size");
    if (w < 1 || h < 1 || w != std::floor(w) || h != std::floor(h) || w > 16384 || h > 16384)
        throw std::invalid_argument(fmt::format("--size {}: two whole numbers 1..16384 expected", text));
    return {static_cast<int>(w), static_cast<int>(h)};
}

flare::FlareView flare_view(const FlareArgs& args) {
    flare::FlareView view;
    std::tie(view.angle_x_deg, view.angle_y_deg) = parse_angle(args.angle);
    const auto [sensor_w, sensor_h] = parse_sensor(args.sensor);  // as the filter's
    view.sensor_width_mm = sensor_w;
    view.sensor_height_mm = sensor_h;
    if (!(sensor_h > 0.0)) {
        // The width alone, as in the filter: the height follows the image's aspect (--size), else 3:2.
        double aspect = 2.0 / 3.0;
        if (!args.size.empty()) {
            const auto [w, h] = parse_pair(args.size, 'x', "--size");
            if (w > 0 && h > 0) aspect = h / w;
        }
        view.sensor_height_mm = sensor_w * aspect;
    }
    if (args.size.empty()) {
        view.width = 960;
        view.height = std::max(1, static_cast<int>(std::lround(960.0 * view.sensor_height_mm / view.sensor_width_mm)));
    } else {
        std::tie(view.width, view.height) = flare_image_size(args.size);
    }
    view.wavelength_nm = args.wavelength;
    view.bands = args.bands;
    view.passes();  // checks --bands before any work
    return view;
}

// --background and --noise: a synthetic capture's black level and Gaussian sensor noise (seeded).
void add_sensor_noise(flare::FlareImage& image, const FlareArgs& args) {
    if (args.background == 0.0 && args.noise == 0.0) return;
    std::mt19937_64 random(args.seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (float& v : image.rgb) v = static_cast<float>(static_cast<double>(v) + args.background + args.noise * normal(random));
}

void write_outputs(flare::FlareImage& image, const FlareArgs& args) {
    add_sensor_noise(image, args);
    if (!args.output.empty()) write_exr(image, args.output);
    if (!args.preview.empty()) write_preview(image, args.preview, args.preview_exposure);
}

// The image and its ghosts' powers times --ghost-gain, each value held at the largest float.
void scale_ghosts(flare::FlareImage& image, double gain) {
    for (float& v : image.rgb) v = static_cast<float>(std::min(static_cast<double>(v) * gain, static_cast<double>(std::numeric_limits<float>::max())));
    for (flare::GhostPower& g : image.ghosts)
        for (double& p : g.power) p *= gain;
}

// A measured lens (kind = "measured"): its fitted ghosts, scaled from its capture by paper equation 2.
void run_measured_flare(const FlareArgs& args) {
    const flare::FlareView view = flare_view(args);
    measured::Capture target = measured::read_measured(args.lens).capture;
    if (args.fstop) target.f_number = *args.fstop;
    if (args.iso) target.iso = *args.iso;
    if (args.shutter) target.exposure_s = *args.shutter;
    flare::FlareImage image = render_measured_flare(args.lens, view, target, args.reference, args.gpu);
    scale_ghosts(image, args.ghost_gain);
    write_outputs(image, args);
}

// The image, the GL targets at full and reduced sizes and a band of read-back rows, and the lens's ghost
// tables, against --memory-limit before any of them is made.
MemoryBudget checked_memory(const FlareArgs& args, const optics::System& system, const flare::FlareView& view) {
    const MemoryBudget memory = memory_budget_option(args.memory_limit);
    memory.check(bytes_of(view.width, view.height, 3 * sizeof(float) + 16.0 * (1.0 + 1.0 / 3)),
                 fmt::format("a {}x{} flare image", view.width, view.height));
    gpu::check_ghost_tables(system, view.passes().size(), memory);
    return memory;
}

// --ghost I,J (1-based surfaces, repeatable) as the view's ghosts (0-based).
void add_only_ghosts(const FlareArgs& args, const optics::System& system, flare::FlareView& view) {
    for (const std::string& g : args.ghosts) {
        const auto [a, b] = parse_pair(g, ',', "--ghost");
        const int count = static_cast<int>(system.interfaces.size());
        if (a != std::floor(a) || b != std::floor(b) || a < 1 || b < 1 || a > count || b > count || a == b) {
            throw CLI::ValidationError(fmt::format("--ghost {}: two different surface numbers 1..{} expected", g, count));
        }
        view.only_ghosts.emplace_back(static_cast<int>(a) - 1, static_cast<int>(b) - 1);
    }
}

// The ghosts by the dense CPU reference (--reference), band-filtered with --band-filter.
flare::FlareImage reference_ghosts(const FlareArgs& args, const optics::System& system, const flare::FlareView& view) {
    flare::ReferenceOptions options;
    options.rays = args.rays;
    options.threads = args.threads > 0 ? args.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    options.per_ghost_power = args.list;
    return args.band_filter
               ? gpu::render_band_filtered(system, view,
                                         [&](flare::FlareView one, const std::vector<std::pair<int, int>>& ghosts) {
                                             one.only_ghosts = ghosts;
                                             return flare::render_reference(system, one, options);
                                         })
               : flare::render_reference(system, view, options);
}

// The ghosts by the GPU renderer, band-filtered with --band-filter.
flare::FlareImage gpu_ghosts(const FlareArgs& args, const optics::System& system, const flare::FlareView& view, const MemoryBudget& memory) {
    const gpu::Context context(gpu::parse_platform(args.gpu));
    gpu::FlareRenderer renderer(context);
    gpu::GpuFlareOptions options;
    options.grid = args.grid;
    options.per_ghost_power = args.list;
    options.accel = args.accel.acceleration();
    options.ringing = args.ringing;
    options.memory = memory;
    if (!args.flare_look.empty())
        options.styles = optics::ghost_styles(optics::read_flare_look(args.flare_look), optics::enumerate_ghosts(system));
    return args.band_filter
               ? gpu::render_band_filtered(system, view, gpu::render_one_on(renderer, system, options))
               : renderer.render(system, view, options);
}

// The light's own diffraction pattern, whole (no recorded image holds its core here), carrying the power unit
// irradiance delivers through the direct path (times --starburst-gain, as in the filter), centred where the
// lens images the light.
void add_light_starburst(const FlareArgs& args, const optics::System& system, const flare::FlareView& view, flare::FlareImage& image) {
    const optics::Paraxial paraxial = optics::paraxial(system);
    const double k = std::numbers::pi / 180.0;
    const double xs = paraxial.efl_mm * std::tan(view.angle_x_deg * k);
    const double ys = paraxial.efl_mm * std::tan(view.angle_y_deg * k);
    const optics::Starburst starburst = optics::make_starburst(system.aperture, starburst_options(args.pupil));
    std::array<double, 3> energy = flare::direct_power(system, view.angle_x_deg, view.angle_y_deg);
    for (double& e : energy) e *= args.starburst_gain;
    const optics::StarburstPlacement at{(xs / view.sensor_width_mm + 0.5) * view.width,
                                        (0.5 - ys / view.sensor_height_mm) * view.height, paraxial.f_number, 0.0};
    optics::draw_starburst(starburst, system.aperture, args.starburst_scale, at, energy,
                           {image.rgb.data(), view.width, view.height, view.sensor_width_mm / view.width, view.sensor_height_mm / view.height});
}

// --list: each ghost's power on the image and their total.
void print_ghost_list(const FlareArgs& args, const optics::System& system, const flare::FlareView& view, const flare::FlareImage& image,
                      double ms) {
    const auto total = image.total_power(view);
    fmt::print("# {} at f/{:.3g}, light ({}, {}) deg, {} ghosts, {} ({:.1f} ms)\n", system.name,
               optics::paraxial(system).f_number, view.angle_x_deg, view.angle_y_deg, image.ghosts.size(),
               args.reference ? fmt::format("reference {}x{} rays", args.rays, args.rays)
                              : fmt::format("gpu grid {}", args.grid),
               ms);
    fmt::print("# surfaces (1-based)   power R         power G         power B        (mm^2 per unit irradiance)\n");
    for (const flare::GhostPower& g : image.ghosts) {
        fmt::print("{:>4},{:<4}            {:<15.6e} {:<15.6e} {:<15.6e}\n", g.second + 1, g.first + 1,
                   g.power[0], g.power[1], g.power[2]);
    }
    fmt::print("total                  {:<15.6e} {:<15.6e} {:<15.6e}\n", total[0], total[1], total[2]);
}

// A physical lens: its ghosts (reference or GPU) and the light's starburst, each as --parts asks and times
// its gain; listed with --list.
void run_flare(const FlareArgs& args) {
    gpu::require_address_space();  // before FFTW (the starburst) or GL, which abort below it
    // A directory (or device, pipe) under an output's name is refused before the render, not after it.
    refuse_special_output(args.output, "-o");
    refuse_special_output(args.preview, "--preview");
    refuse_overwrite(args.preview, "--preview", "", args.output);  // the preview would replace the physical EXR
    for (const std::string* path : {&args.output, &args.preview})
        if (!path->empty()) require_output_format(*path);  // an unknown extension, or a writer of no image file
    if (measured::is_measured_file(args.lens)) return run_measured_flare(args);
    if (args.iso || args.shutter) throw CLI::ValidationError("--iso", "--iso and --shutter apply to measured lenses only");
    const optics::System system = realize_lens(args).system;
    flare::FlareView view = flare_view(args);
    const MemoryBudget memory = checked_memory(args, system, view);
    add_only_ghosts(args, system, view);
    filter::FlareParts parts = filter::parse_parts(args.parts);
    parts.ghosts = parts.ghosts && args.ghost_gain > 0.0;  // as in the filter: a gain of 0 renders nothing
    parts.starburst = parts.starburst && args.starburst_gain > 0.0;
    const auto start = std::chrono::steady_clock::now();
    flare::FlareImage image;
    if (!parts.ghosts) {
        image.width = view.width;
        image.height = view.height;
        image.rgb.assign(static_cast<std::size_t>(view.width) * static_cast<std::size_t>(view.height) * 3, 0.0f);
    } else {
        image = args.reference ? reference_ghosts(args, system, view) : gpu_ghosts(args, system, view, memory);
        if (args.ghost_gain != 1.0) scale_ghosts(image, args.ghost_gain);
    }
    if (parts.starburst) add_light_starburst(args, system, view, image);
    const double ms = ms_since(start);
    if (args.list) print_ghost_list(args, system, view, image, ms);
    write_outputs(image, args);
}

}  // namespace

void register_flare_command(CLI::App& app) {
    auto args = std::make_shared<FlareArgs>();
    auto* cmd = app.add_subcommand("flare", "Render the ghosts of one collimated light of irradiance 1 (sensor irradiance)");
    cmd->add_option("--lens", args->lens, "Preset name or lens file")->required();
    add_lens_options(*cmd, *args, "Flare");
    cmd->add_option("--angle", args->angle, "Light direction AX,AY in degrees (right, up of the view axis)")->required()
        ->check(parsed_by([](const std::string& text) { parse_angle(text); }, "--angle", "AX,AY"));
    cmd->add_option("--sensor", args->sensor, "Sensor width in mm, or WxH (the height follows the image's aspect, else 3:2)")->capture_default_str()->check(sensor_check());
    cmd->add_option("--size", args->size, "Image WxH in pixels (default 960 wide, sensor aspect)")
        ->check(parsed_by([](const std::string& text) { flare_image_size(text); }, "--size", "WxH"));
    cmd->add_option("--wavelength", args->wavelength, "One wavelength (nm) into all channels (default: R 650, G 550, B 450 nm)")
        ->check(CLI::Range(360.0, 830.0))->check(finite_number());
    cmd->add_option("--bands", args->bands, "Spectral bands over 380..780 nm (7..81) into linear Rec.709 through the CIE 1931 functions (0: RGB, 3 wavelengths)")->capture_default_str()
        ->check(bands_check())->excludes("--wavelength");
    cmd->add_flag("--band-filter", args->band_filter, "With --bands: blur each ghost between neighbouring bands (flare paper 4.2); one render per ghost and band")
        ->needs("--bands");
    cmd->add_option("--ghost", args->ghosts, "Only the ghost reflecting at surfaces I,J (1-based; repeatable)");
    cmd->add_flag("--list", args->list, "Print each ghost's power on the image");
    cmd->add_option("--parts", args->parts, "What to render: ghosts, starburst or both (ghosts,starburst)")
        ->capture_default_str();
    cmd->add_option("--starburst-scale", args->starburst_scale,
                    "Starburst length relative to its physical length (the spikes' width stays that of wavelength x f-number)")
        ->capture_default_str()->check(CLI::PositiveNumber);
    filter::add_part_gain_options(*cmd, args->ghost_gain, args->starburst_gain, "Options");
    add_pupil_options(*cmd, args->pupil);
    cmd->add_option("-o,--output", args->output, "Output EXR (float RGB, sensor irradiance)");
    cmd->add_option("--preview", args->preview, "Tone-mapped PNG preview");
    cmd->add_option("--exposure,--preview-exposure", args->preview_exposure, "Exposure in stops before the preview's display transform (default: automatic)")
        ->check(CLI::Range(-64.0, 64.0));
    cmd->add_flag("--reference", args->reference, "Dense CPU reference instead of the GPU");
    cmd->add_option("--rays", args->rays, "Reference: N x N rays per ghost and wavelength")->capture_default_str()->check(CLI::Range(1, 4096));
    cmd->add_option("--grid", args->grid, "GPU: base ray grid cells per side per ghost (the adaptive grid scales it)")
        ->capture_default_str()->check(CLI::Range(2, 2048));
    add_acceleration_options(*cmd, args->accel, "GPU accelerations");
    cmd->add_flag("--ringing", args->ringing, "GPU: shade ghosts by the iris with its diffraction ringing (high quality)");
    cmd->add_option("--flare-look", args->flare_look, "GPU: per-ghost colour, gain and offset, imperfect symmetry (TOML)");
    cmd->add_option("--threads", args->threads, "Worker threads (the CPU reference's; 0: one per core)")->capture_default_str()->check(CLI::Range(0, 1024));
    cmd->add_option("--memory-limit", args->memory_limit, kMemoryLimitHelp)->check(memory_limit_check());
    cmd->add_option("--gpu", args->gpu, "EGL platform: auto, device or surfaceless")
        ->check(CLI::IsMember({"auto", "device", "surfaceless"}))->capture_default_str();
    cmd->add_option("--iso", args->iso, "Measured lenses: the ISO to render for (paper equation 2; default the capture's)")->check(CLI::Range(1.0, 1e7));
    cmd->add_option("--shutter", args->shutter, "Measured lenses: the exposure time in seconds (default the capture's)")->check(CLI::Range(1e-6, 1e5));
    cmd->add_option("--background", args->background, "Add this level to every pixel (a synthetic capture's black level)")->check(CLI::Range(-1e6, 1e6));
    cmd->add_option("--noise", args->noise, "Add Gaussian noise of this standard deviation (a synthetic capture)")->check(CLI::Range(0.0, 1e6));
    cmd->add_option("--seed", args->seed, "Seed of --noise")->capture_default_str();
    cmd->callback([args] {
        if (args->output.empty() && args->preview.empty() && !args->list) {
            throw std::invalid_argument("flare: nothing to do; give -o OUT.exr, --preview OUT.png or --list");
        }
        run_flare(*args);
    });
}

}  // namespace lensfx::filter
