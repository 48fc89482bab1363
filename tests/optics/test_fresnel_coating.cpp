// Fresnel equations and thin-film coatings: closed forms against the transfer-matrix method, energy
// conservation, the limits (TIR, grazing, matched media, zero thickness) and the paper's figure 4 numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include <optics/coating.h>
#include <optics/fresnel.h>
#include <optics/glass.h>

using namespace lensfx::optics;

namespace {
double deg(double a) { return a * std::numbers::pi / 180.0; }
}  // namespace

TEST(Fresnel, NormalIncidence) {
    for (auto [n1, n2] : {std::pair{1.0, 1.5}, std::pair{1.5, 1.0}, std::pair{1.0, 1.9}, std::pair{1.6, 1.52}}) {
        const double r = (n1 - n2) / (n1 + n2);
        const Reflectance f = fresnel_unpolarized(n1, n2, 1.0);
        EXPECT_NEAR(f.R, r * r, 1e-15);
        EXPECT_NEAR(f.T, 1.0 - r * r, 1e-15);
    }
}

TEST(Fresnel, EnergyConservedAtEveryAngle) {
    double worst = 0.0;
    for (double n1 : {1.0, 1.33, 1.5, 1.9}) {
        for (double n2 : {1.0, 1.2, 1.5, 2.0}) {
            for (int k = 0; k <= 2000; ++k) {
                const double c = k / 2000.0;
                for (const Reflectance f : {fresnel_unpolarized(n1, n2, c), fresnel_s(n1, n2, c), fresnel_p(n1, n2, c)}) {
                    ASSERT_TRUE(std::isfinite(f.R) && std::isfinite(f.T));
                    ASSERT_GE(f.R, 0.0);
                    ASSERT_GE(f.T, 0.0);
                    worst = std::max(worst, std::abs(f.R + f.T - 1.0));
                }
            }
        }
    }
    EXPECT_LT(worst, 1e-12);
}

TEST(Fresnel, Limits) {
    // Total internal reflection beyond the critical angle asin(1/1.5) = 41.81 deg.
    EXPECT_EQ(fresnel_unpolarized(1.5, 1.0, std::cos(deg(42.0))).R, 1.0);
    EXPECT_EQ(fresnel_unpolarized(1.5, 1.0, std::cos(deg(42.0))).T, 0.0);
    EXPECT_LT(fresnel_unpolarized(1.5, 1.0, std::cos(deg(41.0))).R, 0.5);
    EXPECT_LT(cos_transmitted(1.5, 1.0, std::cos(deg(42.0))), 0.0);
    // Grazing incidence reflects everything; matched media nothing.
    EXPECT_EQ(fresnel_unpolarized(1.0, 1.5, 0.0).R, 1.0);
    EXPECT_EQ(fresnel_unpolarized(1.5, 1.5, 0.3).R, 0.0);
    EXPECT_EQ(fresnel_unpolarized(1.5, 1.5, 0.0).T, 1.0);
    // Brewster's angle: no p reflection.
    const double brewster = std::atan(1.5);
    EXPECT_NEAR(fresnel_p(1.0, 1.5, std::cos(brewster)).R, 0.0, 1e-15);
    EXPECT_GT(fresnel_s(1.0, 1.5, std::cos(brewster)).R, 0.1);
    // Out-of-range cosines are clamped, never NaN.
    EXPECT_TRUE(std::isfinite(fresnel_unpolarized(1.0, 1.5, std::nan("")).R));
    EXPECT_EQ(fresnel_unpolarized(1.0, 1.5, 1.7).R, fresnel_unpolarized(1.0, 1.5, 1.0).R);
}

TEST(Fresnel, VectorSnellAndReflection) {
    const Vec3 n{0.0, 0.0, 1.0};
    for (double a : {0.0, 10.0, 30.0, 60.0, 89.0}) {
        const Vec3 d{std::sin(deg(a)), 0.0, std::cos(deg(a))};
        Vec3 t;
        double ci = 0.0, ct = 0.0;
        ASSERT_TRUE(refract(d, n, 1.0, 1.5, t, ci, ct));
        EXPECT_NEAR(1.0 * std::sin(deg(a)), 1.5 * t.x, 1e-15);
        EXPECT_NEAR(length(t), 1.0, 1e-15);
        EXPECT_NEAR(ci, std::cos(deg(a)), 1e-15);
        EXPECT_NEAR(ct, t.z, 1e-15);
        const Vec3 r = reflect(d, n);
        EXPECT_NEAR(r.x, d.x, 1e-15);
        EXPECT_NEAR(r.z, -d.z, 1e-15);
    }
    Vec3 out{7.0, 7.0, 7.0};
    double ci = 0.0, ct = 0.0;
    EXPECT_FALSE(refract(Vec3{std::sin(deg(50.0)), 0.0, std::cos(deg(50.0))}, n, 1.5, 1.0, out, ci, ct));
    EXPECT_EQ(out.x, 7.0);
}

TEST(Coating, ZeroThicknessStackIsBareFresnel) {
    const FilmLayer layers[] = {{1.38, 0.0}, {2.1, 0.0}, {1.46, 0.0}};
    for (double c = 0.0; c <= 1.0; c += 0.01) {
        for (auto [n1, n2] : {std::pair{1.0, 1.52}, std::pair{1.7, 1.0}}) {
            const Reflectance m = multilayer_reflectance(layers, n1, n2, c, 550.0);
            const Reflectance f = fresnel_unpolarized(n1, n2, c);
            EXPECT_NEAR(m.R, f.R, 1e-13) << c;
            EXPECT_NEAR(m.T, f.T, 1e-13) << c;
        }
    }
}

TEST(Coating, SingleLayerMatrixEqualsClosedForm) {
    double worst = 0.0;
    for (double thickness : {0.0, 50.0, 99.6, 180.0, 1000.0}) {
        const FilmLayer layer{1.38, thickness};
        for (double nm = 360.0; nm <= 830.0; nm += 47.0) {
            for (double c = 0.0; c <= 1.0; c += 0.02) {
                for (auto [n1, n2] : {std::pair{1.0, 1.52}, std::pair{1.52, 1.0}, std::pair{1.9, 1.0}}) {
                    const Reflectance a = single_layer_reflectance(layer, n1, n2, c, nm);
                    const Reflectance b = multilayer_reflectance({&layer, 1}, n1, n2, c, nm);
                    worst = std::max({worst, std::abs(a.R - b.R), std::abs(a.T - b.T)});
                }
            }
        }
    }
    EXPECT_LT(worst, 1e-12);
}

TEST(Coating, EnergyConservedForLosslessStacks) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> idx(1.3, 2.4), thick(0.0, 400.0), cosd(0.0, 1.0), wl(360.0, 830.0);
    double worst = 0.0;
    for (int trial = 0; trial < 3000; ++trial) {
        std::vector<FilmLayer> layers(1 + trial % 7);
        for (auto& l : layers) l = {idx(rng), thick(rng)};
        const double n1 = trial % 2 ? 1.0 : idx(rng);
        const double n2 = trial % 3 ? idx(rng) : 1.0;
        const Reflectance r = multilayer_reflectance(layers, n1, n2, cosd(rng), wl(rng));
        ASSERT_TRUE(std::isfinite(r.R) && std::isfinite(r.T));
        worst = std::max(worst, std::abs(r.R + r.T - 1.0));
    }
    EXPECT_LT(worst, 1e-12);
}

TEST(Coating, QuarterWaveMatchesTheClassicFormulaAndThePaper) {
    // Paper figure 4: n_glass 1.5, MgF2 1.38, designed for 532 nm (d = 96.4 nm) at normal incidence.
    Coating c;
    c.kind = Coating::Kind::QuarterWave;
    c.design_wavelength_nm = 532.0;
    const Glass glass = glass_from_abbe(1.5, 60.0);
    const ResolvedCoating rc = resolve_coating(c, Glass::air(), glass, 532.0);
    ASSERT_EQ(rc.layers.size(), 1u);
    EXPECT_NEAR(rc.layers[0].thickness_nm, 96.4, 0.05);
    const double ng = glass.index(532.0);
    const double q = (1.0 * ng - 1.38 * 1.38) / (1.0 * ng + 1.38 * 1.38);
    const Reflectance r = coated_reflectance(rc, 1.0, ng, 1.0, 532.0, true);
    EXPECT_NEAR(r.R, q * q, 1e-14);
    EXPECT_LT(r.R, 0.5 * fresnel_unpolarized(1.0, ng, 1.0).R);
    // Off the design wavelength the reflectance rises.
    EXPECT_GT(coated_reflectance(rc, 1.0, ng, 1.0, 400.0, true).R, r.R);
    // The ideal index sqrt(n0 n2) cancels the reflection at the design wavelength.
    c.layer_index = 0.0;
    const ResolvedCoating ideal = resolve_coating(c, Glass::air(), glass, 532.0);
    EXPECT_NEAR(coated_reflectance(ideal, 1.0, ng, 1.0, 532.0, true).R, 0.0, 1e-15);
    // A thickness offset detunes it (the Stingray notes' control).
    c.thickness_offset = 0.5;
    const ResolvedCoating thick = resolve_coating(c, Glass::air(), glass, 532.0);
    EXPECT_GT(coated_reflectance(thick, 1.0, ng, 1.0, 532.0, true).R, 1e-3);
}

TEST(Coating, ReciprocityFromEitherSide) {
    // A lossless stack reflects the same fraction of a ray and of its reversed refracted ray.
    Coating c;
    c.kind = Coating::Kind::Stack;
    c.layers = {{glass_from_abbe(1.38, 95.0), 110.0}, {glass_from_abbe(2.05, 25.0), 60.0}, {glass_from_abbe(1.62, 60.0), 85.0}};
    const Glass glass = *catalog_glass("N-SF6");
    for (double nm : {450.0, 550.0, 650.0}) {
        const ResolvedCoating rc = resolve_coating(c, Glass::air(), glass, nm);
        const double ng = glass.index(nm);
        for (double a = 0.0; a < 89.0; a += 3.0) {
            const double c1 = std::cos(deg(a));
            const double c2 = cos_transmitted(1.0, ng, c1);
            const Reflectance front = coated_reflectance(rc, 1.0, ng, c1, nm, true);
            const Reflectance back = coated_reflectance(rc, ng, 1.0, c2, nm, false);
            EXPECT_NEAR(front.R, back.R, 1e-12) << nm << " nm, " << a << " deg";
            EXPECT_NEAR(front.R + front.T, 1.0, 1e-12);
        }
    }
}

TEST(Coating, GrazingAndTirNeverNaN) {
    const FilmLayer layers[] = {{1.38, 99.0}, {2.0, 70.0}};
    for (double c : {0.0, 1e-300, 1e-160, 1e-12, 0.5}) {
        for (auto [n1, n2] : {std::pair{1.0, 1.5}, std::pair{1.8, 1.0}, std::pair{1.5, 1.5}}) {
            const Reflectance r = multilayer_reflectance(layers, n1, n2, c, 500.0);
            EXPECT_TRUE(std::isfinite(r.R) && std::isfinite(r.T));
            EXPECT_NEAR(r.R + r.T, 1.0, 1e-12) << c << " " << n1 << " " << n2;
        }
    }
    // TIR into the substrate through a layer: everything reflected.
    const Reflectance tir = multilayer_reflectance(layers, 1.8, 1.0, std::cos(deg(70.0)), 500.0);
    EXPECT_NEAR(tir.R, 1.0, 1e-12);
    EXPECT_NEAR(tir.T, 0.0, 1e-12);
}
