// The compiled-in glass catalog table (generated from optics/data/glass.csv at build time); private to
// lensfx_optics, read through catalog_glass() in <optics/glass.h>.
#pragma once

#include <cstddef>

namespace lensfx::optics::detail {

struct CatalogEntry {
    const char* maker;
    const char* name;
    int formula;          // refractiveindex.info formula: 2 Sellmeier-2, 3 polynomial
    double c[7];          // c0, b1, c1, b2, c2, b3, c3 (file order)
    double nd, vd;
    double lambda_min_um, lambda_max_um;
    int extra_count;
    double extra[8];      // coefficients 8.. (formula 3: coefficient, exponent pairs)
};

extern const CatalogEntry kGlassCatalog[];
extern const std::size_t kGlassCatalogSize;

}  // namespace lensfx::optics::detail
