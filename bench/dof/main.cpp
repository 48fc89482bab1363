// bench_dof [--quick] [--no-uniform-skip] [--csv FILE] [--rays N] [--worst N] [--maps DIR]: the lens blur's time against its error. For each scene (a synthetic
// layered scene, a crop of the deep forest) and each quality setting (lens rays per pixel, fixed or "4x":
// up to four times as many where the blur is wide, the rays column then their mean; chromatic or not),
// the GPU trace's milliseconds and its relative L1 error against the dense CPU reference (512 lens
// rays per pixel and channel, every layer of every crossed cell), side by side.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <fmt/core.h>

#include <dof/deep_exr.h>
#include <dof/reference.h>
#include <dof/renderer.h>
#include <gpu/context.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace {

using namespace lensfx;

struct Scene {
    std::string name;
    dof::LayerStack layers;
    double focus_m;
};

// Ground receding from 1.5 to 40 m, a bar at 1 m, bright spots on the ground (bokeh), a sky at 1e9.
Scene synthetic(int w, int h) {
    std::vector<float> rgb(3 * static_cast<std::size_t>(w) * static_cast<std::size_t>(h)), z(static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
            const double v = static_cast<double>(y) / h;
            const bool ground = v > 0.4, bar = x > w / 5 && x < w / 3;
            const double depth = bar ? 1.0 : ground ? 1.5 / std::pow((v - 0.4) / 0.6, 1.5) : 1e9;
            const bool spot = ground && !bar && (x % 23 == 0) && (y % 17 == 0);
            const double checker = ((x / 8 + y / 8) % 2) ? 0.8 : 0.3;
            z[i] = static_cast<float>(std::min(depth, 40.0 + (ground ? 0.0 : 1e9)));
            rgb[3 * i + 0] = static_cast<float>(spot ? 50.0 : bar ? 0.2 : ground ? checker : 0.6);
            rgb[3 * i + 1] = static_cast<float>(spot ? 40.0 : bar ? 0.1 : ground ? checker * 0.9 : 0.7);
            rgb[3 * i + 2] = static_cast<float>(spot ? 20.0 : bar ? 0.1 : ground ? checker * 0.6 : 0.9);
        }
    return {"synthetic", dof::layers_from_flat(rgb.data(), z.data(), w, h), 3.0};
}

std::optional<Scene> forest_crop(int w, int h) {
    const std::string dir = std::string(LENSFX_SHARED_DIR) + "/data/hdr/v2/LowResLeftView/";
    if (!std::filesystem::exists(dir + "Leaves.exr")) return std::nullopt;
    std::vector<dof::DeepImage> parts;
    for (const char* f : {"Balls.exr", "Leaves.exr", "Trunks.exr"}) parts.push_back(dof::read_deep_exr(dir + f, default_memory_budget()));
    const dof::DeepImage all = dof::merge_deep(parts, default_memory_budget());
    const dof::DeepImage crop = dof::reframe(all, all.full_width / 2 - w / 2, all.full_height / 2 - h / 2, w, h);
    return Scene{"forest", dof::layers_from_deep(crop, 0.01), 0.0};  // depth read as centimetres
}

// The n pixels where a and b (RGB, w wide) differ most, with both values: where an error comes from.
void print_worst(const std::vector<float>& a, const std::vector<float>& b, int w, int n) {
    std::vector<std::pair<double, std::size_t>> d;
    for (std::size_t i = 0; i < a.size() / 3; ++i) {
        double e = 0;
        for (std::size_t c = 0; c < 3; ++c) e += std::abs(double{a[3 * i + c]} - double{b[3 * i + c]});
        d.emplace_back(e, i);
    }
    std::sort(d.begin(), d.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
    double total = 0;
    for (const auto& e : d) total += e.first;
    for (int k = 0; k < n && k < static_cast<int>(d.size()); ++k) {
        const std::size_t i = d[static_cast<std::size_t>(k)].second;
        fmt::print("  ({}, {}): {:.3f} of {:.3f} total; gpu {:.3f} {:.3f} {:.3f}, reference {:.3f} {:.3f} {:.3f}\n", static_cast<int>(i) % w,
                   static_cast<int>(i) / w, d[static_cast<std::size_t>(k)].first, total, a[3 * i], a[3 * i + 1], a[3 * i + 2], b[3 * i], b[3 * i + 1], b[3 * i + 2]);
    }
}

// An RGB raster (rows top first) as a PFM file, for previews of the GPU, the reference and their difference.
void write_pfm(const std::string& path, const std::vector<float>& rgb, int w, int h) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) throw std::runtime_error("bench_dof: cannot write " + path);
    fmt::print(f, "PF\n{} {}\n-1.0\n", w, h);
    for (int y = h - 1; y >= 0; --y) std::fwrite(&rgb[3 * static_cast<std::size_t>(y) * static_cast<std::size_t>(w)], sizeof(float), 3 * static_cast<std::size_t>(w), f);
    std::fclose(f);
}

// DIR/SCENE-gpu.pfm, -reference.pfm and -error.pfm (|gpu - reference| per channel).
void write_maps(const std::string& dir, const std::string& scene, const std::vector<float>& gpu, const std::vector<float>& ref, int w, int h) {
    std::vector<float> error(gpu.size());
    for (std::size_t i = 0; i < gpu.size(); ++i) error[i] = std::abs(gpu[i] - ref[i]);
    write_pfm(dir + "/" + scene + "-gpu.pfm", gpu, w, h);
    write_pfm(dir + "/" + scene + "-reference.pfm", ref, w, h);
    write_pfm(dir + "/" + scene + "-error.pfm", error, w, h);
}

double relative_l1(const std::vector<float>& a, const std::vector<float>& b) {
    double d = 0, s = 0;
    for (std::size_t i = 0; i < a.size(); ++i) d += std::abs(double{a[i]} - double{b[i]}), s += std::abs(double{b[i]});
    return d / s;
}

}  // namespace

int main(int argc, char** argv) {
    bool quick = false, skip = true;
    int worst = 0, only_rays = 0;
    std::string csv_path, maps_dir;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--quick") quick = true;
        else if (a == "--no-uniform-skip") skip = false;  // trace every pixel (TraceSettings::uniform_skip)
        else if (a == "--csv" && i + 1 < argc) csv_path = argv[++i];
        else if (a == "--rays" && i + 1 < argc) only_rays = std::stoi(argv[++i]);  // this setting only
        else if (a == "--worst" && i + 1 < argc) worst = std::stoi(argv[++i]);  // list the pixels that differ most
        else if (a == "--maps" && i + 1 < argc) maps_dir = argv[++i];  // PFMs of the chromatic all-rays setting
        else { fmt::print(stderr, "usage: bench_dof [--quick] [--no-uniform-skip] [--csv FILE] [--rays N] [--worst N] [--maps DIR]\n"); return 2; }
    }
    const int w = quick ? 128 : 256, h = quick ? 72 : 144;
    std::vector<Scene> scenes{synthetic(w, h)};
    if (auto f = forest_crop(w, h)) {
        // focus on the near cones (the README's first focus)
        f->focus_m = 0.8;
        scenes.push_back(std::move(*f));
    }
    gpu::Context context;
    dof::Renderer renderer;
    std::FILE* csv = csv_path.empty() ? nullptr : std::fopen(csv_path.c_str(), "w");
    if (csv) fmt::print(csv, "scene,lens,fstop,focus_m,setting,rays,chromatic,ms,rel_l1,ref_ms\n");
    fmt::print("{:<10} {:<18} {:>8} {:>6} {:>9} {:>10} {:>9}\n", "scene", "lens", "setting", "rays", "gpu ms", "rel L1", "ref ms");
    for (const Scene& scene : scenes) {
        dof::Camera cam;
        cam.system = optics::realize(optics::load_lens("mld-double-gauss"), 0.0, 2.8);
        cam.focus_m = scene.focus_m;
        cam.width = w, cam.height = h;
        cam.centre_x = 0.5 * w, cam.centre_y = 0.5 * h;
        cam.sensor_width_mm = 36.0 * w / 1024.0;  // the crop of a full-frame 1024-pixel-wide sensor
        const dof::RayTable table = dof::make_ray_table(cam, quick ? 256 : 512, 9);
        auto t0 = std::chrono::steady_clock::now();
        const std::vector<float> ref = dof::render_reference(scene.layers, table);
        const double ref_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        // fixed counts, then the adaptive ones (lensfx's default: up to 4x where the blur is wide)
        std::vector<std::pair<int, bool>> settings;
        for (int rays : {4, 8, 16, 32, 64, table.samples}) settings.emplace_back(rays, false);
        for (int rays : {8, 16, 32}) settings.emplace_back(rays, true);
        for (bool chromatic : {false, true}) {
            for (const auto& [rays, adaptive] : settings) {
                if (only_rays != 0 && rays != only_rays) continue;
                dof::TraceSettings s;
                s.rays = rays, s.chromatic = chromatic, s.uniform_skip = skip;
                s.max_rays = adaptive ? 4 * rays : 0;
                renderer.render(scene.layers, table, s);  // warm
                const std::vector<float> out = renderer.render(scene.layers, table, s);
                const double err = relative_l1(out, ref);
                const std::string setting = std::string(chromatic ? "rgb" : "green") + (adaptive ? " 4x" : "");
                fmt::print("{:<10} {:<18} {:>8} {:>6.0f} {:>9.1f} {:>10.4f} {:>9.0f}\n", scene.name, "mld-double-gauss", setting, renderer.last_rays(), renderer.last_ms(),
                           err, ref_ms);
                if (rays == table.samples) print_worst(out, ref, w, worst);
                if (rays == table.samples && chromatic && !maps_dir.empty()) write_maps(maps_dir, scene.name, out, ref, w, h);
                if (csv)
                    fmt::print(csv, "{},mld-double-gauss,2.8,{},{},{:.1f},{},{:.2f},{:.5f},{:.0f}\n", scene.name, scene.focus_m, setting, renderer.last_rays(), chromatic ? 1 : 0,
                               renderer.last_ms(), err, ref_ms);
            }
        }
    }
    if (csv) std::fclose(csv);
    return 0;
}
