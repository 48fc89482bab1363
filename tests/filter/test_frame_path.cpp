// The flare filter's frame path end to end (llvmpipe): --layer beside the original channels, the data
// window growing where the flare lands, --min-light, the footprint of an extended source, per-part times
// in --report, flicker of a light moving in sub-pixel steps, and the same output with any thread count.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <utility>
#include <string>
#include <vector>

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <gtest/gtest.h>

#include "run_lensfx.h"
#include <nlohmann/json.hpp>

#include <filter/flare_stage.h>
#include <optics/lens_file.h>
#include <optics/paraxial.h>
#include <optics/system.h>

namespace fs = std::filesystem;
using namespace lensfx;

namespace {

fs::path temp_dir(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / ("lensfx_frame_path_e2e_" + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

struct Disc {
    double x, y, radius, value;
};

// A 320x200 display window, dim grey over the data window (x, y, w, h), with Gaussian-edged discs.
void write_frame(const fs::path& path, const std::vector<Disc>& discs, OIIO::ROI data = OIIO::ROI(0, 320, 0, 200)) {
    OIIO::ImageSpec spec(data.width(), data.height(), 3, OIIO::TypeDesc::HALF);
    spec.x = data.xbegin;
    spec.y = data.ybegin;
    spec.full_x = 0;
    spec.full_y = 0;
    spec.full_width = 320;
    spec.full_height = 200;
    OIIO::ImageBuf buf(spec);
    for (int j = data.ybegin; j < data.yend; ++j)
        for (int i = data.xbegin; i < data.xend; ++i) {
            double v = 0.05;
            for (const Disc& d : discs) {
                const double r = std::hypot(i + 0.5 - d.x, j + 0.5 - d.y);
                v += d.value * std::exp(-std::pow(r / d.radius, 8.0));
            }
            const float px[3] = {static_cast<float>(v), static_cast<float>(v), static_cast<float>(v)};
            buf.setpixel(i, j, px);
        }
    ASSERT_TRUE(buf.write(path.string()));
}

struct Image {
    OIIO::ImageSpec spec;
    std::vector<float> px;  // every channel, data window
    float at(int x, int y, int c) const {
        return px[(static_cast<std::size_t>(y - spec.y) * static_cast<std::size_t>(spec.width) +
                   static_cast<std::size_t>(x - spec.x)) * static_cast<std::size_t>(spec.nchannels) + static_cast<std::size_t>(c)];
    }
    int channel(const std::string& name) const {
        const auto it = std::find(spec.channelnames.begin(), spec.channelnames.end(), name);
        return it == spec.channelnames.end() ? -1 : static_cast<int>(it - spec.channelnames.begin());
    }
    double sum(int c) const {
        double s = 0.0;
        for (std::size_t i = static_cast<std::size_t>(c); i < px.size(); i += static_cast<std::size_t>(spec.nchannels))
            s += static_cast<double>(px[i]);
        return s;
    }
};

Image read(const fs::path& path) {
    OIIO::ImageBuf buf(path.string());
    EXPECT_TRUE(buf.read(0, 0, true, OIIO::TypeDesc::FLOAT)) << path;
    Image im{buf.spec(), {}};
    im.px.resize(static_cast<std::size_t>(im.spec.width) * static_cast<std::size_t>(im.spec.height) *
                 static_cast<std::size_t>(im.spec.nchannels));
    buf.get_pixels(buf.roi(), OIIO::TypeDesc::FLOAT, im.px.data());
    return im;
}

// Runs lensfx with its caches in a scratch directory, never the user's.
int run(const std::string& args) {
    const std::string cache = (fs::temp_directory_path() / "lensfx_frame_path_e2e_cache").string();
    return lensfx::test::run_lensfx_status(args + " 2>&1", cache);
}

const std::string kLensOnly = " --lens brendel-tessar --fstop 4 --grid 32 -q";
const std::string kLens = kLensOnly + " --threshold 100";

// The same flux at (x, y) as a small light of radius 2 px (dir/small.exr) and as a disc of radius kBigR (a
// window, dir/big.exr).
constexpr double kSmallR = 2.0, kBigR = 24.0;
void write_small_and_big_light(const fs::path& dir, double x, double y) {
    write_frame(dir / "small.exr", {{x, y, kSmallR, 20000.0}});
    write_frame(dir / "big.exr", {{x, y, kBigR, 20000.0 * kSmallR * kSmallR / (kBigR * kBigR)}});
}

// The light a plate's source pixels (green over 1) hold above its 0.05 background.
double source_flux(const Image& in) {
    double sum = 0.0;
    for (std::size_t i = 1; i < in.px.size(); i += 3)
        if (in.px[i] > 1.0f) sum += static_cast<double>(in.px[i]) - 0.05;
    return sum;
}

}  // namespace

TEST(FramePath, LayerHoldsTheFlareBesideUntouchedRgb) {
    const fs::path dir = temp_dir("layer");
    write_frame(dir / "in.exr", {{230.3, 60.6, 2.0, 20000.0}});
    ASSERT_EQ(run("-i " + (dir / "in.exr").string() + " -o " + (dir / "only.exr").string() + " --flare-only" + kLens), 0);
    ASSERT_EQ(run("-i " + (dir / "in.exr").string() + " -o " + (dir / "layer.exr").string() + " --layer flare" + kLens), 0);
    const Image in = read(dir / "in.exr"), only = read(dir / "only.exr"), layer = read(dir / "layer.exr");
    ASSERT_EQ(layer.spec.nchannels, 6);
    const int fr = layer.channel("flare.R"), fg = layer.channel("flare.G"), fb = layer.channel("flare.B");
    ASSERT_GE(fr, 0);
    ASSERT_GE(fg, 0);
    ASSERT_GE(fb, 0);
    double flare = 0.0;
    for (int y = 0; y < 200; ++y)
        for (int x = 0; x < 320; ++x) {
            for (int c = 0; c < 3; ++c) ASSERT_EQ(layer.at(x, y, layer.channel(std::string(1, "RGB"[c]))), in.at(x, y, c));
            ASSERT_EQ(layer.at(x, y, fr), only.at(x, y, 0));
            ASSERT_EQ(layer.at(x, y, fg), only.at(x, y, 1));
            ASSERT_EQ(layer.at(x, y, fb), only.at(x, y, 2));
            flare += static_cast<double>(only.at(x, y, 1));
        }
    EXPECT_GT(flare, 0.0);
}

TEST(FramePath, DataWindowGrowsWhereTheFlareLands) {
    const fs::path dir = temp_dir("window");
    // The light is inside a small data window at the upper right; its ghosts fall across the frame.
    write_frame(dir / "in.exr", {{250.3, 50.6, 2.0, 20000.0}}, OIIO::ROI(200, 300, 20, 90));
    ASSERT_EQ(run("-i " + (dir / "in.exr").string() + " -o " + (dir / "out.exr").string() + kLens), 0);
    const Image in = read(dir / "in.exr"), out = read(dir / "out.exr");
    EXPECT_EQ(out.spec.full_width, 320);
    EXPECT_EQ(out.spec.full_height, 200);
    EXPECT_LE(out.spec.x, 200);
    EXPECT_LE(out.spec.y, 20);
    EXPECT_GE(out.spec.x + out.spec.width, 300);
    EXPECT_GE(out.spec.y + out.spec.height, 90);
    EXPECT_GT(out.spec.width * out.spec.height, 100 * 70) << "the flare outside the input's data window is kept";
    double outside = 0.0;
    for (int y = out.spec.y; y < out.spec.y + out.spec.height; ++y)
        for (int x = out.spec.x; x < out.spec.x + out.spec.width; ++x) {
            const bool inside = x >= 200 && x < 300 && y >= 20 && y < 90;
            if (inside) {
                ASSERT_GE(out.at(x, y, 1), in.at(x, y, 1));
            } else {
                ASSERT_GE(out.at(x, y, 1), 0.0f);
                outside += static_cast<double>(out.at(x, y, 1));
            }
        }
    EXPECT_GT(outside, 0.0);
}

TEST(FramePath, MinLightSkipsLightsTooDimAgainstTheBrightest) {
    const fs::path dir = temp_dir("minlight");
    // The second light has about 1/3000 of the first's flux: skipped at --min-light 1e-3, kept at 1e-4.
    write_frame(dir / "both.exr", {{230.3, 60.6, 6.0, 20000.0}, {80.2, 150.4, 1.0, 200.0}});
    write_frame(dir / "one.exr", {{230.3, 60.6, 6.0, 20000.0}});
    const std::string opts = " --flare-only --parts starburst --lens brendel-tessar --fstop 4 --threshold 100 -q";
    ASSERT_EQ(run("-i " + (dir / "both.exr").string() + " -o " + (dir / "a.exr").string() + opts + " --min-light 1e-3"), 0);
    ASSERT_EQ(run("-i " + (dir / "one.exr").string() + " -o " + (dir / "b.exr").string() + opts + " --min-light 1e-3"), 0);
    ASSERT_EQ(run("-i " + (dir / "both.exr").string() + " -o " + (dir / "c.exr").string() + opts + " --min-light 1e-4"), 0);
    const Image a = read(dir / "a.exr"), b = read(dir / "b.exr"), c = read(dir / "c.exr");
    EXPECT_EQ(a.px, b.px);
    EXPECT_GT(c.sum(1), b.sum(1));
}

TEST(FramePath, BandFilterDrawsAPointLightsGhostsUnspread) {
    // --band-filter renders each light on its own (not with the frame's other point lights): a point light's
    // ghosts keep their energy and are not spread over a footprint it has not got.
    const fs::path dir = temp_dir("band_filter");
    write_frame(dir / "small.exr", {{230.3, 60.6, 2.0, 20000.0}});
    const std::string opts = " --flare-only --parts ghosts --threshold 5 --bands 7";
    ASSERT_EQ(run("-i " + (dir / "small.exr").string() + " -o " + (dir / "p.exr").string() + kLensOnly + opts), 0);
    ASSERT_EQ(run("-i " + (dir / "small.exr").string() + " -o " + (dir / "f.exr").string() + kLensOnly + opts +
                  " --band-filter"),
              0);
    const Image plain = read(dir / "p.exr"), filtered = read(dir / "f.exr");
    ASSERT_GT(plain.sum(1), 0.0);
    EXPECT_NEAR(filtered.sum(1) / plain.sum(1), 1.0, 0.02);
}

TEST(FramePath, ExtendedLightsGhostImagingIsCachedAndADamagedFileMadeAgain) {
    // An extended light's ghosts are grouped by their imaging (traced once per lens): the table is kept in the
    // disk cache, read back the next run with the same image, and a damaged file is replaced.
    const fs::path dir = temp_dir("imaging_cache");
    const fs::path cache = dir / "cache";
    write_frame(dir / "in.exr", {{160.3, 100.6, 16.0, 20000.0 * 4.0 / 256.0}});
    const std::string args = "-i " + (dir / "in.exr").string() + " --flare-only --parts ghosts --threshold 5" + kLensOnly + " -o ";
    auto imaging_file = [&]() -> std::optional<fs::path> {
        if (!fs::exists(cache)) return std::nullopt;
        for (const auto& f : fs::directory_iterator(cache))
            if (f.path().filename().string().rfind("imaging-", 0) == 0) return f.path();
        return std::nullopt;
    };
    ASSERT_EQ(lensfx::test::run_lensfx_status(args + (dir / "a.exr").string() + " 2>&1", cache.string()), 0);
    const std::optional<fs::path> file = imaging_file();
    ASSERT_TRUE(file);
    const auto size = fs::file_size(*file);
    ASSERT_EQ(lensfx::test::run_lensfx_status(args + (dir / "b.exr").string() + " 2>&1", cache.string()), 0);
    fs::resize_file(*file, size / 2);
    ASSERT_EQ(lensfx::test::run_lensfx_status(args + (dir / "c.exr").string() + " 2>&1", cache.string()), 0);
    EXPECT_EQ(fs::file_size(*file), size);
    const Image a = read(dir / "a.exr"), b = read(dir / "b.exr"), c = read(dir / "c.exr");
    ASSERT_GT(a.sum(1), 0.0);
    EXPECT_EQ(a.px, b.px);
    EXPECT_EQ(a.px, c.px);
}

TEST(FramePath, ExtendedSourceSpreadsItsStarburstOverItsFootprint) {
    // The same flux as a small light and as a disc of radius 16 px. The disc's diffraction is every point's
    // pattern over the disc; what the recorded disc already holds is left out: each point's pattern within
    // the disc's radius (spread over the disc it would only blur the disc within its own size) and all that
    // lands on the disc's own pixels. The texture lies within a pixel (texels of 0.004 px here); the tail
    // beyond it, lengthened 80 times, carries the spikes past the disc.
    const fs::path dir = temp_dir("extended_starburst");
    const double cx = 160.3, cy = 100.6, radius = 16.0, value = 20000.0 * 4.0 / (radius * radius);
    write_frame(dir / "small.exr", {{cx, cy, 2.0, 20000.0}});
    write_frame(dir / "big.exr", {{cx, cy, radius, value}});
    const std::string opts = " --flare-only --parts starburst --threshold 5 --starburst-scale 80";
    ASSERT_EQ(run("-i " + (dir / "small.exr").string() + " -o " + (dir / "s.exr").string() + kLensOnly + opts), 0);
    ASSERT_EQ(run("-i " + (dir / "big.exr").string() + " -o " + (dir / "b.exr").string() + kLensOnly + opts), 0);
    const Image s = read(dir / "s.exr"), b = read(dir / "b.exr");
    const Image small_in = read(dir / "small.exr"), big_in = read(dir / "big.exr");
    const double scale = source_flux(big_in) / source_flux(small_in);
    // The disc's own pixels: those the detection keeps (down to half the threshold); the radius of the
    // area of its footprint's cells (its bounding box in 32 cells a side, here 2 px) holding any of them.
    std::vector<char> own(320 * 200, 0);
    int x0 = 320, y0 = 200, x1 = 0, y1 = 0;
    for (int y = 0; y < 200; ++y)
        for (int x = 0; x < 320; ++x)
            if (big_in.at(x, y, 1) >= 2.5f) {
                own[static_cast<std::size_t>(y * 320 + x)] = 1;
                x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x + 1), y1 = std::max(y1, y + 1);
            }
    const int cell = (std::max(x1 - x0, y1 - y0) + 31) / 32;
    std::vector<char> cells(static_cast<std::size_t>(320 * 200), 0);
    int cell_count = 0;
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
            if (own[static_cast<std::size_t>(y * 320 + x)]) {
                char& c = cells[static_cast<std::size_t>((y - y0) / cell * 320 + (x - x0) / cell)];
                cell_count += c == 0;
                c = 1;
            }
    const double own_radius = std::sqrt(cell_count / std::numbers::pi) * cell;
    // The reference by direct summation: the small light's pattern beyond that radius, spread over the
    // disc's normalised profile, off the disc's own pixels.
    const int R = static_cast<int>(radius) + 4;
    std::vector<double> f(static_cast<std::size_t>((2 * R + 1) * (2 * R + 1)));
    double fsum = 0.0;
    for (int j = -R; j <= R; ++j)
        for (int i = -R; i <= R; ++i)
            fsum += f[static_cast<std::size_t>((j + R) * (2 * R + 1) + i + R)] = std::exp(-std::pow(std::hypot(i, j) / radius, 8.0));
    std::vector<double> reference(320 * 200, 0.0);
    for (int y = 0; y < 200; ++y)
        for (int x = 0; x < 320; ++x) {
            if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) < own_radius) continue;
            const double v = static_cast<double>(s.at(x, y, 1)) * scale / fsum;
            if (v == 0.0) continue;
            for (int j = std::max(-R, -y); j <= std::min(R, 199 - y); ++j)
                for (int i = std::max(-R, -x); i <= std::min(R, 319 - x); ++i)
                    reference[static_cast<std::size_t>((y + j) * 320 + x + i)] += v * f[static_cast<std::size_t>((j + R) * (2 * R + 1) + i + R)];
        }
    double ref_total = 0.0, l1 = 0.0, on_disc = 0.0;
    for (int by = 0; by < 200; by += 8)
        for (int bx = 0; bx < 320; bx += 8) {
            double rb = 0.0, bb = 0.0;
            for (int y = by; y < by + 8; ++y)
                for (int x = bx; x < bx + 8; ++x) {
                    if (!own[static_cast<std::size_t>(y * 320 + x)]) rb += reference[static_cast<std::size_t>(y * 320 + x)];
                    bb += static_cast<double>(b.at(x, y, 1));
                    if (std::hypot(x + 0.5 - cx, y + 0.5 - cy) < radius - 2.0) on_disc += static_cast<double>(b.at(x, y, 1));
                }
            ref_total += rb;
            l1 += std::abs(bb - rb);
        }
    std::printf("own radius %.2f px, starburst energy disc/reference %.4f (disc/small %.4f), 8x8-block L1 %.4f, on the disc %g\n",
                own_radius, b.sum(1) / ref_total, b.sum(1) / (s.sum(1) * scale), l1 / ref_total, on_disc);
    ASSERT_GT(ref_total, 0.0);
    // A point light's spikes are the texture plus the iris edges' analytic tail, lengthened (not enlarged)
    // by --starburst-scale, and an extended light's are the same spread over its footprint (issue 16):
    // the disc's image is the reference (measured 0.998 of its energy, 8x8-block L1 0.028).
    EXPECT_GT(b.sum(1), 0.9 * ref_total) << "the disc's spikes beyond its radius";
    EXPECT_LT(b.sum(1), 1.03 * ref_total) << "no more than the small light's pattern beyond the disc's radius";
    EXPECT_LT(l1, 0.1 * ref_total) << "the small light's spikes, spread over the disc";
    EXPECT_EQ(on_disc, 0.0) << "nothing added over the disc: it does not bloom";
}

TEST(FramePath, ExtendedSourceSpreadsItsGhostsWithoutLosingEnergy) {
    const fs::path dir = temp_dir("extended");
    // The same flux as a small light and as a disc of radius 24 px (a window): the ghosts of the disc are
    // the small light's spread over its footprint.
    const double big_r = kBigR;
    write_small_and_big_light(dir, 230.3, 60.6);
    const std::string opts = " --flare-only --parts ghosts --threshold 5 --report ";
    ASSERT_EQ(run("-i " + (dir / "small.exr").string() + " -o " + (dir / "s.exr").string() + kLensOnly + opts + (dir / "s.json").string()), 0);
    ASSERT_EQ(run("-i " + (dir / "big.exr").string() + " -o " + (dir / "b.exr").string() + kLensOnly + opts + (dir / "b.json").string()), 0);
    const Image s = read(dir / "s.exr"), b = read(dir / "b.exr");
    // The reference: the small light's ghosts (green) convolved with the disc's normalised footprint here,
    // by direct summation, energy leaving the frame lost as in the filter.
    const int R = static_cast<int>(big_r) + 2;
    std::vector<double> f(static_cast<std::size_t>((2 * R + 1) * (2 * R + 1)));
    double fsum = 0.0;
    for (int j = -R; j <= R; ++j)
        for (int i = -R; i <= R; ++i) fsum += f[static_cast<std::size_t>((j + R) * (2 * R + 1) + i + R)] = std::exp(-std::pow(std::hypot(i, j) / big_r, 8.0));
    std::vector<double> reference(320 * 200, 0.0);
    for (int y = 0; y < 200; ++y)
        for (int x = 0; x < 320; ++x) {
            const double v = static_cast<double>(s.at(x, y, 1)) / fsum;
            if (v == 0.0) continue;
            for (int j = std::max(-R, -y); j <= std::min(R, 199 - y); ++j)
                for (int i = std::max(-R, -x); i <= std::min(R, 319 - x); ++i)
                    reference[static_cast<std::size_t>((y + j) * 320 + x + i)] += v * f[static_cast<std::size_t>((j + R) * (2 * R + 1) + i + R)];
        }
    const double scale = source_flux(read(dir / "big.exr")) / source_flux(read(dir / "small.exr"));
    double ref_total = 0.0, l1 = 0.0;
    for (int by = 0; by < 200; by += 8)
        for (int bx = 0; bx < 320; bx += 8) {
            double rb = 0.0, bb = 0.0;
            for (int y = by; y < by + 8; ++y)
                for (int x = bx; x < bx + 8; ++x) {
                    rb += reference[static_cast<std::size_t>(y * 320 + x)] * scale;
                    bb += static_cast<double>(b.at(x, y, 1));
                }
            ref_total += rb;
            l1 += std::abs(bb - rb);
        }
    // Ghosts too blurred for the window to show are drawn as from a point, the others through the window
    // scaled by their magnification, so the energy is the small light's (less what the sharp ghosts spread
    // beyond the frame), and the image is close to the all-at-magnification-1 convolution, which also loses
    // the blurred ghosts' energy at the frame's edges.
    std::printf("extended/point energy %.4f, extended/reference %.4f, L1 %.4f\n", b.sum(1) / (s.sum(1) * scale), b.sum(1) / ref_total, l1 / ref_total);
    EXPECT_NEAR(b.sum(1) / (s.sum(1) * scale), 1.0, 0.03);
    EXPECT_LT(l1 / ref_total, 0.1) << "8x8-block relative L1 against the direct convolution";
    float s_max = 0.0f, b_max = 0.0f;
    for (std::size_t i = 1; i < s.px.size(); i += 3) {
        s_max = std::max(s_max, s.px[i]);
        b_max = std::max(b_max, b.px[i]);
    }
    EXPECT_LT(b_max, 0.5f * s_max) << "the footprint blurs the ghosts";
    std::ifstream report(dir / "b.json");
    const auto j = nlohmann::json::parse(report);
    const auto& stages = j.at("frames").at(0).at("stages_ms");
    for (const char* part : {"flare.detect", "flare.direct", "flare.ghosts", "flare.starburst", "flare.extended", "flare.composite"})
        EXPECT_TRUE(stages.contains(part)) << part;
    EXPECT_GT(stages.at("flare.extended").get<double>(), 0.0);
}

TEST(FramePath, ExtendedSourceOfManyReducedGroupsKeepsItsEnergy) {
    const fs::path dir = temp_dir("extended_groups");
    // A double Gauss images a disc of radius 24 px through nine reduced footprint groups: each is convolved on a
    // worker thread while the next is drawn (two images in turn, the level sums taking several groups). The
    // ghosts of the disc keep the small light's energy, less what the blur spreads beyond the frame.
    write_small_and_big_light(dir, 160.3, 100.6);
    const std::string opts = " --lens angenieux-double-gauss --grid 32 -q --flare-only --parts ghosts --threshold 5";
    ASSERT_EQ(run("-i " + (dir / "small.exr").string() + " -o " + (dir / "s.exr").string() + opts), 0);
    ASSERT_EQ(run("-i " + (dir / "big.exr").string() + " -o " + (dir / "b.exr").string() + opts), 0);
    const double scale = source_flux(read(dir / "big.exr")) / source_flux(read(dir / "small.exr"));
    const Image s = read(dir / "s.exr"), b = read(dir / "b.exr");
    for (int c = 0; c < 3; ++c) {
        std::printf("channel %d: extended/point energy %.4f\n", c, b.sum(c) / (s.sum(c) * scale));
        EXPECT_NEAR(b.sum(c) / (s.sum(c) * scale), 1.0, 0.03) << "channel " << c;
    }
}

TEST(FramePath, MovingLightDoesNotFlickerAndThreadsDoNotMatter) {
    const fs::path dir = temp_dir("flicker");
    // A light of constant flux moving 0.37 px right and 0.13 px down per frame.
    const int frames = 8;
    for (int f = 1; f <= frames; ++f)
        write_frame(dir / ("in." + std::to_string(10000 + f).substr(1) + ".exr"), {{200.2 + 0.37 * f, 60.7 + 0.13 * f, 3.0, 20000.0}});
    const std::string opts = " --flare-only --parts ghosts" + kLens;
    ASSERT_EQ(run("-i " + (dir / "in.#.exr").string() + " -o " + (dir / "a.#.exr").string() + opts + " --threads 1"), 0);
    ASSERT_EQ(run("-i " + (dir / "in.#.exr").string() + " -o " + (dir / "b.#.exr").string() + opts + " --threads 2"), 0);
    std::vector<double> ratio;
    for (int f = 1; f <= frames; ++f) {
        const std::string n = std::to_string(10000 + f).substr(1);
        const Image in = read(dir / ("in." + n + ".exr")), a = read(dir / ("a." + n + ".exr")), b = read(dir / ("b." + n + ".exr"));
        ASSERT_EQ(a.px, b.px) << "frame " << f << " differs between 1 and 2 threads";
        double source = 0.0;
        for (std::size_t i = 1; i < in.px.size(); i += 3)
            if (in.px[i] > 1.0f) source += static_cast<double>(in.px[i]);
        ratio.push_back(a.sum(1) / source);
    }
    const double mean = [&] { double s = 0.0; for (double r : ratio) s += r; return s / static_cast<double>(ratio.size()); }();
    ASSERT_GT(mean, 0.0);
    for (std::size_t i = 1; i < ratio.size(); ++i)
        EXPECT_LT(std::abs(ratio[i] - ratio[i - 1]) / mean, 0.01) << "flicker between frames " << i << " and " << i + 1;
}

