// bench_spectral: for one lens and light, milliseconds per GPU flare at each quality level (RGB, N bands,
// N bands with the band filter) next to its error against a many-band image: per-channel total power,
// relative L1, L1 of the shapes (each channel scaled to the reference's power) and the edge content
// (total variation over total; the reference's is printed on its row).
//   bench_spectral [--lens NAME] [--angle AX,AY] [--size WxH] [--grid N] [--reference-bands N]
//                  [--bands 0,7,16,...] [--filtered 7,...] [--gpu auto|device|surfaceless]
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/core.h>
#include <gpu/band_filter.h>
#include <gpu/context.h>
#include <flare/flare.h>
#include <gpu/flare_renderer.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace {

using namespace lensfx;
using Clock = std::chrono::steady_clock;

std::vector<int> parse_list(const std::string& text) {
    std::vector<int> out;
    std::stringstream in(text);
    std::string item;
    while (std::getline(in, item, ',')) out.push_back(std::stoi(item));
    return out;
}

struct Errors {
    std::array<double, 3> power{};
    double l1 = 0.0, shape_l1 = 0.0, edges = 0.0;
};

Errors compare(const flare::FlareImage& a, const flare::FlareImage& ref, const flare::FlareView& view) {
    Errors e;
    const auto pa = a.total_power(view), pr = ref.total_power(view);
    for (std::size_t c = 0; c < 3; ++c) {
        e.power[c] = (pa[c] - pr[c]) / pr[c];
        double diff = 0.0, shape = 0.0, total = 0.0;
        for (std::size_t i = c; i < a.rgb.size(); i += 3) {
            const double va = a.rgb[i], vr = ref.rgb[i];
            diff += std::abs(va - vr);
            shape += std::abs(va * pr[c] / pa[c] - vr);
            total += std::abs(vr);
        }
        e.l1 = std::max(e.l1, diff / total);
        e.shape_l1 = std::max(e.shape_l1, shape / total);
    }
    e.edges = a.edge_measure();
    return e;
}

}  // namespace

int main(int argc, char** argv) try {
    std::string lens = "cooke-triplet", gpu_platform = "auto";
    double ax = 8.0, ay = 5.0;
    int width = 180, height = 120, grid = 96, reference_bands = 81;
    std::vector<int> bands = {0, 7, 16, 24, 40}, filtered = {7, 16};
    for (int i = 1; i + 1 < argc; i += 2) {
        const std::string k = argv[i], v = argv[i + 1];
        if (k == "--lens") lens = v;
        else if (k == "--angle") std::sscanf(v.c_str(), "%lf,%lf", &ax, &ay);
        else if (k == "--size") std::sscanf(v.c_str(), "%dx%d", &width, &height);
        else if (k == "--grid") grid = std::stoi(v);
        else if (k == "--reference-bands") reference_bands = std::stoi(v);
        else if (k == "--bands") bands = parse_list(v);
        else if (k == "--filtered") filtered = parse_list(v);
        else if (k == "--gpu") gpu_platform = v;
        else throw std::invalid_argument("unknown option " + k);
    }
    const optics::System system = optics::realize(optics::load_lens(lens));
    const gpu::Context context(gpu::parse_platform(gpu_platform));
    gpu::FlareRenderer renderer(context);
    gpu::GpuFlareOptions options;
    options.grid = grid;
    flare::FlareView view;
    view.angle_x_deg = ax;
    view.angle_y_deg = ay;
    view.width = width;
    view.height = height;
    const auto render = [&](const flare::FlareView& v, bool filter, double& ms) {
        const auto t0 = Clock::now();
        flare::FlareImage image = filter ? gpu::render_band_filtered(system, v, gpu::render_one_on(renderer, system, options))
                                       : renderer.render(system, v, options);
        ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        return image;
    };
    fmt::print("# {} light ({}, {}) deg, {}x{}, grid {}, {} ({})\n", system.name, ax, ay, width, height, grid,
               context.info().gl_renderer, gpu::platform_name(context.info().platform));
    double ms = 0.0;
    flare::FlareView rv = view;
    rv.bands = reference_bands;
    const flare::FlareImage reference = render(rv, false, ms);
    fmt::print("{:<22} {:>10} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}\n", "quality", "ms", "power R", "power G", "power B", "L1",
               "shape L1", "edges");
    fmt::print("{:<22} {:>10.0f} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9.4f}\n", fmt::format("{} bands (reference)", reference_bands),
               ms, "-", "-", "-", "-", "-", reference.edge_measure());
    const auto row = [&](const std::string& name, const flare::FlareView& v, bool filter) {
        const flare::FlareImage image = render(v, filter, ms);
        const Errors e = compare(image, reference, view);
        fmt::print("{:<22} {:>10.0f} {:>+9.4f} {:>+9.4f} {:>+9.4f} {:>9.4f} {:>9.4f} {:>9.4f}\n", name, ms, e.power[0], e.power[1],
                   e.power[2], e.l1, e.shape_l1, e.edges);
        std::fflush(stdout);
    };
    for (int b : bands) {
        flare::FlareView v = view;
        v.bands = b;
        row(b == 0 ? "RGB" : fmt::format("{} bands", b), v, false);
    }
    for (int b : filtered) {
        flare::FlareView v = view;
        v.bands = b;
        row(fmt::format("{} bands filtered", b), v, true);
    }
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "bench_spectral: %s\n", e.what());
    return 1;
}
