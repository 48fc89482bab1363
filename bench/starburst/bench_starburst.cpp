// Prints how long a starburst texture takes to compute (it is cached per iris) for several iris shapes
// and sizes, clean and with dust or scratches, and writes a tone-mapped PNG preview of each: bench_starburst [OUT_DIR].
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>
#include <fmt/core.h>

#include <optics/ringing.h>
#include <optics/starburst.h>

using namespace lensfx::optics;

int main(int argc, char** argv) {
    const std::string dir = argc > 1 ? argv[1] : ".";
    struct Case { const char* name; Aperture aperture; int size; int samples; PupilImperfections dirt; };
    PupilImperfections dusty;
    dusty.dust_density = 150.0;
    dusty.dust_radius = 0.015;
    PupilImperfections scratched;
    scratched.scratches = 12;
    scratched.scratch_length = 0.6;
    scratched.scratch_width = 0.01;
    scratched.scratch_angle_deg = 30.0;
    scratched.scratch_spread_deg = 40.0;
    const std::vector<Case> cases = {
        {"round", {0, 0.0, 0.0}, 512, 96, {}}, {"blades6", {6, 0.0, 0.0}, 512, 96, {}},
        {"blades7", {7, 10.0, 0.0}, 512, 96, {}}, {"blades9_curved", {9, 0.0, 0.5}, 512, 96, {}},
        {"blades6_1024", {6, 0.0, 0.0}, 1024, 192, {}}, {"blades6_dust", {6, 0.0, 0.0}, 512, 96, dusty},
        {"blades6_scratches", {6, 0.0, 0.0}, 512, 96, scratched}};
    fmt::print("starburst texture: size, pupil samples, ms to compute (380-780 nm, 5 nm steps)\n");
    for (const Case& c : cases) {
        StarburstOptions o;
        o.size = c.size;
        o.pupil_samples = c.samples;
        o.dirt = c.dirt;
        const auto t0 = std::chrono::steady_clock::now();
        const Starburst s = make_starburst(c.aperture, o);
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        fmt::print("{:16s} {:5d} {:4d} {:9.1f} ms   texel at f/8: {:.2f} um\n", c.name, c.size, c.samples, ms,
                   s.texel_per_fnumber_mm * 8e3);
        // Preview: log-scaled so the spikes show, normalised to the centre.
        std::vector<unsigned char> png(s.rgb.size());
        const double peak = std::max({s.at(s.size / 2, s.size / 2, 0), s.at(s.size / 2, s.size / 2, 1), s.at(s.size / 2, s.size / 2, 2)});
        for (std::size_t i = 0; i < s.rgb.size(); ++i) {
            const double v = std::log10(std::max(1e-12, static_cast<double>(s.rgb[i]) / peak));  // -7..0
            png[i] = static_cast<unsigned char>(std::clamp((v + 7.0) / 7.0, 0.0, 1.0) * 255.0 + 0.5);
        }
        const std::string path = fmt::format("{}/starburst_{}.png", dir, c.name);
        auto out = OIIO::ImageOutput::create(path);
        if (!out || !out->open(path, OIIO::ImageSpec(s.size, s.size, 3, OIIO::TypeDesc::UINT8)) ||
            !out->write_image(OIIO::TypeDesc::UINT8, png.data())) {
            fmt::print(stderr, "bench_starburst: cannot write {}\n", path);
            return 1;
        }
        out->close();
    }
    // Ghost ringing textures (eq. 5 orders for 650 nm at f/4, f/11 and f/22), linear preview, 1 = grey 170.
    fmt::print("ringing texture (512^2 over +-1.25 stop radii): order, ms to compute\n");
    for (double f_number : {4.0, 11.0, 22.0}) {
        const double alpha = ringing_order(650.0, f_number);
        const auto t0 = std::chrono::steady_clock::now();
        const std::vector<float> ring = ringing_aperture(Aperture{6, 0.0, 0.0}, 512, 1.25, alpha);
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        fmt::print("f/{:<5g} alpha {:.4f} {:9.1f} ms\n", f_number, alpha, ms);
        std::vector<unsigned char> png(ring.size());
        for (std::size_t i = 0; i < ring.size(); ++i)
            png[i] = static_cast<unsigned char>(std::clamp(static_cast<double>(ring[i]) / 1.5, 0.0, 1.0) * 255.0 + 0.5);
        const std::string path = fmt::format("{}/ringing_f{:g}.png", dir, f_number);
        auto out = OIIO::ImageOutput::create(path);
        if (!out || !out->open(path, OIIO::ImageSpec(512, 512, 1, OIIO::TypeDesc::UINT8)) ||
            !out->write_image(OIIO::TypeDesc::UINT8, png.data())) {
            fmt::print(stderr, "bench_starburst: cannot write {}\n", path);
            return 1;
        }
        out->close();
    }
    return 0;
}
