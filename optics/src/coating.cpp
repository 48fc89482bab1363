#include <optics/coating.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

#include <optics/random.h>

namespace lensfx::optics {

namespace {

using cplx = std::complex<double>;

// Smallest cosine used inside the admittance formulas: p admittances are n / cos, so an exact zero
// (grazing) would divide by zero. Changes R by less than 1e-140 for angles closer to grazing.
constexpr double kMinCos = 1e-150;

// cos(theta_k) in a medium of index n_k for the invariant n_in sin(theta_in), on the branch with
// Im <= 0 (an evanescent wave decays with the e^{-i delta} phase convention used below).
cplx cos_in_medium(double n_k, double n_sin) {
    const double s = n_sin / n_k;
    const double c2 = (1.0 - s) * (1.0 + s);
    cplx c = c2 >= 0.0 ? cplx(std::sqrt(c2), 0.0) : cplx(0.0, -std::sqrt(-c2));
    if (std::abs(c) < kMinCos) c = cplx(kMinCos, 0.0);
    return c;
}

// Tilted optical admittance (units of the free-space admittance): s: n cos, p: n / cos.
cplx admittance(double n, cplx c, bool p) { return p ? n / c : n * c; }

Reflectance finite_or_total(double R, double T) {
    if (!std::isfinite(R) || !std::isfinite(T)) return {1.0, 0.0};
    return {R, T};
}

template <class LayerAt>
Reflectance matrix_one_polarisation(std::size_t count, LayerAt layer_at, double n_in, double n_out, double ci,
                                    double wavelength_nm, bool p) {
    const double n_sin = n_in * std::sqrt(std::max(0.0, (1.0 - ci) * (1.0 + ci)));
    const cplx eta0 = admittance(n_in, cplx(ci, 0.0), p);
    const cplx eta_s = admittance(n_out, cos_in_medium(n_out, n_sin), p);
    // [B; C] = M_1 ... M_k [1; eta_s], multiplied from the substrate side.
    cplx B = 1.0;
    cplx C = eta_s;
    for (std::size_t k = count; k-- > 0;) {
        const FilmLayer& L = layer_at(k);
        const cplx c = cos_in_medium(L.index, n_sin);
        const cplx delta = 2.0 * std::numbers::pi * L.index * L.thickness_nm * c / wavelength_nm;
        const cplx eta = admittance(L.index, c, p);
        const cplx cd = std::cos(delta);
        const cplx sd = std::sin(delta);
        const cplx i(0.0, 1.0);
        const cplx nB = cd * B + i * sd / eta * C;
        const cplx nC = i * eta * sd * B + cd * C;
        B = nB;
        C = nC;
    }
    const cplx denom = eta0 * B + C;
    const cplx r = (eta0 * B - C) / denom;
    const double T = 4.0 * eta0.real() * eta_s.real() / std::norm(denom);
    return finite_or_total(std::norm(r), T);
}

// The propagating case (real cosines in the layer and the substrate) in real arithmetic: the ray
// tracer's hot path. r = (r01 + r12 e^{-2i beta}) / (1 + r01 r12 e^{-2i beta}) with real r01, r12.
bool single_layer_real(const FilmLayer& layer, double n_in, double n_out, double ci, double wavelength_nm,
                       Reflectance& s_out, Reflectance& p_out) {
    const double sin2 = std::max(0.0, (1.0 - ci) * (1.0 + ci));
    const double n_sin2 = n_in * n_in * sin2;
    const double c1_2 = 1.0 - n_sin2 / (layer.index * layer.index);
    const double c2_2 = 1.0 - n_sin2 / (n_out * n_out);
    if (c1_2 <= kMinCos || c2_2 <= kMinCos) return false;
    const double c1 = std::sqrt(c1_2);
    const double c2 = std::sqrt(c2_2);
    const double cos2b = std::cos(4.0 * std::numbers::pi * layer.index * layer.thickness_nm * c1 / wavelength_nm);
    const auto one = [&](double e0, double e1, double e2) {
        const double r01 = (e0 - e1) / (e0 + e1);
        const double r12 = (e1 - e2) / (e1 + e2);
        const double t01 = 2.0 * e0 / (e0 + e1);
        const double t12 = 2.0 * e1 / (e1 + e2);
        const double cross = 2.0 * r01 * r12 * cos2b;
        const double den = 1.0 + r01 * r01 * r12 * r12 + cross;
        return Reflectance{(r01 * r01 + r12 * r12 + cross) / den, e2 / e0 * t01 * t01 * t12 * t12 / den};
    };
    s_out = one(n_in * ci, layer.index * c1, n_out * c2);
    p_out = one(n_in / ci, layer.index / c1, n_out / c2);
    return std::isfinite(s_out.R + s_out.T + p_out.R + p_out.T);
}

Reflectance single_layer_one_polarisation(const FilmLayer& layer, double n_in, double n_out, double ci,
                                          double wavelength_nm, bool p) {
    const double n_sin = n_in * std::sqrt(std::max(0.0, (1.0 - ci) * (1.0 + ci)));
    const cplx eta0 = admittance(n_in, cplx(ci, 0.0), p);
    const cplx c1 = cos_in_medium(layer.index, n_sin);
    const cplx eta1 = admittance(layer.index, c1, p);
    const cplx eta2 = admittance(n_out, cos_in_medium(n_out, n_sin), p);
    const cplx r01 = (eta0 - eta1) / (eta0 + eta1);
    const cplx r12 = (eta1 - eta2) / (eta1 + eta2);
    const cplx t01 = 2.0 * eta0 / (eta0 + eta1);
    const cplx t12 = 2.0 * eta1 / (eta1 + eta2);
    const cplx beta = 2.0 * std::numbers::pi * layer.index * layer.thickness_nm * c1 / wavelength_nm;
    const cplx phase = std::exp(cplx(0.0, -1.0) * beta);  // one pass through the layer
    const cplx loop = 1.0 + r01 * r12 * phase * phase;
    const cplx r = (r01 + r12 * phase * phase) / loop;
    const cplx t = t01 * t12 * phase / loop;  // tangential field amplitude
    const double T = eta2.real() / eta0.real() * std::norm(t);
    return finite_or_total(std::norm(r), T);
}

double clamp_cos(double c) { return std::isnan(c) ? 0.0 : std::clamp(c, 0.0, 1.0); }

// A layer of index n and `qwot` quarter waves of optical thickness at wavelength nm.
FilmLayer quarter_waves(double n, double qwot, double nm) { return {n, qwot * nm / (4.0 * n)}; }

// Two layers n1 (air side), n2 (glass side) with zero reflectance at nm on glass ns from air n0: the
// closed-form V-coat (Macleod 4.2), the thinner-first-layer root. Empty when these indices have none.
std::vector<FilmLayer> v_coat(double n0, double n1, double n2, double ns, double nm) {
    const double d = (n1 * n1 * ns - n0 * n2 * n2);
    const double tan2_1 = (ns - n0) * (n2 * n2 - n0 * ns) * n1 * n1 / (d * (n0 * ns - n1 * n1));
    const double tan2_2 = (ns - n0) * (n0 * ns - n1 * n1) * n2 * n2 / (d * (n2 * n2 - n0 * ns));
    if (!(tan2_1 > 0.0) || !(tan2_2 > 0.0) || !std::isfinite(tan2_1) || !std::isfinite(tan2_2)) return {};
    const double delta1 = std::atan(std::sqrt(tan2_1));
    const double delta2 = std::numbers::pi - std::atan(std::sqrt(tan2_2));
    return {{n1, delta1 * nm / (2.0 * std::numbers::pi * n1)}, {n2, delta2 * nm / (2.0 * std::numbers::pi * n2)}};
}

// One normal deviate (Box-Muller) from the generator.
double normal(Random& random) {
    const double u = std::max(random.uniform(), 1e-300);
    return std::sqrt(-2.0 * std::log(u)) * std::cos(2.0 * std::numbers::pi * random.uniform());
}

// Layers of a design on the glass side of an interface, listed from the object side.
std::vector<FilmLayer> design_on(const Coating& coating, const Glass& before, const Glass& after) {
    const double nm = coating.design_wavelength_nm;
    const double nb = before.index(nm), na = after.index(nm);
    std::vector<FilmLayer> layers = design_layers(coating.design, nm, std::min(nb, na), std::max(nb, na));
    if (nb > na) std::reverse(layers.begin(), layers.end());  // the glass is on the object side
    return layers;
}

}  // namespace

std::vector<FilmLayer> design_layers(Coating::Design design, double nm, double n_air, double n_glass) {
    if (!(nm > 0.0) || !(n_air >= 1.0) || !(n_glass > n_air))
        throw std::invalid_argument(fmt::format("coating design {}: needs a design wavelength ({} nm) and glass denser than air ({} on {})",
                                                design_name(design), nm, n_glass, n_air));
    switch (design) {
        case Coating::Design::VCoat: {
            std::vector<FilmLayer> layers = v_coat(n_air, kLowIndex, kHighIndex, n_glass, nm);
            if (layers.empty()) layers = {quarter_waves(kLowIndex, 1.0, nm)};  // glass about 1.9: MgF2 alone is ideal
            return layers;
        }
        case Coating::Design::QuarterHalfQuarter:
            return {quarter_waves(kLowIndex, 1.0, nm), quarter_waves(kHighIndex, 2.0, nm),
                    quarter_waves(kMediumIndex * std::sqrt(n_glass / 1.52), 1.0, nm)};
        case Coating::Design::Broadband4:
            return {quarter_waves(kLowIndex, 0.96, nm), quarter_waves(kHighIndex, 1.96, nm),
                    quarter_waves(kLowIndex, std::clamp(0.32 * (1.9 - n_glass) / 0.38, 0.03, 0.4), nm),
                    quarter_waves(kHighIndex, std::clamp(0.20 * (1.85 - n_glass) / 0.33, 0.01, 0.3), nm)};
    }
    return {};
}

std::optional<Coating::Design> parse_design(std::string_view name) {
    if (name == "v-coat") return Coating::Design::VCoat;
    if (name == "broadband-3") return Coating::Design::QuarterHalfQuarter;
    if (name == "broadband-4") return Coating::Design::Broadband4;
    return std::nullopt;
}

const char* design_name(Coating::Design design) {
    switch (design) {
        case Coating::Design::VCoat: return "v-coat";
        case Coating::Design::QuarterHalfQuarter: return "broadband-3";
        case Coating::Design::Broadband4: return "broadband-4";
    }
    return "?";
}

CoatingChoice parse_coating_choice(std::string_view text) {
    if (text == "uncoated" || text == "none") return CoatingChoice::Uncoated;
    if (text == "single") return CoatingChoice::Single;
    if (text == "multi") return CoatingChoice::Multi;
    if (text == "lens") return CoatingChoice::Lens;
    throw std::invalid_argument(fmt::format("--coating {}: uncoated, single, multi or lens", text));
}

void choose_coatings(System& system, CoatingChoice choice, double spread, std::uint64_t seed) {
    if (!(spread >= 0.0) || !(spread < 0.5))
        throw std::invalid_argument(fmt::format("--coating-spread {}: a relative thickness spread in [0, 0.5)", spread));
    for (std::size_t i = 0; i < system.interfaces.size(); ++i) {
        System::Interface& s = system.interfaces[i];
        const bool air_glass = !s.is_stop && s.before.is_air() != s.after.is_air();
        if (choice != CoatingChoice::Lens && air_glass) {
            Coating c;
            if (choice == CoatingChoice::Single) c.kind = Coating::Kind::QuarterWave;
            if (choice == CoatingChoice::Multi) c.kind = Coating::Kind::Design;
            s.coating = c;
        }
        s.coating.layer_errors.clear();
        if (s.coating.kind == Coating::Kind::None || spread == 0.0) continue;
        Random random(seed * 0x9e3779b97f4a7c15ULL + i + 1);
        for (int k = 0; k < 4; ++k) s.coating.layer_errors.push_back(spread * normal(random));
        s.coating.layer_errors.resize(std::max<std::size_t>(4, s.coating.layers.size()), 0.0);
        for (std::size_t k = 4; k < s.coating.layer_errors.size(); ++k) s.coating.layer_errors[k] = spread * normal(random);
    }
}

ResolvedCoating resolve_coating(const Coating& coating, const Glass& before, const Glass& after,
                                double wavelength_nm) {
    ResolvedCoating out;
    switch (coating.kind) {
        case Coating::Kind::None: break;
        case Coating::Kind::QuarterWave: {
            double n = coating.layer_index;
            if (n <= 0.0) n = std::sqrt(before.index(coating.design_wavelength_nm) * after.index(coating.design_wavelength_nm));
            if (!(coating.design_wavelength_nm > 0.0) || !std::isfinite(n) || !(1.0 + coating.thickness_offset >= 0.0))
                throw std::invalid_argument(fmt::format(
                    "quarter-wave coating: bad design wavelength {} nm, layer index {} or thickness offset {}",
                    coating.design_wavelength_nm, n, coating.thickness_offset));
            out.layers.push_back({n, coating.design_wavelength_nm / (4.0 * n) * (1.0 + coating.thickness_offset)});
            break;
        }
        case Coating::Kind::Stack:
            for (std::size_t i = 0; i < coating.layers.size(); ++i) {
                const auto& L = coating.layers[i];
                const double n = L.material.index(wavelength_nm);
                if (!(L.thickness_nm >= 0.0) || !std::isfinite(L.thickness_nm))
                    throw std::invalid_argument(
                        fmt::format("coating layer {} ({}): bad thickness {} nm", i + 1, L.material.name, L.thickness_nm));
                out.layers.push_back({n, L.thickness_nm});
            }
            break;
        case Coating::Kind::Design: out.layers = design_on(coating, before, after); break;
    }
    for (std::size_t i = 0; i < out.layers.size() && i < coating.layer_errors.size(); ++i)
        out.layers[i].thickness_nm *= std::max(0.0, 1.0 + coating.layer_errors[i]);
    return out;
}

Reflectance multilayer_reflectance(std::span<const FilmLayer> layers, double n_in, double n_out, double cos_i,
                                   double wavelength_nm) {
    const double ci0 = clamp_cos(cos_i);
    if (layers.empty() || ci0 == 0.0) {
        if (n_in == n_out && layers.empty()) return {0.0, 1.0};
        if (ci0 == 0.0) return {1.0, 0.0};
    }
    const double ci = std::max(ci0, kMinCos);
    auto at = [&](std::size_t k) -> const FilmLayer& { return layers[k]; };
    const Reflectance s = matrix_one_polarisation(layers.size(), at, n_in, n_out, ci, wavelength_nm, false);
    const Reflectance p = matrix_one_polarisation(layers.size(), at, n_in, n_out, ci, wavelength_nm, true);
    return {0.5 * (s.R + p.R), 0.5 * (s.T + p.T)};
}

Reflectance single_layer_reflectance(const FilmLayer& layer, double n_in, double n_out, double cos_i,
                                     double wavelength_nm) {
    const double ci0 = clamp_cos(cos_i);
    if (ci0 == 0.0) return {1.0, 0.0};
    const double ci = std::max(ci0, kMinCos);
    Reflectance rs, rp;
    if (single_layer_real(layer, n_in, n_out, ci, wavelength_nm, rs, rp)) return {0.5 * (rs.R + rp.R), 0.5 * (rs.T + rp.T)};
    const Reflectance s = single_layer_one_polarisation(layer, n_in, n_out, ci, wavelength_nm, false);
    const Reflectance p = single_layer_one_polarisation(layer, n_in, n_out, ci, wavelength_nm, true);
    return {0.5 * (s.R + p.R), 0.5 * (s.T + p.T)};
}

Reflectance coated_reflectance(const ResolvedCoating& coating, double n_in, double n_out, double cos_i,
                               double wavelength_nm, bool from_object_side) {
    const auto& L = coating.layers;
    if (L.empty()) return fresnel_unpolarized(n_in, n_out, cos_i);
    if (L.size() == 1) return single_layer_reflectance(L[0], n_in, n_out, cos_i, wavelength_nm);
    const double ci0 = clamp_cos(cos_i);
    if (ci0 == 0.0) return {1.0, 0.0};
    const double ci = std::max(ci0, kMinCos);
    const std::size_t n = L.size();
    auto at = [&](std::size_t k) -> const FilmLayer& { return from_object_side ? L[k] : L[n - 1 - k]; };
    const Reflectance s = matrix_one_polarisation(n, at, n_in, n_out, ci, wavelength_nm, false);
    const Reflectance p = matrix_one_polarisation(n, at, n_in, n_out, ci, wavelength_nm, true);
    return {0.5 * (s.R + p.R), 0.5 * (s.T + p.T)};
}

}  // namespace lensfx::optics
