// The built-in OCIO config (ACES output transforms from OCIO's built-in transforms) and its parts.
#include "ocio_parts.h"

#include <cmath>

#include <fmt/core.h>
#include <fmt/format.h>

namespace lensfx::colour {

std::string join(const std::vector<std::string>& v) {
    return v.empty() ? std::string("(none)") : fmt::format("{}", fmt::join(v, ", "));
}

OCIO::TransformRcPtr matrix_transform(const Mat3& m) {
    auto t = OCIO::MatrixTransform::Create();
    const double m44[16] = {m[0], m[1], m[2], 0, m[3], m[4], m[5], 0, m[6], m[7], m[8], 0, 0, 0, 0, 1};
    t->setMatrix(m44);
    return t;
}

namespace {

OCIO::TransformRcPtr builtin_transform(const char* style, bool inverse_dir = false) {
    auto t = OCIO::BuiltinTransform::Create();
    t->setStyle(style);
    if (inverse_dir) t->setDirection(OCIO::TRANSFORM_DIR_INVERSE);
    return t;
}

constexpr const char* ap0_to_xyz_d65 = "UTILITY - ACES-AP0_to_CIE-XYZ-D65_BFD";

}  // namespace

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

}  // namespace lensfx::colour
