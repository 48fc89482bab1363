// Placeholder: the catalog and dispersion models land with issue 3.
#include <optics/glass.h>

namespace lensfx::optics {
double Glass::index(double) const { return nd; }
std::optional<Glass> catalog_glass(std::string_view) { return std::nullopt; }
Glass glass_from_abbe(double nd, double vd, std::string name) {
    Glass g;
    g.name = std::move(name);
    g.formula = Glass::Formula::Abbe;
    g.nd = nd;
    g.vd = vd;
    return g;
}
}  // namespace lensfx::optics
