// bench_dof_peer: the error of finished lens-blur frames (lensfx's, a peer's such as Blender's Defocus node)
// against lensfx's dense CPU reference on a crop of the same input (docs/dof.md, "Against Blender").
//   bench_dof_peer --input IN.exr --lens L --fstop N --focus M --crop X,Y,W,H [--rays 256] [--margin 32]
//                  [--reference-out REF.exr] RESULT.exr ...
// IN: R, G, B, Z over its display window (data window = display window); the reference traces the crop and
// a margin around it (the blur's reach) with the lens's rays through the prescription, and each RESULT's
// relative L1 over R, G, B of the crop is printed.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <fmt/core.h>

#include <dof/layers.h>
#include <dof/reference.h>
#include <optics/lens_file.h>
#include <optics/system.h>

namespace {

using namespace lensfx;

// Channels of an EXR over its display window (0 outside the data window), one plane each.
struct Planes {
    int width = 0, height = 0;
    std::vector<std::vector<float>> planes;
};

Planes read_planes(const std::string& path, const std::vector<std::string>& names) {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i disp = file.header().displayWindow(), data = file.header().dataWindow();
    Planes p;
    p.width = disp.max.x - disp.min.x + 1, p.height = disp.max.y - disp.min.y + 1;
    const auto w = static_cast<std::size_t>(p.width);
    Imf::FrameBuffer fb;
    for (const std::string& n : names) {
        p.planes.emplace_back(w * static_cast<std::size_t>(p.height), 0.0f);
        char* base = reinterpret_cast<char*>(p.planes.back().data()) -
                     (static_cast<std::ptrdiff_t>(disp.min.y) * static_cast<std::ptrdiff_t>(w) + disp.min.x) * static_cast<std::ptrdiff_t>(sizeof(float));
        fb.insert(n, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * w));
    }
    file.setFrameBuffer(fb);
    file.readPixels(data.min.y, data.max.y);
    return p;
}

void write_rgb(const std::string& path, int w, int h, const std::vector<float>& rgb) {
    Imf::Header header(w, h);
    Imf::FrameBuffer fb;
    const char* names[] = {"R", "G", "B"};
    for (std::size_t c = 0; c < 3; ++c) {
        header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
        fb.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(rgb.data() + c)), 3 * sizeof(float),
                                       3 * sizeof(float) * static_cast<std::size_t>(w)));
    }
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(h);
}

struct Options {
    std::string input, lens, reference_out;
    double fstop = 2.8, focus_m = 3.0;
    int x = 0, y = 0, w = 0, h = 0, rays = 256, margin = 32;
    std::vector<std::string> results;
};

Options parse(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto next = [&] { return i + 1 < argc ? std::string(argv[++i]) : throw std::runtime_error(a + " needs a value"); };
        if (a == "--input") o.input = next();
        else if (a == "--lens") o.lens = next();
        else if (a == "--fstop") o.fstop = std::stod(next());
        else if (a == "--focus") o.focus_m = std::stod(next());
        else if (a == "--rays") o.rays = std::stoi(next());
        else if (a == "--margin") o.margin = std::stoi(next());
        else if (a == "--reference-out") o.reference_out = next();
        else if (a == "--crop") {
            if (std::sscanf(next().c_str(), "%d,%d,%d,%d", &o.x, &o.y, &o.w, &o.h) != 4) throw std::runtime_error("--crop X,Y,W,H");
        } else o.results.push_back(a);
    }
    if (o.input.empty() || o.lens.empty() || o.w < 1 || o.h < 1) throw std::runtime_error("--input, --lens and --crop are needed");
    return o;
}

double relative_l1(const std::vector<float>& a, const std::vector<float>& b) {
    double d = 0, s = 0;
    for (std::size_t i = 0; i < a.size(); ++i) d += std::abs(double{a[i]} - double{b[i]}), s += std::abs(double{b[i]});
    return d / s;
}

// R, G, B of a frame's crop (x, y, w, h), interleaved.
std::vector<float> crop_rgb(const Planes& p, int x, int y, int w, int h) {
    std::vector<float> out(3 * static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0.0f);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const int sx = x + i, sy = y + j;
            if (sx < 0 || sy < 0 || sx >= p.width || sy >= p.height) continue;
            const std::size_t src = static_cast<std::size_t>(sy) * static_cast<std::size_t>(p.width) + static_cast<std::size_t>(sx);
            for (std::size_t c = 0; c < 3; ++c) out[3 * (static_cast<std::size_t>(j) * static_cast<std::size_t>(w) + static_cast<std::size_t>(i)) + c] = p.planes[c][src];
        }
    return out;
}

}  // namespace

int main(int argc, char** argv) try {
    const Options o = parse(argc, argv);
    const Planes in = read_planes(o.input, {"R", "G", "B", "Z"});
    const int x0 = o.x - o.margin, y0 = o.y - o.margin, w = o.w + 2 * o.margin, h = o.h + 2 * o.margin;
    const std::vector<float> rgb = crop_rgb(in, x0, y0, w, h);
    std::vector<float> z(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0.0f);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
            if (x0 + i >= 0 && y0 + j >= 0 && x0 + i < in.width && y0 + j < in.height)
                z[static_cast<std::size_t>(j * w + i)] = in.planes[3][static_cast<std::size_t>(y0 + j) * static_cast<std::size_t>(in.width) + static_cast<std::size_t>(x0 + i)];
    dof::Camera cam;
    cam.system = optics::realize(optics::load_lens(o.lens), 0.0, o.fstop);
    cam.focus_m = o.focus_m;
    cam.width = w, cam.height = h, cam.display_width = in.width;
    cam.centre_x = 0.5 * in.width - x0, cam.centre_y = 0.5 * in.height - y0;
    const dof::RayTable table = dof::make_ray_table(cam, o.rays, 9);
    dof::FlatLayerOptions layer_options;
    layer_options.hidden_radius_px = std::min(64.0, o.margin + 2.0);
    const dof::LayerStack layers = dof::layers_from_flat(rgb.data(), z.data(), w, h, layer_options);
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<float> ref_all = dof::render_reference(layers, table);
    const double ref_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::vector<float> ref(3 * static_cast<std::size_t>(o.w) * static_cast<std::size_t>(o.h));
    for (int j = 0; j < o.h; ++j)
        for (int i = 0; i < o.w; ++i)
            for (std::size_t c = 0; c < 3; ++c)
                ref[3 * (static_cast<std::size_t>(j) * static_cast<std::size_t>(o.w) + static_cast<std::size_t>(i)) + c] =
                    ref_all[3 * (static_cast<std::size_t>(j + o.margin) * static_cast<std::size_t>(w) + static_cast<std::size_t>(i + o.margin)) + c];
    if (!o.reference_out.empty()) write_rgb(o.reference_out, o.w, o.h, ref);
    fmt::print("reference: {}x{} crop at {},{} of {} ({} lens rays per pixel and channel, {:.1f} s); plate itself: rel L1 {:.4f}\n", o.w, o.h,
               o.x, o.y, o.input, o.rays, ref_s, relative_l1(crop_rgb(in, o.x, o.y, o.w, o.h), ref));
    for (const std::string& r : o.results)
        fmt::print("{}: rel L1 {:.4f}\n", r, relative_l1(crop_rgb(read_planes(r, {"R", "G", "B"}), o.x, o.y, o.w, o.h), ref));
    return 0;
} catch (const std::exception& e) {
    fmt::print(stderr, "bench_dof_peer: {}\n", e.what());
    return 1;
}
