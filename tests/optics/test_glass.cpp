// Glass catalog and dispersion models: the makers' nd/Vd reproduced by every catalog row's own formula,
// name lookup rules, and the nd/Vd (Abbe) model.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include <optics/glass.h>

using namespace lensfx::optics;

namespace {

// Measured over the catalog (see AbbeModelIsCloseToRealGlasses): median 2.8e-4, 90th percentile 1.4e-3,
// worst 1.3e-2 over 400-700 nm; worst 4.9e-2 at 360/830 nm. Bounds: those, rounded up.
constexpr double kAbbeVisMedian = 3e-4;
constexpr double kAbbeVisP90 = 1.5e-3;
constexpr double kAbbeVisBound = 1.5e-2;
constexpr double kAbbeEndsBound = 5e-2;

double abbe_number(const Glass& g) { return (g.index(kLineD_nm) - 1.0) / (g.index(kLineF_nm) - g.index(kLineC_nm)); }

}  // namespace

TEST(Glass, IssueReferenceIndices) {
    const auto bk7 = catalog_glass("N-BK7");
    const auto sf6 = catalog_glass("N-SF6");
    ASSERT_TRUE(bk7 && sf6);
    EXPECT_NEAR(bk7->index(587.56), 1.5168, 5e-6);
    EXPECT_NEAR(sf6->index(587.56), 1.80518, 5e-6);
    EXPECT_EQ(bk7->catalog, "schott");
    EXPECT_EQ(bk7->formula, Glass::Formula::Sellmeier);
}

TEST(Glass, EveryCatalogRowReproducesItsNdAndVd) {
    const auto names = catalog_glass_names();
    ASSERT_EQ(names.size(), 1609u);
    double worst_nd = 0.0, worst_vd = 0.0;
    for (const auto& name : names) {
        const auto g = catalog_glass(name);
        ASSERT_TRUE(g) << name;
        const double dn = std::abs(g->index(kLineD_nm) - g->nd);
        const double dv = std::abs(abbe_number(*g) - g->vd);
        worst_nd = std::max(worst_nd, dn);
        worst_vd = std::max(worst_vd, dv);
        // The README of the reference data measured max 3.8e-5 (nd) and 0.23 (Vd), all sumita.
        EXPECT_LT(dn, 5e-5) << name;
        EXPECT_LT(dv, 0.25) << name;
        for (double nm : {360.0, 450.0, 550.0, 650.0, 830.0}) {
            const double n = g->index(nm);
            EXPECT_TRUE(std::isfinite(n) && n > 1.2 && n < 2.5) << name << " at " << nm << " nm: " << n;
        }
    }
    RecordProperty("worst_nd", std::to_string(worst_nd));
    RecordProperty("worst_vd", std::to_string(worst_vd));
}

TEST(Glass, PolynomialFormulaMatchesTheReadmeExample) {
    // hoya BAC4, formula 3, written out by hand from the reference README.
    const auto g = catalog_glass("hoya:BAC4");
    ASSERT_TRUE(g);
    EXPECT_EQ(g->formula, Glass::Formula::Polynomial);
    const double l = 0.5;
    const double n2 = 2.4196645 - 0.0083329314 * l * l + 0.01539739 / (l * l) - 0.00017391654 / std::pow(l, 4) +
                      6.218322e-05 / std::pow(l, 6) - 3.062131e-06 / std::pow(l, 8);
    EXPECT_NEAR(g->index(500.0), std::sqrt(n2), 1e-12);
}

TEST(Glass, LookupIsCaseInsensitiveWithOptionalMaker) {
    EXPECT_TRUE(catalog_glass("n-bk7"));
    EXPECT_TRUE(catalog_glass("SCHOTT:N-BK7"));
    EXPECT_TRUE(catalog_glass("  schott : n-bk7 "));
    EXPECT_FALSE(catalog_glass("ohara:N-BK7"));
    EXPECT_FALSE(catalog_glass("unobtainium"));
    EXPECT_FALSE(catalog_glass(""));
    // F2 exists at schott (nd 1.62004), hikari (1.62004) and cdgm (1.612929): schott is preferred.
    const auto f2 = catalog_glass("F2");
    ASSERT_TRUE(f2);
    EXPECT_EQ(f2->catalog, "schott");
    const auto cdgm_f2 = catalog_glass("cdgm:F2");
    ASSERT_TRUE(cdgm_f2);
    EXPECT_NEAR(cdgm_f2->index(kLineD_nm), 1.612929, 1e-6);
    // BAF10: hikari and hoya only; hikari comes first in kCatalogMakers.
    const auto baf10 = catalog_glass("BAF10");
    ASSERT_TRUE(baf10);
    EXPECT_EQ(baf10->catalog, "hikari");
}

TEST(Glass, AbbeModelReproducesNdAndVd) {
    for (double nd : {1.45, 1.5168, 1.62, 1.75, 1.9, 2.0}) {
        for (double vd : {20.0, 30.0, 45.0, 64.17, 80.0, 95.0}) {
            Glass g;
            try {
                g = glass_from_abbe(nd, vd);
            } catch (const std::invalid_argument&) {
                // Only combinations far from real glasses may be refused.
                EXPECT_TRUE(nd > 1.85 && vd > 60.0) << nd << " " << vd;
                continue;
            }
            EXPECT_NEAR(g.index(kLineD_nm), nd, 1e-12);
            EXPECT_NEAR(abbe_number(g), vd, 1e-9 * vd);
            double prev = 10.0;
            for (double nm = 360.0; nm <= 830.0; nm += 10.0) {
                const double n = g.index(nm);
                EXPECT_LT(n, prev) << "normal dispersion: n falls with wavelength";
                prev = n;
            }
        }
    }
    EXPECT_THROW(glass_from_abbe(0.9, 50.0), std::invalid_argument);
    EXPECT_THROW(glass_from_abbe(1.5, -1.0), std::invalid_argument);
}

TEST(Glass, AbbeModelIsCloseToRealGlasses) {
    // Over the whole catalog (glasses the model can represent), the largest index error of the nd/Vd model
    // against the makers' formulas at 400-700 nm and at 360/830 nm. Bounds set from the measured values
    // (printed), rounded up: a regression guard for the model, not a claim about a particular glass.
    double worst_vis = 0.0, worst_ends = 0.0;
    std::vector<double> per_glass;
    int modelled = 0;
    for (const auto& name : catalog_glass_names()) {
        const auto g = catalog_glass(name);
        Glass m;
        try {
            m = glass_from_abbe(g->nd, g->vd);
        } catch (const std::invalid_argument&) {
            continue;
        }
        ++modelled;
        double e = 0.0;
        for (double nm = 400.0; nm <= 700.0; nm += 25.0) e = std::max(e, std::abs(m.index(nm) - g->index(nm)));
        per_glass.push_back(e);
        worst_vis = std::max(worst_vis, e);
        for (double nm : {360.0, 830.0}) worst_ends = std::max(worst_ends, std::abs(m.index(nm) - g->index(nm)));
    }
    std::sort(per_glass.begin(), per_glass.end());
    const double median = per_glass[per_glass.size() / 2];
    const double p90 = per_glass[per_glass.size() * 9 / 10];
    std::printf("abbe model over %d catalog glasses, max |dn| 400-700 nm: median %.2e, p90 %.2e, worst %.2e; "
                "at 360/830 nm worst %.2e\n", modelled, median, p90, worst_vis, worst_ends);
    EXPECT_GT(modelled, 1500);
    EXPECT_LT(median, kAbbeVisMedian);
    EXPECT_LT(p90, kAbbeVisP90);
    EXPECT_LT(worst_vis, kAbbeVisBound);
    EXPECT_LT(worst_ends, kAbbeEndsBound);
}

TEST(Glass, SameMedium) {
    EXPECT_TRUE(same_medium(Glass::air(), Glass::air()));
    EXPECT_TRUE(same_medium(*catalog_glass("N-BK7"), *catalog_glass("schott:n-bk7")));
    EXPECT_FALSE(same_medium(*catalog_glass("N-BK7"), Glass::air()));
    EXPECT_FALSE(same_medium(*catalog_glass("F2"), *catalog_glass("hikari:F2")));
}
