#include <filter/colour.h>
#include <filter/float_range.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <fmt/core.h>
#include <fmt/format.h>

#include "option_checks.h"

namespace lensfx::colour {

// ---------------------------------------------------------------------------------------------------------
// Matrices and primaries

Mat3 multiply(const Mat3& a, const Mat3& b) {
    Mat3 r{};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) r[3 * i + j] += a[3 * i + k] * b[3 * k + j];
    return r;
}

Mat3 inverse(const Mat3& m) {
    const double c00 = m[4] * m[8] - m[5] * m[7];
    const double c01 = m[5] * m[6] - m[3] * m[8];
    const double c02 = m[3] * m[7] - m[4] * m[6];
    const double det = m[0] * c00 + m[1] * c01 + m[2] * c02;
    double scale = 0.0;
    for (double v : m) scale = std::max(scale, std::abs(v));
    if (!(std::abs(det) > 1e-12 * scale * scale * scale))
        throw std::invalid_argument("colour: singular 3x3 matrix (degenerate primaries?)");
    const double s = 1.0 / det;
    return {c00 * s, (m[2] * m[7] - m[1] * m[8]) * s, (m[1] * m[5] - m[2] * m[4]) * s,
            c01 * s, (m[0] * m[8] - m[2] * m[6]) * s, (m[2] * m[3] - m[0] * m[5]) * s,
            c02 * s, (m[1] * m[6] - m[0] * m[7]) * s, (m[0] * m[4] - m[1] * m[3]) * s};
}

namespace {

std::array<double, 3> apply3(const Mat3& m, const std::array<double, 3>& v) {
    return {m[0] * v[0] + m[1] * v[1] + m[2] * v[2], m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
            m[6] * v[0] + m[7] * v[1] + m[8] * v[2]};
}

std::array<double, 3> xy_to_xyz(double x, double y) { return {x / y, 1.0, (1.0 - x - y) / y}; }

// D65 as OCIO's built-in transforms and ITU-R BT.709 state it.
constexpr double d65_x = 0.3127, d65_y = 0.3290;

// An EXR chromaticities attribute (float) as Chromaticities (double).
Chromaticities widened(const std::array<float, 8>& c) {
    const auto d = [&](std::size_t i) { return static_cast<double>(c[i]); };
    return {d(0), d(1), d(2), d(3), d(4), d(5), d(6), d(7)};
}

}  // namespace

Chromaticities chromaticities(KnownPrimaries p) {
    switch (p) {
        case KnownPrimaries::Rec709: return {0.64, 0.33, 0.30, 0.60, 0.15, 0.06, d65_x, d65_y};
        case KnownPrimaries::AcesAP0: return {0.7347, 0.2653, 0.0, 1.0, 0.0001, -0.0770, 0.32168, 0.33767};
        case KnownPrimaries::AcesAP1: return {0.713, 0.293, 0.165, 0.830, 0.128, 0.044, 0.32168, 0.33767};
        case KnownPrimaries::Rec2020: return {0.708, 0.292, 0.170, 0.797, 0.131, 0.046, d65_x, d65_y};
        case KnownPrimaries::P3D65: return {0.680, 0.320, 0.265, 0.690, 0.150, 0.060, d65_x, d65_y};
    }
    throw std::invalid_argument("colour: unknown primaries");
}

std::string_view name(KnownPrimaries p) {
    switch (p) {
        case KnownPrimaries::Rec709: return "Rec.709";
        case KnownPrimaries::AcesAP0: return "ACES AP0";
        case KnownPrimaries::AcesAP1: return "ACES AP1";
        case KnownPrimaries::Rec2020: return "Rec.2020";
        case KnownPrimaries::P3D65: return "P3-D65";
    }
    return "?";
}

std::optional<KnownPrimaries> identify_primaries(const std::array<float, 8>& c, double tolerance) {
    for (auto p : {KnownPrimaries::Rec709, KnownPrimaries::AcesAP0, KnownPrimaries::AcesAP1,
                   KnownPrimaries::Rec2020, KnownPrimaries::P3D65}) {
        const Chromaticities k = chromaticities(p);
        const std::array<double, 8> ref{k.rx, k.ry, k.gx, k.gy, k.bx, k.by, k.wx, k.wy};
        bool match = true;
        for (std::size_t i = 0; i < 8 && match; ++i)
            match = std::abs(static_cast<double>(c[i]) - ref[i]) <= tolerance;
        if (match) return p;
    }
    return std::nullopt;
}

Mat3 rgb_to_xyz(const Chromaticities& c) {
    if (!(std::abs(c.wy) > 1e-9))
        throw std::invalid_argument(fmt::format("colour: white point with y = 0 (x {}, y {})", c.wx, c.wy));
    auto col = [](double x, double y) { return std::array<double, 3>{x, y, 1.0 - x - y}; };
    const auto r = col(c.rx, c.ry), g = col(c.gx, c.gy), b = col(c.bx, c.by);
    const Mat3 p{r[0], g[0], b[0], r[1], g[1], b[1], r[2], g[2], b[2]};
    const auto s = apply3(inverse(p), xy_to_xyz(c.wx, c.wy));
    return {p[0] * s[0], p[1] * s[1], p[2] * s[2], p[3] * s[0], p[4] * s[1],
            p[5] * s[2], p[6] * s[0], p[7] * s[1], p[8] * s[2]};
}

Mat3 bradford(double src_wx, double src_wy, double dst_wx, double dst_wy) {
    const Mat3 m{0.8951, 0.2664, -0.1614, -0.7502, 1.7135, 0.0367, 0.0389, -0.0685, 1.0296};
    const auto s = apply3(m, xy_to_xyz(src_wx, src_wy));
    const auto d = apply3(m, xy_to_xyz(dst_wx, dst_wy));
    const Mat3 scale{d[0] / s[0], 0, 0, 0, d[1] / s[1], 0, 0, 0, d[2] / s[2]};
    return multiply(inverse(m), multiply(scale, m));
}

std::array<double, 3> wavelength_to_rgb(double wavelength_nm, const Mat3& rgb_to_xyz_matrix) {
    return apply3(inverse(rgb_to_xyz_matrix), cie1931_xyz(wavelength_nm));
}

// ---------------------------------------------------------------------------------------------------------
// The built-in config

namespace {

std::string join(const std::vector<std::string>& v) {
    return v.empty() ? std::string("(none)") : fmt::format("{}", fmt::join(v, ", "));
}

OCIO::TransformRcPtr builtin_transform(const char* style, bool inverse_dir = false) {
    auto t = OCIO::BuiltinTransform::Create();
    t->setStyle(style);
    if (inverse_dir) t->setDirection(OCIO::TRANSFORM_DIR_INVERSE);
    return t;
}

OCIO::TransformRcPtr matrix_transform(const Mat3& m) {
    auto t = OCIO::MatrixTransform::Create();
    const double m44[16] = {m[0], m[1], m[2], 0, m[3], m[4], m[5], 0, m[6], m[7], m[8], 0, 0, 0, 0, 1};
    t->setMatrix(m44);
    return t;
}

constexpr const char* ap0_to_xyz_d65 = "UTILITY - ACES-AP0_to_CIE-XYZ-D65_BFD";

// A scene-linear RGB space -> ACES2065-1 (the built-in config's scene reference): RGB -> XYZ, Bradford
// to D65 when its white differs, then OCIO's AP0 <- XYZ-D65.
OCIO::TransformRcPtr rgb_to_aces_reference(const Chromaticities& c) {
    Mat3 m = rgb_to_xyz(c);
    if (std::abs(c.wx - d65_x) > 1e-5 || std::abs(c.wy - d65_y) > 1e-5)
        m = multiply(bradford(c.wx, c.wy, d65_x, d65_y), m);
    auto g = OCIO::GroupTransform::Create();
    g->appendTransform(matrix_transform(m));
    g->appendTransform(builtin_transform(ap0_to_xyz_d65, true));
    return g;
}

OCIO::ColorSpaceRcPtr scene_space(std::string_view name, std::string_view family, std::string_view description,
                                  OCIO::ConstTransformRcPtr to_reference) {
    auto cs = OCIO::ColorSpace::Create(OCIO::REFERENCE_SPACE_SCENE);
    cs->setName(std::string(name).c_str());
    cs->setFamily(std::string(family).c_str());
    cs->setDescription(std::string(description).c_str());
    cs->setEncoding("scene-linear");
    cs->setBitDepth(OCIO::BIT_DEPTH_F32);
    if (to_reference) cs->setTransform(to_reference, OCIO::COLORSPACE_DIR_TO_REFERENCE);
    return cs;
}

OCIO::ConstConfigRcPtr make_builtin_config() {
    auto cfg = OCIO::Config::Create();
    cfg->setMajorVersion(2);
    cfg->setMinorVersion(1);
    cfg->setName("lensfx-builtin");
    cfg->setDescription(
        "lensfx built-in config: ACES 1.x output transforms from OpenColorIO's built-in transforms. "
        "Scene reference ACES2065-1, display reference CIE XYZ D65.");

    cfg->addColorSpace(scene_space(builtin::aces2065_1, "ACES", "ACES2065-1 (AP0, scene-linear)", nullptr));
    cfg->addColorSpace(scene_space(builtin::acescg, "ACES", "ACEScg (AP1, scene-linear)",
                                   builtin_transform("ACEScg_to_ACES2065-1")));
    {
        auto g = OCIO::GroupTransform::Create();
        g->appendTransform(builtin_transform("UTILITY - ACES-AP1_to_LINEAR-REC709_BFD", true));
        g->appendTransform(builtin_transform("ACEScg_to_ACES2065-1"));
        cfg->addColorSpace(scene_space(builtin::lin_rec709, "Utility", "Linear Rec.709 / sRGB primaries, D65", g));
    }
    cfg->addColorSpace(scene_space(builtin::lin_rec2020, "Utility", "Linear Rec.2020 primaries, D65",
                                   rgb_to_aces_reference(chromaticities(KnownPrimaries::Rec2020))));
    cfg->addColorSpace(scene_space(builtin::lin_p3d65, "Utility", "Linear P3 primaries, D65",
                                   rgb_to_aces_reference(chromaticities(KnownPrimaries::P3D65))));
    cfg->addColorSpace(scene_space(builtin::xyz_d65, "Utility", "CIE XYZ, D65 white (Bradford from ACES)",
                                   builtin_transform(ap0_to_xyz_d65)));
    {
        auto raw = OCIO::ColorSpace::Create(OCIO::REFERENCE_SPACE_SCENE);
        raw->setName("Raw");
        raw->setFamily("Utility");
        raw->setDescription("Data: never converted");
        raw->setIsData(true);
        cfg->addColorSpace(raw);
    }

    struct DisplaySpace {
        std::string_view display;
        const char* space;
        const char* builtin;
    };
    const DisplaySpace display_spaces[] = {
        {builtin::display_srgb, "sRGB - Display", "DISPLAY - CIE-XYZ-D65_to_sRGB"},
        {builtin::display_rec709, "Rec.1886 Rec.709 - Display", "DISPLAY - CIE-XYZ-D65_to_REC.1886-REC.709"},
        {builtin::display_rec2100_pq, "Rec.2100-PQ - Display", "DISPLAY - CIE-XYZ-D65_to_REC.2100-PQ"},
    };
    for (const auto& d : display_spaces) {
        auto cs = OCIO::ColorSpace::Create(OCIO::REFERENCE_SPACE_DISPLAY);
        cs->setName(d.space);
        cs->setFamily("Display");
        cs->setEncoding(d.display == builtin::display_rec2100_pq ? "hdr-video" : "sdr-video");
        cs->setTransform(builtin_transform(d.builtin), OCIO::COLORSPACE_DIR_FROM_REFERENCE);
        cfg->addColorSpace(cs);
    }
    cfg->addColorSpace([] {
        auto cs = OCIO::ColorSpace::Create(OCIO::REFERENCE_SPACE_DISPLAY);
        cs->setName("CIE-XYZ-D65 - Display");
        cs->setFamily("Display");
        return cs;
    }());

    auto view_transform = [&](std::string_view name, const char* style, const char* description) {
        auto vt = OCIO::ViewTransform::Create(OCIO::REFERENCE_SPACE_SCENE);
        vt->setName(std::string(name).c_str());
        vt->setDescription(description);
        vt->setTransform(builtin_transform(style), OCIO::VIEWTRANSFORM_DIR_FROM_REFERENCE);
        cfg->addViewTransform(vt);
    };
    view_transform(builtin::view_sdr, "ACES-OUTPUT - ACES2065-1_to_CIE-XYZ-D65 - SDR-VIDEO_1.0",
                   "ACES 1.0 output transform, SDR video (100 nits)");
    view_transform(builtin::view_hdr, "ACES-OUTPUT - ACES2065-1_to_CIE-XYZ-D65 - HDR-VIDEO-1000nit-15nit-REC2020lim_1.1",
                   "ACES 1.1 output transform, HDR video 1000 nits, Rec.2020 limited");
    view_transform(builtin::view_untonemapped, ap0_to_xyz_d65, "No tone scale: scene 1.0 = display white");

    for (const auto& d : display_spaces) {
        const std::string display(d.display);
        const bool hdr = d.display == builtin::display_rec2100_pq;
        cfg->addDisplayView(display.c_str(), std::string(hdr ? builtin::view_hdr : builtin::view_sdr).c_str(),
                            std::string(hdr ? builtin::view_hdr : builtin::view_sdr).c_str(), d.space, "", "", "");
        cfg->addDisplayView(display.c_str(), std::string(builtin::view_untonemapped).c_str(),
                            std::string(builtin::view_untonemapped).c_str(), d.space, "", "", "");
    }
    cfg->setActiveDisplays(fmt::format("{}, {}, {}", builtin::display_srgb, builtin::display_rec709,
                                       builtin::display_rec2100_pq)
                               .c_str());

    auto look = [&](const char* name, const char* style, const char* description) {
        auto l = OCIO::Look::Create();
        l->setName(name);
        l->setProcessSpace(std::string(builtin::aces2065_1).c_str());
        l->setDescription(description);
        l->setTransform(builtin_transform(style));
        cfg->addLook(l);
    };
    look("Reference Gamut Compression", "ACES-LMT - ACES 1.3 Reference Gamut Compression",
         "ACES 1.3 reference gamut compression (brings out-of-gamut camera colours into AP1)");
    look("Blue Light Artifact Fix", "ACES-LMT - BLUE_LIGHT_ARTIFACT_FIX", "Desaturates saturated blue lights");

    cfg->setRole(OCIO::ROLE_SCENE_LINEAR, std::string(builtin::acescg).c_str());
    cfg->setRole(OCIO::ROLE_DEFAULT, std::string(builtin::lin_rec709).c_str());
    cfg->setRole(OCIO::ROLE_INTERCHANGE_SCENE, std::string(builtin::aces2065_1).c_str());
    cfg->setRole(OCIO::ROLE_INTERCHANGE_DISPLAY, "CIE-XYZ-D65 - Display");
    cfg->setRole(OCIO::ROLE_DATA, "Raw");
    cfg->setRole(OCIO::ROLE_COLOR_PICKING, std::string(builtin::lin_rec709).c_str());
    cfg->setRole(OCIO::ROLE_TEXTURE_PAINT, std::string(builtin::lin_rec709).c_str());
    cfg->setRole(OCIO::ROLE_MATTE_PAINT, std::string(builtin::lin_rec709).c_str());
    cfg->validate();
    return cfg;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// ColourConfig

ColourConfig ColourConfig::builtin_config() {
    ColourConfig c;
    c.config_ = make_builtin_config();
    c.source_ = "built-in";
    c.builtin_ = true;
    return c;
}

ColourConfig ColourConfig::load(const std::string& path) {
    std::string file = path;
    if (file.empty()) {
        const char* env = std::getenv("OCIO");
        if (env == nullptr || *env == '\0') return builtin_config();
        file = env;
    }
    ColourConfig c;
    try {
        c.config_ = OCIO::Config::CreateFromFile(file.c_str());
        c.config_->validate();
    } catch (const OCIO::Exception& e) {
        throw std::runtime_error(fmt::format("OCIO config '{}'{}: {}", file,
                                             path.empty() ? " (from $OCIO)" : "", e.what()));
    }
    c.source_ = file;
    return c;
}

std::string ColourConfig::serialize() const {
    std::ostringstream os;
    config_->serialize(os);
    return os.str();
}

std::vector<std::string> ColourConfig::colour_spaces() const {
    std::vector<std::string> v;
    const int n = config_->getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL);
    for (int i = 0; i < n; ++i)
        v.emplace_back(config_->getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL, i));
    return v;
}

std::vector<std::string> ColourConfig::displays() const {
    std::vector<std::string> v;
    for (int i = 0; i < config_->getNumDisplays(); ++i) v.emplace_back(config_->getDisplay(i));
    return v;
}

std::vector<std::string> ColourConfig::views(const std::string& display) const {
    std::vector<std::string> v;
    for (int i = 0; i < config_->getNumViews(display.c_str()); ++i) v.emplace_back(config_->getView(display.c_str(), i));
    return v;
}

std::vector<std::string> ColourConfig::looks() const {
    std::vector<std::string> v;
    for (int i = 0; i < config_->getNumLooks(); ++i) v.emplace_back(config_->getLookNameByIndex(i));
    return v;
}

std::string ColourConfig::default_display() const { return config_->getDefaultDisplay(); }

std::string ColourConfig::default_view(const std::string& display) const {
    return config_->getDefaultView(display.c_str());
}

void ColourConfig::check_colour_space(const std::string& name) const {
    if (!config_->getColorSpace(name.c_str()))
        throw std::runtime_error(fmt::format("unknown colour space '{}' in OCIO config {}; valid: {}", name,
                                             source_, join(colour_spaces())));
}

void ColourConfig::check_display_view(const std::string& display, const std::string& view) const {
    const auto ds = displays();
    if (std::find(ds.begin(), ds.end(), display) == ds.end())
        throw std::runtime_error(
            fmt::format("unknown display '{}' in OCIO config {}; valid: {}", display, source_, join(ds)));
    const auto vs = views(display);
    if (std::find(vs.begin(), vs.end(), view) == vs.end())
        throw std::runtime_error(fmt::format("unknown view '{}' for display '{}' in OCIO config {}; valid: {}",
                                             view, display, source_, join(vs)));
}

void ColourConfig::check_looks(const std::string& looks) const {
    // OCIO look strings: names separated by ',' or ':', each optionally prefixed by '+' or '-'; '|' separates
    // fallbacks.
    std::string token;
    auto check = [&] {
        auto b = token.find_first_not_of(" \t+-");
        auto e = token.find_last_not_of(" \t");
        const std::string look = b == std::string::npos ? std::string() : token.substr(b, e - b + 1);
        token.clear();
        if (look.empty()) return;
        if (!config_->getLook(look.c_str()))
            throw std::runtime_error(fmt::format("unknown look '{}' in OCIO config {}; valid: {}", look, source_,
                                                 join(this->looks())));
    };
    for (char ch : looks) {
        if (ch == ',' || ch == ':' || ch == '|')
            check();
        else
            token += ch;
    }
    check();
}

namespace {

struct NamedSpaces {
    KnownPrimaries primaries;
    std::vector<const char*> names;
};

// The names the common configs (ACES studio/cg 1.x and 2.x, spi, Blender) give linear spaces of known primaries.
const std::vector<NamedSpaces>& usual_names() {
    static const std::vector<NamedSpaces> names{
        {KnownPrimaries::Rec709,
         {"Linear Rec.709 (sRGB)", "lin_rec709_srgb", "lin_rec709", "Utility - Linear - sRGB",
          "Utility - Linear - Rec.709", "lin_srgb", "Linear sRGB", "Linear Rec.709"}},
        {KnownPrimaries::AcesAP0, {"ACES2065-1", "ACES - ACES2065-1", "aces_interchange", "lin_ap0"}},
        {KnownPrimaries::AcesAP1, {"ACEScg", "ACES - ACEScg", "lin_ap1"}},
        {KnownPrimaries::Rec2020,
         {"Linear Rec.2020", "lin_rec2020", "Utility - Linear - Rec.2020", "Linear Rec.2020 (Rec.2100)"}},
        {KnownPrimaries::P3D65, {"Linear P3-D65", "lin_p3d65", "Utility - Linear - P3-D65"}},
    };
    return names;
}

std::string describe(const std::array<float, 8>& c) {
    return fmt::format("r ({}, {}) g ({}, {}) b ({}, {}) w ({}, {})", c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]);
}

// The 3x3 matrix of `space` -> ACES2065-1 when the config can convert to ACES (aces_interchange role) and
// the conversion is linear (checked on test vectors); nullopt otherwise.
std::optional<Mat3> measure_to_ap0(const OCIO::ConstConfigRcPtr& config, const std::string& space) {
    if (!config->getColorSpace(OCIO::ROLE_INTERCHANGE_SCENE)) return std::nullopt;
    OCIO::ConstCPUProcessorRcPtr cpu;
    try {
        cpu = config->getProcessor(space.c_str(), OCIO::ROLE_INTERCHANGE_SCENE)->getDefaultCPUProcessor();
    } catch (const OCIO::Exception&) {
        return std::nullopt;
    }
    auto f = [&](double r, double g, double b) {
        float p[3] = {static_cast<float>(r), static_cast<float>(g), static_cast<float>(b)};
        cpu->applyRGB(p);
        return std::array<double, 3>{static_cast<double>(p[0]), static_cast<double>(p[1]), static_cast<double>(p[2])};
    };
    const auto cr = f(1, 0, 0), cg = f(0, 1, 0), cb = f(0, 0, 1);
    const Mat3 m{cr[0], cg[0], cb[0], cr[1], cg[1], cb[1], cr[2], cg[2], cb[2]};
    const std::array<std::array<double, 3>, 4> probes{{{0.18, 0.18, 0.18}, {0.3, 0.05, 0.7}, {8.0, 2.0, 0.5}, {0, 0, 0}}};
    for (const auto& v : probes) {
        const auto want = apply3(m, v);
        const auto got = f(v[0], v[1], v[2]);
        for (int i = 0; i < 3; ++i)
            if (std::abs(got[i] - want[i]) > 1e-4 * (1.0 + std::abs(want[i]))) return std::nullopt;
    }
    return m;
}

Mat3 ap0_to_xyz_d65_matrix() {
    const auto ap0 = chromaticities(KnownPrimaries::AcesAP0);
    return multiply(bradford(ap0.wx, ap0.wy, d65_x, d65_y), rgb_to_xyz(ap0));
}

// Primaries and white of an RGB -> XYZ matrix (the xy of its columns and of their sum).
Chromaticities primaries_of(const Mat3& m) {
    auto xy = [](double x, double y, double z) {
        const double s = x + y + z;
        return std::array<double, 2>{x / s, y / s};
    };
    const auto r = xy(m[0], m[3], m[6]), g = xy(m[1], m[4], m[7]), b = xy(m[2], m[5], m[8]);
    const auto w = xy(m[0] + m[1] + m[2], m[3] + m[4] + m[5], m[6] + m[7] + m[8]);
    return {r[0], r[1], g[0], g[1], b[0], b[1], w[0], w[1]};
}

}  // namespace

std::string ColourConfig::input_space(const std::string& requested,
                                      const std::optional<std::array<float, 8>>& exr_chromaticities) {
    if (!requested.empty()) {
        check_colour_space(requested);
        return requested;
    }
    if (!exr_chromaticities) {
        if (builtin_) return std::string(builtin::lin_rec709);
        // An EXR without chromaticities is linear Rec.709 (the format's default primaries); else, as
        // oiiotool takes an untagged image, the config's scene_linear role, then its default role.
        for (const char* n : usual_names().front().names)
            if (config_->getColorSpace(n)) return n;
        for (const char* role : {OCIO::ROLE_SCENE_LINEAR, OCIO::ROLE_DEFAULT})
            if (const auto cs = config_->getColorSpace(role)) return cs->getName();
        throw std::runtime_error(fmt::format(
            "the input has no chromaticities and OCIO config {} has no linear Rec.709 colour space under a usual "
            "name and no scene_linear or default role; give --colorspace, one of: {}",
            source_, join(colour_spaces())));
    }
    const auto& c = *exr_chromaticities;
    const auto known = identify_primaries(c);
    if (known) {
        // When the config can convert to ACES (aces_interchange role), a candidate must measure as linear with
        // these primaries; without that role the usual names are trusted.
        const auto k = chromaticities(*known);
        const Mat3 want = multiply(bradford(k.wx, k.wy, d65_x, d65_y), rgb_to_xyz(k));
        const bool can_measure = config_->getColorSpace(OCIO::ROLE_INTERCHANGE_SCENE) != nullptr;
        auto matches = [&](const std::string& n) {
            const auto m = measure_to_ap0(config_, n);
            if (!m) return false;
            const Mat3 got = multiply(ap0_to_xyz_d65_matrix(), *m);
            for (std::size_t i = 0; i < 9; ++i)
                if (std::abs(got[i] - want[i]) > 2e-3) return false;
            return true;
        };
        for (const auto& entry : usual_names())
            if (entry.primaries == *known)
                for (const char* n : entry.names)
                    if (config_->getColorSpace(n) && (!can_measure || matches(n))) return n;
        if (can_measure)
            for (const auto& n : colour_spaces()) {
                const auto cs = config_->getColorSpace(n.c_str());
                if (cs && !cs->isData() && cs->getReferenceSpaceType() == OCIO::REFERENCE_SPACE_SCENE && matches(n))
                    return n;
            }
    }
    if (!builtin_)
        throw std::runtime_error(fmt::format(
            "OCIO config {} has no linear colour space with the input's chromaticities {}{}; give --colorspace, "
            "one of: {}",
            source_, describe(c), known ? fmt::format(" ({})", name(*known)) : std::string(), join(colour_spaces())));
    if (known) {
        switch (*known) {
            case KnownPrimaries::Rec709: return std::string(builtin::lin_rec709);
            case KnownPrimaries::AcesAP0: return std::string(builtin::aces2065_1);
            case KnownPrimaries::AcesAP1: return std::string(builtin::acescg);
            case KnownPrimaries::Rec2020: return std::string(builtin::lin_rec2020);
            case KnownPrimaries::P3D65: return std::string(builtin::lin_p3d65);
        }
    }
    // Other chromaticities: add a linear colour space for them to (a copy of) the built-in config.
    const Chromaticities ch = widened(c);
    OCIO::TransformRcPtr to_ref;
    try {
        to_ref = rgb_to_aces_reference(ch);
    } catch (const std::invalid_argument& e) {
        throw std::runtime_error(fmt::format("input chromaticities {}: {}", describe(c), e.what()));
    }
    const std::string space = fmt::format("Linear input primaries {}", describe(c));
    if (!config_->getColorSpace(space.c_str())) {
        auto copy = config_->createEditableCopy();
        copy->addColorSpace(scene_space(space, "Input", "Linear RGB of the input file's EXR chromaticities", to_ref));
        config_ = copy;
    }
    return space;
}

// ---------------------------------------------------------------------------------------------------------
// ColourTransform

ColourTransform::ColourTransform(OCIO::ConstProcessorRcPtr processor, bool clamp)
    : processor_(std::move(processor)), clamp_(clamp) {
    if (processor_) {
        cpu_ = processor_->getOptimizedCPUProcessor(OCIO::BIT_DEPTH_F32, OCIO::BIT_DEPTH_F32,
                                                    OCIO::OPTIMIZATION_DEFAULT);
        if (cpu_->isNoOp() && !clamp_) {
            processor_.reset();
            cpu_.reset();
        }
    }
}

ColourTransform make_transform(const ColourConfig& config, const std::string& src, const std::string& dst) {
    config.check_colour_space(src);
    config.check_colour_space(dst);
    try {
        return ColourTransform(config.ocio()->getProcessor(src.c_str(), dst.c_str()), false);
    } catch (const OCIO::Exception& e) {
        throw std::runtime_error(fmt::format("OCIO config {}: no transform from '{}' to '{}': {}", config.source(),
                                             src, dst, e.what()));
    }
}

namespace {

// The largest half float: what +Inf becomes, so that it stays the brightest value an EXR can hold.
constexpr float inf_replacement = 65504.0f;

inline float sanitise(float v) {
    if (std::isnan(v)) return 0.0f;
    if (std::isinf(v)) return v > 0.0f ? inf_replacement : 0.0f;
    return v;
}

// Clamp to [0, 1] that also turns a NaN into 0.
inline float clamp01(float v) { return v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f; }

}  // namespace

void ColourTransform::apply(PixelSpan px) const {
    if (!cpu_ || px.width == 0 || px.height == 0) return;
    if (px.channels < 3 || px.data == nullptr)
        throw std::invalid_argument(fmt::format("colour transform: need at least 3 channels, got {}", px.channels));
    const std::size_t nc = static_cast<std::size_t>(px.channels);
    const std::size_t stride = px.row_stride ? px.row_stride : px.width * nc;
    auto run_rows = [&](std::size_t y0, std::size_t y1) {
        for (std::size_t y = y0; y < y1; ++y) {
            float* row = px.data + y * stride;
            for (std::size_t x = 0; x < px.width; ++x)
                for (std::size_t c = 0; c < 3; ++c) row[x * nc + c] = sanitise(row[x * nc + c]);
        }
        float* first = px.data + y0 * stride;
        const auto w = static_cast<long>(px.width), h = static_cast<long>(y1 - y0);
        const auto xs = static_cast<std::ptrdiff_t>(nc * sizeof(float));
        const auto ys = static_cast<std::ptrdiff_t>(stride * sizeof(float));
        // RGB ordering with the pixel stride, also for RGBA: OCIO's RGBA path rescales alpha in some ops, and
        // alpha and further channels must come back bit for bit.
        OCIO::PackedImageDesc desc(first, w, h, OCIO::CHANNEL_ORDERING_RGB, OCIO::BIT_DEPTH_F32, sizeof(float), xs, ys);
        cpu_->apply(desc);
        for (std::size_t y = y0; y < y1; ++y) {
            float* row = px.data + y * stride;
            for (std::size_t x = 0; x < px.width; ++x)
                for (std::size_t c = 0; c < 3; ++c) {
                    float& v = row[x * nc + c];
                    v = clamp_ ? clamp01(v) : sanitise(v);
                }
        }
    };
    // Threads only where the frame is large enough to pay for them (about 64k pixels per thread).
    const std::size_t hw = std::max(1u, std::thread::hardware_concurrency());
    const std::size_t threads = std::clamp<std::size_t>(px.width * px.height / 65536, 1, hw);
    if (threads == 1) {
        run_rows(0, px.height);
        return;
    }
    std::vector<std::jthread> pool;
    const std::size_t chunk = (px.height + threads - 1) / threads;
    for (std::size_t y = 0; y < px.height; y += chunk)
        pool.emplace_back(run_rows, y, std::min(px.height, y + chunk));
}

void ColourTransform::apply_rgb(float* rgb, std::size_t count) const {
    apply(PixelSpan{rgb, count, 1, 3, 0});
}

std::string ColourTransform::description() const {
    if (!processor_) return "identity";
    std::ostringstream os;
    os << *processor_->createGroupTransform();
    return os.str();
}

GpuShader gpu_shader(const ColourTransform& transform, const std::string& function) {
    GpuShader out;
    out.function = function;
    const std::string ocio_function = function + "_ocio";
    const std::string body = "    return " + ocio_function + "(c);\n";
    if (transform.processor()) {
        auto desc = OCIO::GpuShaderDesc::CreateShaderDesc();
        desc->setLanguage(OCIO::GPU_LANGUAGE_GLSL_4_0);
        desc->setFunctionName(ocio_function.c_str());
        desc->setResourcePrefix((function + "_").c_str());
        transform.processor()->getDefaultGPUProcessor()->extractGpuShaderInfo(desc);
        if (desc->getNumUniforms() > 0)
            throw std::runtime_error(fmt::format("colour: the GPU path does not feed uniforms, and this transform "
                                                 "needs {} (dynamic properties)", desc->getNumUniforms()));
        for (unsigned i = 0; i < desc->getNumTextures(); ++i) {
            const char *texture = nullptr, *sampler = nullptr;
            unsigned w = 0, h = 0;
            OCIO::GpuShaderDesc::TextureType type{};
            OCIO::Interpolation interp{};
            desc->getTexture(i, texture, sampler, w, h, type, interp);
            const float* values = nullptr;
            desc->getTextureValues(i, values);
            GpuShader::Texture t;
            t.sampler = sampler;
            t.dimensions = h > 1 ? 2 : 1;
            t.width = w;
            t.height = h;
            t.channels = type == OCIO::GpuShaderDesc::TEXTURE_RED_CHANNEL ? 1 : 3;
            t.linear = interp != OCIO::INTERP_NEAREST;
            t.values.assign(values, values + std::size_t{w} * h * static_cast<std::size_t>(t.channels));
            out.textures.push_back(std::move(t));
        }
        for (unsigned i = 0; i < desc->getNum3DTextures(); ++i) {
            const char *texture = nullptr, *sampler = nullptr;
            unsigned edge = 0;
            OCIO::Interpolation interp{};
            desc->get3DTexture(i, texture, sampler, edge, interp);
            const float* values = nullptr;
            desc->get3DTextureValues(i, values);
            GpuShader::Texture t;
            t.sampler = sampler;
            t.dimensions = 3;
            t.width = t.height = t.depth = edge;
            t.channels = 3;
            t.linear = interp != OCIO::INTERP_NEAREST;
            t.values.assign(values, values + std::size_t{edge} * edge * edge * 3);
            out.textures.push_back(std::move(t));
        }
        out.source = desc->getShaderText();
    } else {
        out.source = fmt::format("vec4 {}(vec4 c) {{ return c; }}\n", function);  // identity: untouched, as on the CPU
        return out;
    }
    const std::string end = transform.clamps() ? "clamp01" : "sanitise";
    out.source += fmt::format(R"(
float {0}_sanitise(float v) {{ return isnan(v) ? 0.0 : (isinf(v) ? (v > 0.0 ? {1:.1f} : 0.0) : v); }}
float {0}_clamp01(float v) {{ return v > 0.0 ? min(v, 1.0) : 0.0; }}
vec4 {0}_core(vec4 c) {{
{2}}}
vec4 {0}(vec4 c) {{
    c.rgb = vec3({0}_sanitise(c.r), {0}_sanitise(c.g), {0}_sanitise(c.b));
    vec4 o = {0}_core(c);
    return vec4({0}_{3}(o.r), {0}_{3}(o.g), {0}_{3}(o.b), c.a);
}}
)",
                              function, static_cast<double>(inf_replacement), body, end);
    return out;
}

// ---------------------------------------------------------------------------------------------------------
// ColourPipeline

ColourPipeline::ColourPipeline(ColourConfig config, const ColourOptions& options,
                               const std::optional<std::array<float, 8>>& exr_chromaticities)
    : config_(std::move(config)) {
    input_space_ = config_.input_space(options.colorspace, exr_chromaticities);
    const auto& cfg = config_.ocio();

    // Working space: the input's own space when it is scene-linear (measured through the config where it can
    // convert to ACES, else trusted from the colour space's encoding); else the scene_linear role.
    auto linear_matrix = measure_to_ap0(cfg, input_space_);
    const bool can_measure = cfg->getColorSpace(OCIO::ROLE_INTERCHANGE_SCENE) != nullptr;
    bool input_linear = linear_matrix.has_value();
    if (!can_measure) {
        const auto cs = cfg->getColorSpace(input_space_.c_str());
        const auto scene_linear = cfg->getColorSpace(OCIO::ROLE_SCENE_LINEAR);
        input_linear = std::string_view(cs->getEncoding()) == "scene-linear" ||
                       (scene_linear && std::string_view(scene_linear->getName()) == cs->getName());
    }
    if (input_linear) {
        working_.name = input_space_;
        working_.is_input_space = true;
    } else {
        const auto scene_linear = cfg->getColorSpace(OCIO::ROLE_SCENE_LINEAR);
        if (!scene_linear)
            throw std::runtime_error(fmt::format(
                "input colour space '{}' is not scene-linear and OCIO config {} has no scene_linear role to work in",
                input_space_, config_.source()));
        working_.name = scene_linear->getName();
        linear_matrix = measure_to_ap0(cfg, working_.name);
    }
    if (exr_chromaticities && options.colorspace.empty()) {
        const auto& c = *exr_chromaticities;
        working_.primaries = widened(c);
        if (const auto k = identify_primaries(c)) working_.primaries = chromaticities(*k);
    } else if (linear_matrix) {
        working_.primaries = primaries_of(multiply(ap0_to_xyz_d65_matrix(), *linear_matrix));
        // Snap to the exact values when the measurement is one of the known sets (with its native white).
        const auto& p = working_.primaries;
        const std::array<float, 8> measured{static_cast<float>(p.rx), static_cast<float>(p.ry),
                                            static_cast<float>(p.gx), static_cast<float>(p.gy),
                                            static_cast<float>(p.bx), static_cast<float>(p.by),
                                            static_cast<float>(p.wx), static_cast<float>(p.wy)};
        if (const auto k = identify_primaries(measured)) working_.primaries = chromaticities(*k);
        for (auto k : {KnownPrimaries::AcesAP0, KnownPrimaries::AcesAP1}) {
            // Measured through OCIO, ACES spaces come out Bradford-adapted to D65; their primaries are theirs.
            auto d65 = chromaticities(k);
            const Mat3 adapted = multiply(bradford(d65.wx, d65.wy, d65_x, d65_y), rgb_to_xyz(d65));
            const auto q = primaries_of(adapted);
            const std::array<float, 8> qa{static_cast<float>(q.rx), static_cast<float>(q.ry),
                                          static_cast<float>(q.gx), static_cast<float>(q.gy),
                                          static_cast<float>(q.bx), static_cast<float>(q.by),
                                          static_cast<float>(q.wx), static_cast<float>(q.wy)};
            bool same = true;
            for (std::size_t i = 0; i < 8 && same; ++i)
                same = std::abs(static_cast<double>(qa[i]) - static_cast<double>(measured[i])) < 2e-3;
            if (same) working_.primaries = d65;
        }
    } else {
        working_.primaries = chromaticities(KnownPrimaries::Rec709);
        working_.primaries_assumed = true;
    }
    working_.rgb_to_xyz = rgb_to_xyz(working_.primaries);

    if (!working_.is_input_space) {
        to_working_ = make_transform(config_, input_space_, working_.name);
        from_working_ = make_transform(config_, working_.name, input_space_);
    }

    display_ = options.display.empty() ? config_.default_display() : options.display;
    if (!options.display.empty() || !options.view.empty()) {
        const auto ds = config_.displays();
        if (std::find(ds.begin(), ds.end(), display_) == ds.end()) config_.check_display_view(display_, "");
    }
    view_ = options.view.empty() ? config_.default_view(display_) : options.view;
    config_.check_display_view(display_, view_);
    if (!options.look.empty()) config_.check_looks(options.look);

    auto group = OCIO::GroupTransform::Create();
    if (options.exposure_ev != 0.0) {
        const double s = std::exp2(options.exposure_ev);
        group->appendTransform(matrix_transform({s, 0, 0, 0, s, 0, 0, 0, s}));
    }
    auto dvt = OCIO::DisplayViewTransform::Create();
    dvt->setSrc(working_.name.c_str());
    dvt->setDisplay(display_.c_str());
    dvt->setView(view_.c_str());
    if (!options.look.empty()) {
        auto lt = OCIO::LookTransform::Create();
        lt->setSrc(working_.name.c_str());
        lt->setDst(working_.name.c_str());
        lt->setLooks(options.look.c_str());
        group->appendTransform(lt);
        dvt->setLooksBypass(true);
    }
    group->appendTransform(dvt);
    try {
        to_display_ = ColourTransform(cfg->getProcessor(group), true);
    } catch (const OCIO::Exception& e) {
        throw std::runtime_error(fmt::format("OCIO config {}: display '{}' view '{}'{}: {}", config_.source(),
                                             display_, view_, options.look.empty() ? "" : " look '" + options.look + "'",
                                             e.what()));
    }
}

// ---------------------------------------------------------------------------------------------------------
// Output formats and quantisation

bool is_display_referred_format(std::string_view path) {
    const auto dot = path.rfind('.');
    std::string ext(dot == std::string_view::npos ? path : path.substr(dot + 1));
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
    for (const char* e : {"png", "jpg", "jpeg", "jpe", "jfif", "bmp", "gif", "webp", "ppm", "pgm", "pnm", "tga",
                          "jp2", "j2k", "dpx", "cin", "heic", "avif"})
        if (ext == e) return true;
    return false;
}

namespace {

// 16x16 Bayer index: the bits of (x xor y, y) interleaved, lowest level most significant.
unsigned bayer16(std::size_t x, std::size_t y) {
    unsigned v = 0;
    for (unsigned k = 0; k < 4; ++k) {
        const unsigned xb = (x >> k) & 1u, yb = (y >> k) & 1u;
        v |= (((xb ^ yb) << 1) | yb) << (2 * (3 - k));
    }
    return v;
}

constexpr std::size_t bn_size = 64;

// A 64x64 blue-noise rank table by the void-and-cluster method (Ulichney 1993): Gaussian energy on the
// torus (sigma 1.5), a seeded initial pattern relaxed by moving its tightest cluster into its largest void,
// then ranks by removing clusters and filling voids. Deterministic; built once.
std::vector<float> make_blue_noise() {
    constexpr std::size_t n = bn_size, count = n * n;
    std::vector<double> kernel(count);
    for (std::size_t y = 0; y < n; ++y)
        for (std::size_t x = 0; x < n; ++x) {
            const double dx = static_cast<double>(std::min(x, n - x)), dy = static_cast<double>(std::min(y, n - y));
            kernel[y * n + x] = std::exp(-(dx * dx + dy * dy) / (2.0 * 1.5 * 1.5));
        }
    std::vector<char> on(count, 0);
    std::vector<double> energy(count, 0.0);
    auto splat = [&](std::size_t i, double sign) {
        const std::size_t px = i % n, py = i / n;
        for (std::size_t y = 0; y < n; ++y)
            for (std::size_t x = 0; x < n; ++x)
                energy[y * n + x] += sign * kernel[((y + n - py) % n) * n + (x + n - px) % n];
    };
    auto tightest = [&] {  // the set pixel of highest energy
        std::size_t best = 0;
        double e = -1.0;
        for (std::size_t i = 0; i < count; ++i)
            if (on[i] && energy[i] > e) e = energy[i], best = i;
        return best;
    };
    auto largest_void = [&] {  // the empty pixel of lowest energy
        std::size_t best = 0;
        double e = std::numeric_limits<double>::max();
        for (std::size_t i = 0; i < count; ++i)
            if (!on[i] && energy[i] < e) e = energy[i], best = i;
        return best;
    };
    std::uint64_t state = 0x9e3779b97f4a7c15ull;  // xorshift64 with a fixed seed
    std::size_t ones = 0;
    while (ones < count / 10) {
        state ^= state << 13, state ^= state >> 7, state ^= state << 17;
        const std::size_t i = state % count;
        if (!on[i]) on[i] = 1, splat(i, 1.0), ++ones;
    }
    for (;;) {
        const std::size_t c = tightest();
        on[c] = 0, splat(c, -1.0);
        const std::size_t v = largest_void();
        on[v] = 1, splat(v, 1.0);
        if (v == c) break;
    }
    std::vector<std::size_t> rank(count, 0);
    const std::vector<char> initial = on;
    const std::vector<double> initial_energy = energy;
    for (std::size_t r = ones; r-- > 0;) {
        const std::size_t c = tightest();
        on[c] = 0, splat(c, -1.0);
        rank[c] = r;
    }
    on = initial, energy = initial_energy;
    for (std::size_t r = ones; r < count; ++r) {
        const std::size_t v = largest_void();
        on[v] = 1, splat(v, 1.0);
        rank[v] = r;
    }
    std::vector<float> table(count);
    for (std::size_t i = 0; i < count; ++i)
        table[i] = static_cast<float>((static_cast<double>(rank[i]) + 0.5) / static_cast<double>(count) - 0.5);
    return table;
}

const std::vector<float>& blue_noise() {
    static const std::vector<float> table = make_blue_noise();
    return table;
}

// The dither offsets of one row, channel by channel (what dither_offset gives, computed once per row).
void row_offsets(Dither dither, std::size_t width, std::size_t y, std::size_t channels, std::uint64_t frame,
                 std::vector<float>& out) {
    out.resize(width * channels);
    if (dither == Dither::Ordered && width > 16) {  // periodic: compute one period and repeat it
        for (std::size_t x = 0; x < 16; ++x)
            for (std::size_t c = 0; c < channels; ++c)
                out[x * channels + c] = dither_offset(dither, x, y, static_cast<int>(c), frame);
        for (std::size_t i = 16 * channels; i < out.size(); ++i) out[i] = out[i - 16 * channels];
        return;
    }
    for (std::size_t x = 0; x < width; ++x)
        for (std::size_t c = 0; c < channels; ++c)
            out[x * channels + c] = dither_offset(dither, x, y, static_cast<int>(c), frame);
}

template <typename T>
std::vector<T> quantise(const PixelSpan& px, Dither dither, std::uint64_t frame, float max) {
    const std::size_t nc = static_cast<std::size_t>(px.channels);
    const std::size_t stride = px.row_stride ? px.row_stride : px.width * nc;
    const std::size_t n = px.width * nc;
    std::vector<T> out(px.width * px.height * nc);
    std::vector<float> offsets(n, 0.0f);
    // Blue noise repeats every 64 rows and columns: rows 64 apart share their offsets.
    std::vector<std::vector<float>> blue_rows;
    for (std::size_t y = 0; y < px.height; ++y) {
        if (dither == Dither::Ordered) {
            row_offsets(dither, px.width, y, nc, frame, offsets);
        } else if (dither == Dither::BlueNoise) {
            if (blue_rows.size() <= y % bn_size) {
                blue_rows.emplace_back();
                row_offsets(dither, px.width, y, nc, frame, blue_rows.back());
            }
            offsets = blue_rows[y % bn_size];
        }
        const float* row = px.data + y * stride;
        T* o = out.data() + y * n;
        for (std::size_t i = 0; i < n; ++i) {
            const float q = std::floor(clamp01(row[i]) * max + 0.5f + offsets[i]);
            o[i] = static_cast<T>(q < 0.0f ? 0.0f : (q > max ? max : q));
        }
    }
    return out;
}

}  // namespace

float dither_offset(Dither dither, std::size_t x, std::size_t y, int channel, std::uint64_t frame) {
    switch (dither) {
        case Dither::None: return 0.0f;
        case Dither::Ordered: {
            // One threshold for all channels (no colour noise); the pattern moves by a coprime step per frame.
            const std::size_t shift = static_cast<std::size_t>(frame % 256);
            return (static_cast<float>(bayer16(x + shift * 7, y + shift * 11)) + 0.5f) / 256.0f - 0.5f;
        }
        case Dither::BlueNoise: {
            const auto& t = blue_noise();
            // Channels read the tile at offsets of about a third of it (decorrelated); frames add the golden
            // ratio to the threshold (each pixel's threshold sequence over time is low-discrepancy).
            const std::size_t c = static_cast<std::size_t>(channel);
            const float v = t[((y + c * 23) % bn_size) * bn_size + (x + c * 41) % bn_size];
            const double g = std::fmod(static_cast<double>(frame % 1000003) * 0.6180339887498949, 1.0);
            double s = static_cast<double>(v) + 0.5 + g;
            s -= std::floor(s);
            return static_cast<float>(s - 0.5);
        }
    }
    return 0.0f;
}

std::vector<std::uint8_t> quantise8(const PixelSpan& pixels, Dither dither, std::uint64_t frame) {
    return quantise<std::uint8_t>(pixels, dither, frame, 255.0f);
}

std::vector<std::uint16_t> quantise16(const PixelSpan& pixels, Dither dither, std::uint64_t frame) {
    return quantise<std::uint16_t>(pixels, dither, frame, 65535.0f);
}

// ---------------------------------------------------------------------------------------------------------
// The colour stages

Dither ColourArgs::dither_mode() const {
    if (dither == "none") return Dither::None;
    if (dither == "ordered") return Dither::Ordered;
    if (dither == "blue-noise") return Dither::BlueNoise;
    throw std::runtime_error(fmt::format("--dither must be none, ordered or blue-noise, not \"{}\"", dither));
}

bool ColourArgs::display_asked() const {
    return !options.display.empty() || !options.view.empty() || !options.look.empty();
}

void add_colour_options(CLI::App& app, ColourArgs& args) {
    ColourOptions& o = args.options;
    const char* group = "Colour";
    app.add_option("--colorspace,--colourspace", o.colorspace,
                   "OCIO colour space of the input (default: from the EXR chromaticities, else linear Rec.709)")
        ->group(group);
    app.add_option("--ocio", o.ocio_config, "OCIO config file (default: $OCIO, else the built-in ACES config)")
        ->group(group);
    app.add_option("--display", o.display,
                   "Display to tone map for (built-in config: srgb, rec709, rec2100-pq); also applies it to "
                   "scene-linear outputs")
        ->group(group);
    app.add_option("--view", o.view, "View of the display (default: the display's first)")->group(group);
    app.add_option("--look", o.look, "OCIO look(s) applied before the view, replacing the view's own")->group(group);
    app.add_option("--exposure", o.exposure_ev, "Exposure in stops, applied in scene-linear before the display")
        ->check(CLI::Range(-64.0, 64.0))
        ->check(filter::finite_number())
        ->group(group);
    app.add_option("--bits", args.bits, "Bits per channel of display-referred files: 8 or 16 (JPEG: 8)")
        ->check(CLI::IsMember({8, 16}))
        ->group(group);
    app.add_option("--dither", args.dither, "Dither when quantising display outputs: none, ordered, blue-noise")
        ->check(CLI::IsMember({"none", "ordered", "blue-noise"}))
        ->group(group);
    app.add_option("--colour-on,--color-on", args.device,
                   "Where the output colour transform runs: auto (the GPU when the flare stage or --gpu made a GL "
                   "context), cpu, gpu")
        ->check(CLI::IsMember({"auto", "cpu", "gpu"}))
        ->capture_default_str()
        ->group(group);
}

ColourSession::ColourSession(const ColourArgs& args, const std::string& output)
    : config_(ColourConfig::load(args.options.ocio_config)),
      options_(args.options),
      display_output_(args.display_asked() || is_display_referred_format(output)) {
    // Check every name now, before any frame is read.
    if (!options_.colorspace.empty()) config_.check_colour_space(options_.colorspace);
    if (options_.display.empty()) options_.display = config_.default_display();
    const auto displays = config_.displays();
    if (std::find(displays.begin(), displays.end(), options_.display) == displays.end())
        config_.check_display_view(options_.display, options_.view);
    if (options_.view.empty()) options_.view = config_.default_view(options_.display);
    config_.check_display_view(options_.display, options_.view);
    if (!options_.look.empty()) config_.check_looks(options_.look);
}

const ColourPipeline& ColourSession::pipeline_for(const filter::Frame& frame) {
    const auto& chroma = frame.spec.chromaticities;
    if (!pipeline_) {
        pipeline_.emplace(config_, options_, chroma);
        first_chromaticities_ = chroma;
    } else if (options_.colorspace.empty() && chroma != first_chromaticities_) {
        throw std::runtime_error(fmt::format("its chromaticities ({}) differ from the first frame's ({})",
                                             chroma ? describe(*chroma) : "none",
                                             first_chromaticities_ ? describe(*first_chromaticities_) : "none"));
    }
    return *pipeline_;
}

namespace {

PixelSpan rgb_span(filter::Frame& frame) {
    return PixelSpan{frame.rgb.data(), static_cast<std::size_t>(frame.spec.width),
                     static_cast<std::size_t>(frame.spec.height), 3, 0};
}

}  // namespace

void ColourInputStage::process(filter::Frame& frame) {
    if (frame.rgb.empty()) return;  // no stage touches the pixels: nothing to resolve
    session_->pipeline_for(frame).to_working().apply(rgb_span(frame));
}

bool ColourOutputStage::wants_rgb() const {
    const auto& o = session_->options();
    return session_->display_output() || o.exposure_ev != 0.0 || !o.colorspace.empty();
}

ColourOutputStage::ColourOutputStage(std::shared_ptr<ColourSession> session, std::shared_ptr<filter::GpuSession> gpu,
                                     std::string device)
    : session_(std::move(session)), gpu_(std::move(gpu)), device_(std::move(device)) {
    if (device_ != "auto" && device_ != "cpu" && device_ != "gpu")
        throw std::invalid_argument(fmt::format("--colour-on must be auto, cpu or gpu, not \"{}\"", device_));
    if (device_ == "gpu" && !gpu_) gpu_ = std::make_shared<filter::GpuSession>();
}

ColourOutputStage::~ColourOutputStage() {
    // The compiled shaders belong to the shared context: release them while it is current.
    if ((gpu_display_ || gpu_scene_) && gpu_ && gpu_->context) gpu_->context->make_current();
}

void ColourOutputStage::apply(const ColourTransform& transform, std::unique_ptr<GpuColourTransform>& compiled,
                              PixelSpan pixels) {
    const bool gpu = !transform.is_identity() && gpu_ && (device_ == "gpu" || (device_ == "auto" && gpu_->active()));
    ran_on_gpu_ = gpu;
    if (!gpu) {
        transform.apply(pixels);
        return;
    }
    gpu_->get().make_current();
    if (!compiled) compiled = std::make_unique<GpuColourTransform>(transform);
    compiled->apply(pixels);
}

namespace {
// Where the output transform ran, in the frame's metadata (EXR outputs keep it).
void record_device(filter::Frame& frame, bool gpu) { frame.spec.text["lensfx:colourTransformOn"] = gpu ? "gpu" : "cpu"; }
}  // namespace

void ColourOutputStage::process(filter::Frame& frame) {
    if (frame.rgb.empty()) return;
    const auto& p = session_->pipeline_for(frame);
    auto px = rgb_span(frame);
    if (session_->display_output()) {
        apply(p.to_display(), gpu_display_, px);
        record_device(frame, ran_on_gpu_);
        // The pixels are display code values now: the input's primaries no longer describe them.
        frame.spec.chromaticities.reset();
        const std::string& display = p.display();
        if (display == builtin::display_srgb && session_->config().is_builtin())
            frame.spec.text["oiio:ColorSpace"] = "sRGB";
        else if (display == builtin::display_rec709 && session_->config().is_builtin())
            frame.spec.text["oiio:ColorSpace"] = "Rec709";
        else
            frame.spec.text["oiio:ColorSpace"] = display;
        return;
    }
    const double ev = session_->options().exposure_ev;
    if (ev != 0.0) {
        const float s = static_cast<float>(std::exp2(ev));
        for (float& v : frame.rgb) v = filter::scaled_within_float(v, s);
    }
    apply(p.to_scene_output(), gpu_scene_, px);
    if (!p.to_scene_output().is_identity()) record_device(frame, ran_on_gpu_);
}

}  // namespace lensfx::colour
