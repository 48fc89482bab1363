// The lens blur's optics through the dense CPU reference (issue 18's "Done when"): blur size and energy of a
// defocused point, a focused point's concentration, no halo of a blurred background around an in-focus
// edge, partial occlusion from deep input, and chromatic blur of the Cooke triplet.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <dof/deep_exr.h>
#include <dof/highlights.h>
#include <dof/reference.h>
#include <flare/flare.h>
#include <optics/tracer.h>

#include "dof_scenes.h"

namespace lensfx::dof {
namespace {

using test::camera_for;
using test::disc_diameter;
using test::moments;
using test::point_scene;
using test::thin_lens_blur_mm;

constexpr int kSize = 80;

float at(const std::vector<float>& rgb, int w, int x, int y, int c) {
    return rgb[3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) + static_cast<std::size_t>(c)];
}

// The sensor spot of an on-axis object point at z_m, traced forward through a dense grid over the round
// entrance pupil at one wavelength: the diameter of the uniform disc with its second moment (mm). Independent of
// the ray table and the gather; it holds the lens's spherical aberration, which the thin lens lacks.
double traced_spot_diameter_mm(const Camera& cam, double z_m, double wavelength_nm = 550.0) {
    const Focus f = focus_of(cam.system, cam.focus_m);
    optics::System system = cam.system;
    system.sensor_z_mm = f.sensor_z_mm;
    const optics::TraceSystem ts(system, wavelength_nm);
    const auto path = optics::direct_path(system);
    const double z_obj = f.entrance_pupil_z_mm - z_m * 1000.0, r = 0.5 * f.entrance_pupil_diameter_mm;
    double sum = 0.0;
    int n = 0;
    constexpr int kGrid = 64;
    for (int j = 0; j < kGrid; ++j)
        for (int i = 0; i < kGrid; ++i) {
            const double u = (2.0 * i + 1.0) / kGrid - 1.0, v = (2.0 * j + 1.0) / kGrid - 1.0;
            if (u * u + v * v > 1.0) continue;
            const optics::Vec3 aim{u * r, v * r, f.entrance_pupil_z_mm};
            const optics::TraceResult t = optics::trace(ts, {{0.0, 0.0, z_obj}, optics::normalize(aim - optics::Vec3{0.0, 0.0, z_obj})}, path);
            if (!t.ok()) continue;
            sum += t.position.x * t.position.x + t.position.y * t.position.y;
            ++n;
        }
    return std::sqrt(8.0 * sum / n);
}

// The formula is a round pupil's: the lens's six blades are taken out here (and tested in the bokeh below).
TEST(DofReference, DefocusedPointHasTheThinLensDiameterAndItsEnergy) {
    Camera cam = camera_for("mld-double-gauss", 4.0, 1.0, 2.0, kSize, 20.0);
    cam.system.aperture.blades = 0;
    const RayTable table = make_ray_table(cam, 1024, 9);
    const std::vector<float> out = render_reference(point_scene(kSize, 2.0, kSize / 2, kSize / 2, 1000.0f), table);
    const double thin_lens_px = thin_lens_blur_mm(cam.system, 2.0, 1.0) / cam.pitch_mm();
    const double traced_px = traced_spot_diameter_mm(cam, 2.0) / cam.pitch_mm();
    const test::Moments m = moments(out, kSize, kSize, 1);
    EXPECT_NEAR(disc_diameter(m) / thin_lens_px, 1.0, 0.05) << "diameter " << disc_diameter(m) << " px, thin lens " << thin_lens_px;
    EXPECT_NEAR(disc_diameter(m) / traced_px, 1.0, 0.02) << "diameter " << disc_diameter(m) << " px, forward trace " << traced_px;
    // the lens images 2 m at its own scale (focus breathing): the point's energy over that scale squared
    const double scale = scene_scale(table, 1, 0.5);
    EXPECT_NEAR(m.sum / (1000.0 / (scale * scale)), 1.0, 0.01) << "energy " << m.sum << ", scene scale " << scale;
}

// Six straight blades inscribed in the round stop: a hexagonal bokeh, whose second moment is 5/6 of the
// circumscribed disc's (diameter ratio sqrt(5/6) = 0.913).
TEST(DofReference, BladesShapeTheBokeh) {
    Camera cam = camera_for("mld-double-gauss", 4.0, 1.0, 2.0, kSize, 20.0);
    cam.system.aperture.blades = 0;
    const LayerStack scene = point_scene(kSize, 2.0, kSize / 2, kSize / 2, 1000.0f);
    const double round = disc_diameter(moments(render_reference(scene, make_ray_table(cam, 1024, 3)), kSize, kSize, 1));
    cam.system.aperture.blades = 6;
    const double hexagon = disc_diameter(moments(render_reference(scene, make_ray_table(cam, 1024, 3)), kSize, kSize, 1));
    EXPECT_NEAR(hexagon / round, std::sqrt(5.0 / 6.0), 0.02);
}

TEST(DofReference, PointInFocusKeepsItsEnergyWithinFiveByFive) {
    const Camera cam = camera_for("mld-double-gauss", 4.0, 1.0, 2.0, kSize, 20.0);
    const RayTable table = make_ray_table(cam, 256, 5);
    const std::vector<float> out = render_reference(point_scene(kSize, 1.0, kSize / 2, kSize / 2, 1000.0f), table);
    const test::Moments m = moments(out, kSize, kSize, 1);
    double inside = 0.0;
    for (int y = kSize / 2 - 2; y <= kSize / 2 + 2; ++y)
        for (int x = kSize / 2 - 2; x <= kSize / 2 + 2; ++x) inside += double{at(out, kSize, x, y, 1)};
    EXPECT_GE(inside / m.sum, 0.8) << inside << " of " << m.sum;
}

// A foreground square at 0.5 m over nothing, focus at 2 m (16 px blur): its alpha blurs with its colour, so
// the edge is soft in alpha (not cut at the square's own pixels) and the premultiplied colour stays alpha x 1.
TEST(DofReference, BlurredForegroundIsSoftInAlphaToo) {
    const Camera cam = camera_for("mld-double-gauss", 4.0, 2.0, 0.5, kSize, 16.0);
    std::vector<float> alpha;
    const std::vector<float> out = render_reference(test::alpha_square_scene(kSize, 20, 60, 0.5), make_ray_table(cam, 256, 5), 0, 0, &alpha);
    ASSERT_EQ(alpha.size(), static_cast<std::size_t>(kSize * kSize));
    const auto a = [&](int x, int y) { return alpha[static_cast<std::size_t>(y * kSize + x)]; };
    const int y = kSize / 2;
    EXPECT_NEAR(a(kSize / 2, y), 1.0f, 1e-3f) << "inside the square";
    EXPECT_NEAR(a(2, y), 0.0f, 1e-3f) << "beyond the blur";
    EXPECT_GT(a(16, y), 0.05f) << "4 px outside the square, its blur covers";
    EXPECT_LT(a(24, y), 0.95f) << "4 px inside, the blur uncovers";
    EXPECT_NEAR(a(20, y), 0.5f, 0.15f) << "half at the edge";
    for (int x = 1; x < kSize / 2; ++x) EXPECT_GE(a(x, y) + 1e-4f, a(x - 1, y)) << "rises towards the square at x " << x;
    for (std::size_t i = 0; i < alpha.size(); ++i) ASSERT_NEAR(out[3 * i + 1], alpha[i], 1e-4f) << "premultiplied white at pixel " << i;
}

// An in-focus black edge at 1 m before a bright background at 10 m (test::edge_scene).
TEST(DofReference, InFocusEdgeGetsNoHaloOfTheBlurredBackground) {
    const Camera cam = camera_for("mld-double-gauss", 4.0, 1.0, 10.0, kSize, 16.0);
    const LayerStack layers = test::edge_scene(kSize);
    ASSERT_EQ(layers.count, 2);
    const std::vector<float> out = render_reference(layers, make_ray_table(cam, 256, 5));
    float worst = 0.0f;
    for (int y = 10; y < kSize - 10; ++y)
        for (int x = 0; x < kSize / 2 - 3; ++x) worst = std::max(worst, at(out, kSize, x, y, 1));
    EXPECT_LE(worst, 0.1f) << "0.1% of the background's 100";
    EXPECT_GT(at(out, kSize, kSize / 2 + 1, kSize / 2, 1), 30.0f) << "the background beside the edge is lit";
}

// Deep input: a black surface at 0.5 m over the left half, out of focus, in front of a sharp striped plane
// at 2 m (the focus) that the deep samples hold behind it too.
TEST(DofReference, BlurredForegroundShowsTheBackgroundThroughItFromDeepInput) {
    const Camera cam = camera_for("mld-double-gauss", 4.0, 2.0, 0.5, kSize, 16.0);
    DeepImage deep;
    deep.width = deep.height = deep.full_width = deep.full_height = kSize;
    deep.offsets.push_back(0);
    const auto stripe = [](int y) { return (y / 2) % 2 ? 1.0f : 0.2f; };
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) {
            if (x < kSize / 2) deep.samples.push_back({0, 0, 0, 1, 0.5f, 0.5f});
            const float s = stripe(y);
            deep.samples.push_back({s, s, s, 1, 2.0f, 2.0f});
            deep.offsets.push_back(static_cast<std::uint32_t>(deep.samples.size()));
        }
    const std::vector<float> out = render_reference(layers_from_deep(deep), make_ray_table(cam, 256, 5));
    const int x = kSize / 2 - 3;  // inside the foreground, within its blur
    double bright = 0, dark = 0;
    int nb = 0, nd = 0;
    for (int y = 20; y < kSize - 20; ++y) {
        const double v = at(out, kSize, x, y, 1);
        if (stripe(y) > 0.5f) bright += v, ++nb; else dark += v, ++nd;
    }
    bright /= nb, dark /= nd;
    const double seen = 0.5 * (bright + dark) / 0.6;  // share of the background seen (mean stripe level 0.6)
    EXPECT_GT(seen, 0.1) << "the background shows through the foreground's blur";
    EXPECT_GT(bright - dark, 0.5 * (1.0 - 0.2) * seen) << "and it is sharp: its stripes keep half their contrast or more";
}

TEST(DofReference, CookeTripletBlursEachChannelAsItsGlassesImply) {
    Camera cam = camera_for("cooke-triplet", 5.6, 1.0, 2.0, kSize, 20.0);
    cam.system.aperture.blades = 0;  // the forward trace's pupil is round
    const RayTable table = make_ray_table(cam, 1024, 3);
    const std::vector<float> out = render_reference(point_scene(kSize, 2.0, kSize / 2, kSize / 2, 1000.0f), table);
    std::array<double, 3> measured{}, predicted{};
    for (int c = 0; c < 3; ++c) {
        measured[static_cast<std::size_t>(c)] = disc_diameter(moments(out, kSize, kSize, c)) * cam.pitch_mm();
        predicted[static_cast<std::size_t>(c)] = traced_spot_diameter_mm(cam, 2.0, cam.wavelengths_nm[static_cast<std::size_t>(c)]);
    }
    const double measured_ratio = measured[0] / measured[2], predicted_ratio = predicted[0] / predicted[2];
    EXPECT_GT(std::abs(predicted_ratio - 1.0), 0.01) << "the triplet's glasses disperse";
    EXPECT_NEAR(measured_ratio - 1.0, predicted_ratio - 1.0, 0.35 * std::abs(predicted_ratio - 1.0))
        << "red/blue diameters " << measured[0] << "/" << measured[2] << " mm, forward traces " << predicted[0] << "/" << predicted[2];
}

// A focal surface through two focus points (paper section 5.2): a point at 1 m on the left and one at 2 m
// on the right, each under its own focus point, are both sharp; the plane at 1 m blurs the right one.
TEST(DofReference, FocalSurfaceKeepsEachFocusPointSharp) {
    constexpr int w = 200, h = 24;
    std::vector<float> rgb(3 * w * h, 0.0f), depth(w * h, 1.0f);
    for (int y = 0; y < h; ++y)
        for (int x = w / 2; x < w; ++x) depth[static_cast<std::size_t>(y * w + x)] = 2.0f;
    for (int x : {30, 170})
        for (std::size_t c = 0; c < 3; ++c) rgb[3 * static_cast<std::size_t>(h / 2 * w + x) + c] = 1000.0f;
    const LayerStack scene = layers_from_flat(rgb.data(), depth.data(), w, h);
    Camera cam = camera_for("mld-double-gauss", 4.0, 1.0, 2.0, w, 20.0);
    cam.height = h, cam.centre_y = 0.5 * h;
    // share of the energy within 30 px of column `near` (inside the frame) that lies in the 5 x 5 px round
    // its centroid (the focused lens images the plate slightly larger: focus breathing moves the points out)
    const auto sharp = [&](const std::vector<float>& out, int near) {
        const int x0 = std::max(0, near - 30), x1 = std::min(w - 1, near + 30);
        double all = 0, cx = 0, in = 0;
        for (int y = 0; y < h; ++y)
            for (int x = x0; x <= x1; ++x) all += double{at(out, w, x, y, 1)}, cx += double{at(out, w, x, y, 1)} * x;
        const int centre = static_cast<int>(std::lround(cx / all));
        for (int y = h / 2 - 2; y <= h / 2 + 2; ++y)
            for (int x = std::max(0, centre - 2); x <= std::min(w - 1, centre + 2); ++x) in += double{at(out, w, x, y, 1)};
        return in / all;
    };
    const std::vector<float> plane = render_reference(scene, make_ray_table(cam, 256, 9));
    cam.focus_points = {{30.5, 12.5, 1.0}, {170.5, 12.5, 2.0}};
    EXPECT_DOUBLE_EQ(focus_at(cam, 30.5, 12.5), 1.0);
    EXPECT_DOUBLE_EQ(focus_at(cam, 170.5, 12.5), 2.0);
    EXPECT_NEAR(focus_at(cam, 100.5, 12.5), 2.0 / 1.5, 1e-9) << "halfway: the mean of 1/1 and 1/2 (inverse distance)";
    const std::vector<float> surface = render_reference(scene, make_ray_table(cam, 256, 9));
    EXPECT_GE(sharp(plane, 30), 0.8);
    EXPECT_LT(sharp(plane, 170), 0.3) << "the plane at 1 m blurs the point at 2 m";
    EXPECT_GE(sharp(surface, 30), 0.8);
    EXPECT_GE(sharp(surface, 170), 0.8) << "the surface is at 2 m there";
}

// Seven spectral bands (--bands 7, CIE 1931 weights into Rec. 709): each channel is exactly its bands' blurs
// (each band alone, as a one-wavelength camera) mixed by the weights; a uniform plane keeps its value (each
// channel's weights sum to 1); and the Cooke triplet's dispersion shows as different red and blue blurs.
TEST(DofReference, SpectralBandsMixEachBandsBlurByTheColourMatchingWeights) {
    constexpr int n = 48;
    Camera cam = camera_for("cooke-triplet", 5.6, 1.0, 2.0, n, 14.0);
    cam.system.aperture.blades = 0;
    const LayerStack scene = point_scene(n, 2.0, n / 2, n / 2, 1000.0f);
    std::vector<Band> bands;
    for (const flare::SpectralPass& p : flare::spectral_passes(7)) bands.push_back({p.wavelength_nm, p.weight});
    std::vector<double> mixed(3 * static_cast<std::size_t>(n * n), 0.0);
    for (const Band& b : bands) {
        Camera one = cam;
        one.bands = {{b.wavelength_nm, {1.0, 1.0, 1.0}}};
        const std::vector<float> alone = render_reference(scene, make_ray_table(one, 128, 3));
        for (std::size_t i = 0; i < mixed.size(); ++i) mixed[i] += b.weight[i % 3] * double{alone[i]};
    }
    cam.bands = bands;
    const RayTable table = make_ray_table(cam, 128, 3);
    ASSERT_EQ(table.channels, 7);
    EXPECT_LT(std::abs(bands[static_cast<std::size_t>(table.achromatic)].wavelength_nm - 550.0), 0.5 * 400.0 / 7) << "the band holding 550 nm";
    const std::vector<float> out = render_reference(scene, table);
    double worst = 0.0, peak = 0.0;
    for (std::size_t i = 0; i < out.size(); ++i) worst = std::max(worst, std::abs(double{out[i]} - mixed[i])), peak = std::max(peak, mixed[i]);
    EXPECT_LT(worst, 1e-4 * peak) << "the bands' blurs mixed by their weights";
    const double red = disc_diameter(moments(out, n, n, 0)), blue = disc_diameter(moments(out, n, n, 2));
    EXPECT_GT(std::abs(red / blue - 1.0), 0.01) << "red " << red << " px, blue " << blue << " px";
    // a plane of 1 keeps 1 in every channel: each channel's weights sum to 1
    std::vector<float> ones(3 * 16 * 16, 1.0f), depth(16 * 16, 1.5f);
    Camera flat = cam;
    flat.width = flat.height = 16, flat.centre_x = flat.centre_y = 8.0;
    for (float v : render_reference(layers_from_flat(ones.data(), depth.data(), 16, 16), make_ray_table(flat, 64, 3))) ASSERT_NEAR(v, 1.0f, 1e-4f);
}

// Tilt-shift: a sensor tilted about the vertical axis moves each column's focus; points at the focus
// distance stay sharp on the axis and blur towards the sides (Scheimpflug).
TEST(DofReference, TiltedSensorBlursTheFocusPlaneAwayFromTheAxis) {
    constexpr int w = 320, h = 24;
    std::vector<float> rgb(3 * w * h, 0.0f), depth(w * h, 1.0f);
    for (int x : {30, 160, 290})
        for (std::size_t c = 0; c < 3; ++c) rgb[3 * static_cast<std::size_t>(h / 2 * w + x) + c] = 1000.0f;
    const LayerStack scene = layers_from_flat(rgb.data(), depth.data(), w, h);
    Camera cam = camera_for("mld-double-gauss", 4.0, 1.0, 2.0, w, 20.0);
    cam.height = h, cam.centre_y = 0.5 * h;
    // share of the energy near column `near` (within 20 px, inside the frame) lying beyond 2 px of its centroid
    const auto spread = [&](const std::vector<float>& out, int near) {
        const int x0 = std::max(0, near - 20), x1 = std::min(w - 1, near + 20);
        double all = 0, cx = 0, in = 0;
        for (int y = 0; y < h; ++y)
            for (int x = x0; x <= x1; ++x) all += double{at(out, w, x, y, 1)}, cx += (x + 0.5) * double{at(out, w, x, y, 1)};
        cx /= all;
        for (int y = h / 2 - 2; y <= h / 2 + 2; ++y)
            for (int x = x0; x <= x1; ++x)
                if (std::abs(x + 0.5 - cx) <= 2.5) in += double{at(out, w, x, y, 1)};
        return 1.0 - in / all;
    };
    const std::vector<float> flat = render_reference(scene, make_ray_table(cam, 256, 5));
    cam.tilt_y_deg = 30.0;  // 143 px off the axis (130, magnified by the focused lens): about 14 px of blur
    const std::vector<float> tilted = render_reference(scene, make_ray_table(cam, 256, 5));
    for (int x : {17, 303}) {  // where the lens, focused at 1 m, images columns 30 and 290
        EXPECT_LT(spread(flat, x), 0.2) << x;
        EXPECT_GT(spread(tilted, x), 0.4) << x;
    }
    EXPECT_LT(spread(tilted, 160), 0.2);
}

// Cat's-eye bokeh: towards the frame's edge the lens's clear apertures clip the pupil, so a defocused
// point's bokeh narrows along the radius (here x) and keeps its height.
TEST(DofReference, BokehBecomesACatsEyeTowardsTheEdge) {
    constexpr int w = 640, h = 48;
    std::vector<float> rgb(3 * w * h, 0.0f), depth(w * h, 3.0f);
    for (int x : {320, 600})
        for (std::size_t c = 0; c < 3; ++c) rgb[3 * static_cast<std::size_t>(h / 2 * w + x) + c] = 1000.0f;
    Camera cam;
    cam.system = optics::realize(optics::load_lens("pbrt-dgauss-50"), 0.0, 2.1);
    cam.system.aperture.blades = 0;
    cam.focus_m = 1.0;
    cam.width = w, cam.height = h, cam.centre_x = 0.5 * w, cam.centre_y = 0.5 * h;
    cam.sensor_width_mm = 36.0;  // the point at x = 600 is 15.8 mm off the axis
    const std::vector<float> out = render_reference(layers_from_flat(rgb.data(), depth.data(), w, h), make_ray_table(cam, 512, 17));
    // second moments along x and y of the energy within 30 px of column `near`
    const auto aspect = [&](int near) {
        double s = 0, mx = 0, my = 0, xx = 0, yy = 0;
        for (int y = 0; y < h; ++y)
            for (int x = near - 30; x <= std::min(w - 1, near + 30); ++x) {
                const double v = at(out, w, x, y, 1);
                s += v, mx += v * x, my += v * y, xx += v * x * x, yy += v * y * y;
            }
        mx /= s, my /= s;
        return (xx / s - mx * mx) / (yy / s - my * my);
    };
    EXPECT_NEAR(aspect(320), 1.0, 0.05) << "round on the axis";
    EXPECT_LT(aspect(620), 0.85) << "narrower along the radius at the edge";
}

TEST(DofLayers, FlatImageGetsTheHiddenSurfaceUnderItsNearerNeighbour) {
    std::vector<float> rgb(3 * 16 * 4, 1.0f), depth(16 * 4, 5.0f);
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 8; ++x) depth[static_cast<std::size_t>(y * 16 + x)] = 1.0f;
    FlatLayerOptions o;
    o.hidden_radius_px = 4;
    const LayerStack l = layers_from_flat(rgb.data(), depth.data(), 16, 4, o);
    ASSERT_EQ(l.count, 2);
    EXPECT_FLOAT_EQ(l.front[l.at(1, 7, 1)], 5.0f);   // under the near surface, next to the edge
    EXPECT_FLOAT_EQ(l.front[l.at(1, 4, 1)], 5.0f);   // 4 px in
    EXPECT_FLOAT_EQ(l.front[l.at(1, 2, 1)], 0.0f);   // beyond the reach
    EXPECT_FLOAT_EQ(l.front[l.at(1, 12, 1)], 0.0f);  // nothing hides behind the far surface
}

// The highlights taken from a plate for the bokeh splat are the brightest whose bokehs' areas fit
// HighlightSettings::max_area_ratio (the splat's cost follows that area); the others stay in the plate.
TEST(Highlights, TheBrightestWithinTheAreaBudgetAreTaken) {
    constexpr int n = 96;
    const Camera cam = camera_for("mld-double-gauss", 4.0, 1.0, 10.0, n, 12.0);  // 10 m blurs to about 12 px
    const RayTable table = make_ray_table(cam, 256, 5);
    std::vector<float> rgb(3 * n * n, 0.0f), depth(n * n, 10.0f);
    std::vector<std::size_t> lights;  // a lattice of 36 one-pixel lights of 100, 110, 120...
    for (int y = 8; y < n; y += 16)
        for (int x = 8; x < n; x += 16) {
            const std::size_t i = static_cast<std::size_t>(y * n + x);
            for (std::size_t c = 0; c < 3; ++c) rgb[3 * i + c] = 100.0f + 10.0f * static_cast<float>(lights.size());
            lights.push_back(i);
        }
    const auto taken = [&](double ratio, std::vector<float>& plate) {
        plate = rgb;
        HighlightSettings settings;
        settings.max_area_ratio = ratio;
        return take_highlights(plate, depth, n, n, table, 0, 0, settings);
    };
    std::vector<float> plate;
    EXPECT_EQ(taken(1e9, plate).size(), lights.size());
    const std::vector<Highlight> some = taken(0.1, plate);  // 922 px^2: a few discs of radius about 6 px
    ASSERT_GT(some.size(), 0u);
    ASSERT_LT(some.size(), lights.size());
    float dimmest_taken = 1e30f;
    for (const Highlight& h : some) dimmest_taken = std::min(dimmest_taken, h.excess[1]);
    for (const std::size_t i : lights) {
        const bool was_taken = std::any_of(some.begin(), some.end(), [&](const Highlight& h) { return static_cast<std::size_t>(h.y * n + h.x) == i; });
        if (was_taken) {
            EXPECT_EQ(plate[3 * i + 1], 0.0f) << "a taken light leaves the plate";
        } else {
            EXPECT_EQ(plate[3 * i + 1], rgb[3 * i + 1]) << "a light left out stays in the plate";
            EXPECT_LT(rgb[3 * i + 1], dimmest_taken) << "the brightest are taken";
        }
    }
    // Equal lights are taken all or none: a cap splitting them by place would splat a band and gather the rest.
    for (const std::size_t i : lights)
        for (std::size_t c = 0; c < 3; ++c) rgb[3 * i + c] = 100.0f;
    EXPECT_EQ(taken(1e9, plate).size(), lights.size());
    EXPECT_TRUE(taken(0.1, plate).empty());
    EXPECT_EQ(plate, rgb);
}

}  // namespace
}  // namespace lensfx::dof
