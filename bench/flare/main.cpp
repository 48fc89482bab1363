// bench_flare: for each lens preset, the number of ghosts, milliseconds per flare on the GPU at the
// default grid (RGB and one wavelength) and for the dense CPU reference, and the GPU image's error
// against the reference (total power, worst ghost over 1% of the total, 8x8-block relative L1), and its
// structure error: the gradient-domain relative L1 (flare::gradient_error) of the default RGB render against
// one at grid --structure-grid (512) with every acceleration off (0: not computed).
//   bench_flare [--presets a,b,...] [--angle AX,AY] [--fstop F] [--size WxH] [--grid N] [--rays N]
//               [--repeat K] [--gpu auto|device|surfaceless] [--ref-bounds 0|1] [--structure-grid N]
//               [--full-target-bytes B] [--ghost I,J] [--dump DIR]
// --ghost I,J: only the ghost reflecting at surfaces I, J (1-based, as `lensfx flare --ghost`), to find
// which ghost carries an error. --dump DIR: the default RGB render and the structure error's reference
// written as DIR/PRESET-default.exr and DIR/PRESET-reference.exr, to look at.
// --full-target-bytes: the full-size GL target's band limit (GpuFlareOptions::full_target_bytes; 0: one
// whole target), to time the banded target of big frames against one whole target.
// --ref-bounds 1: the reference's rays cover each ghost's pupil bounds (ReferenceOptions::ghost_bounds),
// so small ghosts of big zooms get enough rays. --rays 0: times only, no reference (nor error figures),
// and the fewest ms of CPU (all threads) an RGB render took.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <exception>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <filter/image_io.h>
#include <fmt/core.h>
#include <gpu/acceleration.h>
#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/presets.h>
#include <optics/stopwatch.h>
#include <optics/system.h>
#include <optics/text_pairs.h>

namespace {

using Clock = std::chrono::steady_clock;
using lensfx::ms_since;

// CPU time of the whole process (llvmpipe's threads included), in ms: on a shared machine less disturbed
// by others' work than the wall time.
double process_cpu_ms() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) / 1e6;
}

// Reads the two numbers of an option's "A<sep>B" value into a and b; throws naming the option when it is not that.
template <typename T>
void read_pair(const std::string& key, const std::string& value, char sep, T& a, T& b) {
    const auto pair = lensfx::parse_pair_of<T>(value, sep);
    if (!pair) throw std::invalid_argument(fmt::format("{} {}: give two numbers as A{}B", key, value, sep));
    a = (*pair)[0];
    b = (*pair)[1];
}

std::vector<std::string> split(const std::string& text, char sep) {
    std::vector<std::string> out;
    std::stringstream in(text);
    for (std::string item; std::getline(in, item, sep);) {
        if (!item.empty()) out.push_back(item);
    }
    return out;
}

// A flare render written as a float RGB EXR.
void write_flare(const lensfx::flare::FlareImage& image, const std::string& path) {
    lensfx::filter::write_image(
        lensfx::filter::image_frame(image.width, image.height, 3, lensfx::filter::PixelType::float32, image.rgb.data()), path);
}

}  // namespace

int main(int argc, char** argv) try {
    std::vector<std::string> presets = lensfx::optics::preset_names();
    double ax = 8.0;
    double ay = 5.0;
    std::optional<double> fstop;
    int width = 240;
    int height = 160;
    int grid = lensfx::gpu::GpuFlareOptions{}.grid;
    double full_target_bytes = lensfx::gpu::GpuFlareOptions{}.full_target_bytes;
    int rays = 400;
    int repeat = 3;
    std::string platform = "auto";
    bool ref_bounds = false;
    int structure_grid = 512;
    std::vector<std::pair<int, int>> only_ghosts;
    std::string dump_dir;
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string key = argv[i];
        const std::string value = argv[i + 1];
        if (key == "--presets") presets = split(value, ',');
        else if (key == "--angle") read_pair(key, value, ',', ax, ay);
        else if (key == "--fstop") fstop = std::stod(value);
        else if (key == "--size") read_pair(key, value, 'x', width, height);
        else if (key == "--grid") grid = std::stoi(value);
        else if (key == "--rays") rays = std::stoi(value);
        else if (key == "--full-target-bytes") full_target_bytes = std::stod(value);
        else if (key == "--repeat") repeat = std::max(1, std::stoi(value));
        else if (key == "--gpu") platform = value;
        else if (key == "--ref-bounds") ref_bounds = value == "1";
        else if (key == "--structure-grid") structure_grid = std::stoi(value);
        else if (key == "--ghost") { const auto v = split(value, ','); only_ghosts.emplace_back(std::stoi(v.at(0)) - 1, std::stoi(v.at(1)) - 1); }
        else if (key == "--dump") dump_dir = value;
        else throw std::invalid_argument("unknown option " + key);
    }

    const lensfx::gpu::Context context(lensfx::gpu::parse_platform(platform));
    lensfx::gpu::FlareRenderer renderer(context);
    fmt::print("# {} | {} | light ({}, {}) deg | {}x{} px | GPU grid {} | reference {}x{} rays{}, 2 threads\n",
               context.info().gl_renderer, lensfx::gpu::platform_name(context.info().platform), ax, ay, width,
               height, grid, rays, rays, ref_bounds ? " over each ghost's bounds" : "");
    fmt::print("# error of the GPU image against the reference at 550 nm (total power, worst ghost > 1% and its surfaces, 8x8 L1)\n");
    fmt::print("# struct: gradient L1 of the default RGB render against grid {} without accelerations\n", structure_grid);
    fmt::print("{:<24} {:>6} {:>6} {:>11} {:>11} {:>12} {:>8} {:>8} {:>8} {:>8} {:>8}\n", "preset", "f/", "ghosts",
               "gpu_rgb_ms", "gpu_1wl_ms", "ref_1wl_ms", "total%", "ghost%", "worst", "L1%", "struct");
    for (const std::string& name : presets) {
        try {
            const lensfx::optics::Lens lens = lensfx::optics::load_lens(name);
            const lensfx::optics::System system = lensfx::optics::realize(lens, 0.0, fstop);
            lensfx::flare::FlareView view;
            view.angle_x_deg = ax;
            view.angle_y_deg = ay;
            view.width = width;
            view.height = height;
            view.only_ghosts = only_ghosts;
            const std::size_t ghosts = lensfx::optics::ghost_count(system);
            lensfx::gpu::GpuFlareOptions options;
            options.grid = grid;
            options.full_target_bytes = full_target_bytes;
            const lensfx::flare::FlareImage rgb_image = renderer.render(system, view, options);  // also the warm-up
            if (!dump_dir.empty()) write_flare(rgb_image, dump_dir + "/" + name + "-default.exr");
            double structure = -1.0;
            if (structure_grid > 0) {
                lensfx::gpu::GpuFlareOptions dense;
                dense.grid = structure_grid;
                dense.accel.bounding = lensfx::gpu::Bounding::None;
                dense.accel.adaptive = dense.accel.lod = dense.accel.reduced = false;
                const lensfx::flare::FlareImage reference = renderer.render(system, view, dense);
                structure = lensfx::flare::gradient_error(rgb_image, reference);
                if (!dump_dir.empty()) write_flare(reference, dump_dir + "/" + name + "-reference.exr");
            }
            double rgb_ms = 1e300;
            double rgb_cpu_ms = 1e300;
            for (int k = 0; k < repeat; ++k) {
                const auto start = Clock::now();
                const double cpu_start = process_cpu_ms();
                renderer.render(system, view, options);
                rgb_ms = std::min(rgb_ms, ms_since(start));
                rgb_cpu_ms = std::min(rgb_cpu_ms, process_cpu_ms() - cpu_start);
            }
            view.wavelength_nm = 550.0;
            double one_ms = 1e300;
            for (int k = 0; k < repeat; ++k) {
                const auto start = Clock::now();
                renderer.render(system, view, options);
                one_ms = std::min(one_ms, ms_since(start));
            }
            if (rays <= 0) {
                fmt::print("{:<24} {:>6.2f} {:>6} {:>11.1f} {:>11.1f}   rgb cpu {:.1f} ms   struct {:.3f}\n", name,
                           lensfx::optics::paraxial(system).f_number, ghosts, rgb_ms, one_ms, rgb_cpu_ms, structure);
                std::fflush(stdout);
                continue;
            }
            options.per_ghost_power = true;
            const lensfx::flare::FlareImage gpu_image = renderer.render(system, view, options);
            lensfx::flare::ReferenceOptions ref_options;
            ref_options.rays = rays;
            ref_options.ghost_bounds = ref_bounds;
            const auto start = Clock::now();
            const lensfx::flare::FlareImage reference = lensfx::flare::render_reference(system, view, ref_options);
            const double ref_ms = ms_since(start);
            const lensfx::flare::FlareError error = lensfx::flare::compare_flare(gpu_image, reference, view);
            fmt::print("{:<24} {:>6.2f} {:>6} {:>11.1f} {:>11.1f} {:>12.1f} {:>8.2f} {:>8.2f} {:>8} {:>8.2f} {:>8.3f}\n",
                       name, lensfx::optics::paraxial(system).f_number, ghosts, rgb_ms, one_ms, ref_ms,
                       100 * error.total, 100 * error.worst_ghost,
                       fmt::format("{},{}", error.worst.second + 1, error.worst.first + 1), 100 * error.block_l1, structure);
            std::fflush(stdout);
        } catch (const std::exception& e) {
            fmt::print("{:<24} failed: {}\n", name, e.what());
        }
    }
    return 0;
} catch (const std::exception& e) {
    fmt::print(stderr, "bench_flare: {}\n", e.what());
    return 1;
}
