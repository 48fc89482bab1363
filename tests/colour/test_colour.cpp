// Colour module: primaries and matrices against published values, the built-in OCIO config against OCIO's
// own processors, known tone-mapping values, clamping, NaN/Inf, errors that list the valid names, dither.
#include <filter/colour.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numeric>
#include <random>

namespace {

using namespace lensfx::colour;
namespace fs = std::filesystem;

std::string error_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "(no error)";
}

std::array<float, 8> exr(const Chromaticities& c) {
    return {static_cast<float>(c.rx), static_cast<float>(c.ry), static_cast<float>(c.gx), static_cast<float>(c.gy),
            static_cast<float>(c.bx), static_cast<float>(c.by), static_cast<float>(c.wx), static_cast<float>(c.wy)};
}

std::vector<float> random_hdr_pixels(std::size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> stops(-8.0f, 8.0f);
    std::uniform_real_distribution<float> mix(-0.05f, 1.0f);
    std::vector<float> v(n * 3);
    for (std::size_t i = 0; i < n; ++i) {
        const float level = 0.18f * std::exp2(stops(rng));
        for (std::size_t c = 0; c < 3; ++c) v[3 * i + c] = level * mix(rng);
    }
    return v;
}

// OCIO's own processor for display/view from `src`, applied pixel by pixel, then clamped.
std::vector<float> ocio_reference(const ColourConfig& cfg, const std::string& src, const std::string& display,
                                  const std::string& view, std::vector<float> px) {
    auto cpu = cfg.ocio()->getProcessor(src.c_str(), display.c_str(), view.c_str(), OCIO::TRANSFORM_DIR_FORWARD)
                   ->getDefaultCPUProcessor();
    for (std::size_t i = 0; i < px.size(); i += 3) cpu->applyRGB(&px[i]);
    for (float& v : px) v = std::clamp(v, 0.0f, 1.0f);
    return px;
}

float max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
    float m = 0.0f;
    for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
    return m;
}

float display_of(const ColourPipeline& p, float r, float g, float b, int channel = 0) {
    float px[3] = {r, g, b};
    p.to_display().apply_rgb(px, 1);
    return px[channel];
}

// ----------------------------------------------------------------------------------------------------------

TEST(Primaries, Rec709MatrixMatchesIec61966) {
    const Mat3 m = rgb_to_xyz(chromaticities(KnownPrimaries::Rec709));
    // IEC 61966-2-1 (sRGB), to the 4 decimals it publishes.
    const Mat3 want{0.4124, 0.3576, 0.1805, 0.2126, 0.7152, 0.0722, 0.0193, 0.1192, 0.9505};
    for (std::size_t i = 0; i < 9; ++i) EXPECT_NEAR(m[i], want[i], 1.5e-4) << i;
}

TEST(Primaries, Ap0MatrixMatchesSmpte2065) {
    const Mat3 m = rgb_to_xyz(chromaticities(KnownPrimaries::AcesAP0));
    // SMPTE ST 2065-1 / ACES TB-2014-004.
    const Mat3 want{0.9525523959, 0.0, 0.0000936786, 0.3439664498, 0.7281660966, -0.0721325464, 0.0, 0.0, 1.0088251844};
    for (std::size_t i = 0; i < 9; ++i) EXPECT_NEAR(m[i], want[i], 1e-8) << i;
}

TEST(Primaries, InverseAndBradford) {
    const Mat3 m = rgb_to_xyz(chromaticities(KnownPrimaries::Rec2020));
    const Mat3 id = multiply(m, inverse(m));
    for (std::size_t i = 0; i < 9; ++i) EXPECT_NEAR(id[i], i % 4 == 0 ? 1.0 : 0.0, 1e-12);
    // Bradford maps the source white to the destination white.
    const Mat3 b = bradford(0.32168, 0.33767, 0.3127, 0.3290);
    const double sx = 0.32168 / 0.33767, sz = (1 - 0.32168 - 0.33767) / 0.33767;
    const double X = b[0] * sx + b[1] + b[2] * sz, Y = b[3] * sx + b[4] + b[5] * sz, Z = b[6] * sx + b[7] + b[8] * sz;
    EXPECT_NEAR(X / (X + Y + Z), 0.3127, 1e-9);
    EXPECT_NEAR(Y / (X + Y + Z), 0.3290, 1e-9);
    EXPECT_THROW(inverse(Mat3{1, 2, 3, 2, 4, 6, 0, 0, 1}), std::invalid_argument);
}

TEST(Primaries, IdentifiesExrChromaticitiesTolerantly) {
    for (auto k : {KnownPrimaries::Rec709, KnownPrimaries::AcesAP0, KnownPrimaries::AcesAP1, KnownPrimaries::Rec2020,
                   KnownPrimaries::P3D65}) {
        auto c = exr(chromaticities(k));
        EXPECT_EQ(identify_primaries(c), k) << name(k);
        c[0] += 0.0015f;  // a writer's rounding
        EXPECT_EQ(identify_primaries(c), k) << name(k);
        c[0] += 0.01f;
        EXPECT_EQ(identify_primaries(c), std::nullopt) << name(k);
    }
    // OpenEXR's own default chromaticities (Rec.709, white 0.3127 0.3290) as floats.
    EXPECT_EQ(identify_primaries({0.64f, 0.33f, 0.3f, 0.6f, 0.15f, 0.06f, 0.3127f, 0.329f}), KnownPrimaries::Rec709);
    // AP0 and AP1 share a white but not primaries.
    EXPECT_EQ(identify_primaries({0.713f, 0.293f, 0.165f, 0.83f, 0.128f, 0.044f, 0.32168f, 0.33767f}),
              KnownPrimaries::AcesAP1);
}

TEST(Spectral, ColourMatchingFunctionsFollowTheCieTable) {
    // CIE 1931 2-degree observer, tabulated values.
    const std::pair<double, std::array<double, 3>> table[] = {
        {450, {0.3362, 0.0380, 1.7721}}, {500, {0.0049, 0.3230, 0.2720}}, {530, {0.1655, 0.8620, 0.0422}},
        {555, {0.5121, 1.0000, 0.0057}}, {600, {1.0622, 0.6310, 0.0008}}, {650, {0.2835, 0.1070, 0.0000}}};
    for (const auto& [nm, xyz] : table) {
        const auto got = cie1931_xyz(nm);
        for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(got[i], xyz[i], 0.015) << nm << " nm, component " << i;
    }
    // The three functions have (nearly) equal areas: an equal-energy spectrum is the white E (x = y = 1/3).
    std::array<double, 3> area{};
    for (double nm = 360; nm <= 830; nm += 1)
        for (std::size_t i = 0; i < 3; ++i) area[i] += cie1931_xyz(nm)[i];
    EXPECT_NEAR(area[0] / area[1], 1.0, 0.01);
    EXPECT_NEAR(area[2] / area[1], 1.0, 0.01);
    EXPECT_NEAR(area[1], 106.86, 1.0);  // the CIE table's sum at 1 nm
}

TEST(Spectral, WavelengthsLandInTheWorkingPrimaries) {
    const Mat3 rec709 = rgb_to_xyz(chromaticities(KnownPrimaries::Rec709));
    const auto green = wavelength_to_rgb(540, rec709);
    EXPECT_GT(green[1], green[0]);
    EXPECT_GT(green[1], green[2]);
    // 450 nm is outside Rec.709 (negative green) but inside AP0, whose gamut holds every spectral colour.
    EXPECT_LT(wavelength_to_rgb(450, rec709)[1], 0.0);
    const Mat3 ap0 = rgb_to_xyz(chromaticities(KnownPrimaries::AcesAP0));
    for (double nm = 420; nm <= 680; nm += 10)
        for (double v : wavelength_to_rgb(nm, ap0)) EXPECT_GT(v, -1e-3) << nm;
    // Back to XYZ exactly.
    const auto rgb = wavelength_to_rgb(580, rec709);
    const auto xyz = cie1931_xyz(580);
    for (int i = 0; i < 3; ++i)
        EXPECT_NEAR(rec709[3 * i] * rgb[0] + rec709[3 * i + 1] * rgb[1] + rec709[3 * i + 2] * rgb[2],
                    xyz[static_cast<std::size_t>(i)], 1e-12);
}

// ----------------------------------------------------------------------------------------------------------

TEST(BuiltinConfig, HasTheDocumentedDisplaysViewsAndLooks) {
    const auto cfg = ColourConfig::builtin_config();
    EXPECT_TRUE(cfg.is_builtin());
    EXPECT_EQ(cfg.displays(), (std::vector<std::string>{"srgb", "rec709", "rec2100-pq"}));
    EXPECT_EQ(cfg.default_display(), "srgb");
    EXPECT_EQ(cfg.default_view("srgb"), builtin::view_sdr);
    EXPECT_EQ(cfg.default_view("rec2100-pq"), builtin::view_hdr);
    EXPECT_EQ(cfg.views("rec709").size(), 2u);
    EXPECT_EQ(cfg.looks().size(), 2u);
    EXPECT_NO_THROW(cfg.ocio()->validate());
}

TEST(BuiltinConfig, MiddleGreyThroughAcesSdrVideoSrgb) {
    ColourPipeline p(ColourConfig::builtin_config(), ColourOptions{}, std::nullopt);
    EXPECT_EQ(p.input_space(), builtin::lin_rec709);
    EXPECT_EQ(p.display(), "srgb");
    EXPECT_EQ(p.view(), builtin::view_sdr);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(display_of(p, 0.18f, 0.18f, 0.18f, c), 0.356, 1e-3);
}

TEST(BuiltinConfig, UntonemappedSrgbIsTheSrgbCurve) {
    ColourOptions o;
    o.view = builtin::view_untonemapped;
    ColourPipeline p(ColourConfig::builtin_config(), o, std::nullopt);
    for (float v : {0.001f, 0.0031308f, 0.18f, 0.5f, 0.9f}) {
        const double want = v <= 0.0031308f ? 12.92 * static_cast<double>(v)
                                             : 1.055 * std::pow(static_cast<double>(v), 1 / 2.4) - 0.055;
        EXPECT_NEAR(display_of(p, v, v, v), want, 2e-5) << v;
    }
}

TEST(BuiltinConfig, FarAboveWhiteClampsToOne) {
    const auto cfg = ColourConfig::builtin_config();
    for (const auto& d : cfg.displays())
        for (const auto& v : cfg.views(d)) {
            ColourOptions o;
            o.display = d;
            o.view = v;
            ColourPipeline p(cfg, o, std::nullopt);
            std::vector<float> px{1e4f, 1e4f, 1e4f, 1e6f, 1e6f, 1e6f, 60000.f, 0.f, 0.f};
            p.to_display().apply_rgb(px.data(), 3);
            for (float x : px) {
                EXPECT_LE(x, 1.0f) << d << " / " << v;
                EXPECT_GE(x, 0.0f) << d << " / " << v;
            }
            // SDR displays reach full white; the 1000-nit PQ view peaks near PQ(1000 nits) = 0.7518.
            const float peak = d == "rec2100-pq" && v == builtin::view_hdr ? 0.7518f : 1.0f;
            EXPECT_NEAR(px[1], peak, 3e-3) << d << " / " << v;
        }
}

TEST(BuiltinConfig, NanAndInfNeverReachTheOutput) {
    const auto cfg = ColourConfig::builtin_config();
    const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
    for (const auto& d : cfg.displays()) {
        ColourOptions o;
        o.display = d;
        ColourPipeline p(cfg, o, std::nullopt);
        std::vector<float> px{nan, nan, nan, inf, inf, inf, -inf, -inf, -inf, nan, inf, -inf, 0.18f, nan, 0.18f};
        p.to_display().apply_rgb(px.data(), 5);
        for (float x : px) {
            EXPECT_TRUE(std::isfinite(x)) << d;
            EXPECT_GE(x, 0.0f) << d;
            EXPECT_LE(x, 1.0f) << d;
        }
        // NaN and -Inf are black, +Inf is the brightest white.
        EXPECT_FLOAT_EQ(px[0], display_of(p, 0, 0, 0)) << d;
        EXPECT_FLOAT_EQ(px[6], display_of(p, 0, 0, 0)) << d;
        EXPECT_FLOAT_EQ(px[3], display_of(p, 65504.f, 65504.f, 65504.f)) << d;
    }
    // Scene-linear conversions keep values finite too.
    const auto t = make_transform(cfg, std::string(builtin::lin_rec709), std::string(builtin::acescg));
    std::vector<float> px{nan, inf, -inf};
    t.apply_rgb(px.data(), 1);
    for (float x : px) EXPECT_TRUE(std::isfinite(x));
}

TEST(BuiltinConfig, EveryDisplayViewMatchesOcioOwnProcessor) {
    const auto cfg = ColourConfig::builtin_config();
    const auto pixels = random_hdr_pixels(4096, 7);
    for (const auto& d : cfg.displays())
        for (const auto& v : cfg.views(d)) {
            ColourOptions o;
            o.display = d;
            o.view = v;
            ColourPipeline p(cfg, o, std::nullopt);
            auto ours = pixels;
            p.to_display().apply(PixelSpan{ours.data(), 64, 64, 3, 0});
            const auto ref = ocio_reference(cfg, p.working().name, d, v, pixels);
            EXPECT_LT(max_abs_diff(ours, ref), 1e-4f) << d << " / " << v;
        }
}

TEST(BuiltinConfig, SerialisedConfigLoadsFromFileAndFromOcioVariable) {
    const auto builtin_cfg = ColourConfig::builtin_config();
    const fs::path file = fs::temp_directory_path() / "lensfx_colour_test_builtin.ocio";
    std::ofstream(file) << builtin_cfg.serialize();
    const auto loaded = ColourConfig::load(file.string());
    EXPECT_FALSE(loaded.is_builtin());
    EXPECT_EQ(loaded.source(), file.string());
    EXPECT_EQ(loaded.displays(), builtin_cfg.displays());

    const auto pixels = random_hdr_pixels(1024, 3);
    auto a = pixels, b = pixels;
    ColourPipeline(builtin_cfg, ColourOptions{}, std::nullopt).to_display().apply_rgb(a.data(), 1024);
    ColourPipeline(loaded, ColourOptions{}, std::nullopt).to_display().apply_rgb(b.data(), 1024);
    EXPECT_EQ(a, b);

    const char* previous = std::getenv("OCIO");
    const std::string saved = previous ? previous : "";
    setenv("OCIO", file.string().c_str(), 1);
    EXPECT_EQ(ColourConfig::load("").source(), file.string());
    unsetenv("OCIO");
    EXPECT_TRUE(ColourConfig::load("").is_builtin());
    if (previous) setenv("OCIO", saved.c_str(), 1);
    fs::remove(file);
}

// ----------------------------------------------------------------------------------------------------------

TEST(Pipeline, ExposureIsAScaleBeforeTheView) {
    ColourOptions o;
    o.exposure_ev = 1.0;
    ColourPipeline brighter(ColourConfig::builtin_config(), o, std::nullopt);
    ColourPipeline plain(ColourConfig::builtin_config(), ColourOptions{}, std::nullopt);
    EXPECT_NEAR(display_of(brighter, 0.09f, 0.05f, 0.2f), display_of(plain, 0.18f, 0.1f, 0.4f), 1e-5);
    EXPECT_NEAR(display_of(brighter, 0.09f, 0.09f, 0.09f), 0.356, 1e-3);
}

TEST(Pipeline, LookReplacesTheViewLooks) {
    ColourOptions o;
    o.look = "Blue Light Artifact Fix";
    ColourPipeline look(ColourConfig::builtin_config(), o, std::nullopt);
    ColourPipeline plain(ColourConfig::builtin_config(), ColourOptions{}, std::nullopt);
    // A saturated blue light is desaturated; a grey is (almost) untouched.
    EXPECT_GT(display_of(look, 0.02f, 0.02f, 4.0f, 1), display_of(plain, 0.02f, 0.02f, 4.0f, 1) + 0.01f);
    EXPECT_NEAR(display_of(look, 0.18f, 0.18f, 0.18f), display_of(plain, 0.18f, 0.18f, 0.18f), 2e-3);
}

TEST(Pipeline, InputSpaceFromChromaticities) {
    const auto cfg = ColourConfig::builtin_config();
    const std::pair<KnownPrimaries, std::string_view> cases[] = {{KnownPrimaries::Rec709, builtin::lin_rec709},
                                                                 {KnownPrimaries::AcesAP0, builtin::aces2065_1},
                                                                 {KnownPrimaries::AcesAP1, builtin::acescg},
                                                                 {KnownPrimaries::Rec2020, builtin::lin_rec2020},
                                                                 {KnownPrimaries::P3D65, builtin::lin_p3d65}};
    for (const auto& [k, space] : cases) {
        ColourPipeline p(cfg, ColourOptions{}, exr(chromaticities(k)));
        EXPECT_EQ(p.input_space(), space);
        EXPECT_EQ(p.working().name, space);
        EXPECT_TRUE(p.working().is_input_space);
        EXPECT_TRUE(p.to_working().is_identity());
        EXPECT_EQ(identify_primaries(exr(p.working().primaries)), k);
    }
}

// The same colour given in different primaries shows the same on the display: checks the module's own
// matrices against OCIO's built-in ACES transforms.
TEST(Pipeline, SameColourInOtherPrimariesDisplaysTheSame) {
    const auto cfg = ColourConfig::builtin_config();
    ColourPipeline rec709(cfg, ColourOptions{}, std::nullopt);
    const Mat3 to_xyz = rgb_to_xyz(chromaticities(KnownPrimaries::Rec709));
    const std::array<float, 8> adobe{0.64f, 0.33f, 0.21f, 0.71f, 0.15f, 0.06f, 0.3127f, 0.329f};  // Adobe RGB (1998)
    const Chromaticities adobe_c{0.64, 0.33, 0.21, 0.71, 0.15, 0.06, 0.3127, 0.329};
    const auto ap0 = chromaticities(KnownPrimaries::AcesAP0);
    struct Case {
        std::array<float, 8> chroma;
        Mat3 from_xyz_d65;
    };
    const Case cases[] = {
        {exr(chromaticities(KnownPrimaries::Rec2020)), inverse(rgb_to_xyz(chromaticities(KnownPrimaries::Rec2020)))},
        {adobe, inverse(rgb_to_xyz(adobe_c))},
        {exr(ap0), multiply(inverse(rgb_to_xyz(ap0)), bradford(0.3127, 0.3290, ap0.wx, ap0.wy))},
    };
    const std::array<std::array<double, 3>, 4> colours{{{0.18, 0.18, 0.18}, {0.6, 0.2, 0.05}, {0.05, 0.3, 0.5}, {2.0, 1.5, 0.9}}};
    for (const auto& c : cases) {
        ColourPipeline other(cfg, ColourOptions{}, c.chroma);
        const Mat3 m = multiply(c.from_xyz_d65, to_xyz);
        for (const auto& rgb : colours) {
            float a[3] = {static_cast<float>(rgb[0]), static_cast<float>(rgb[1]), static_cast<float>(rgb[2])};
            float b[3];
            for (int i = 0; i < 3; ++i)
                b[i] = static_cast<float>(m[3 * i] * rgb[0] + m[3 * i + 1] * rgb[1] + m[3 * i + 2] * rgb[2]);
            rec709.to_display().apply_rgb(a, 1);
            other.to_display().apply_rgb(b, 1);
            for (int i = 0; i < 3; ++i) EXPECT_NEAR(a[i], b[i], 1e-4) << other.input_space() << " channel " << i;
        }
    }
}

TEST(Pipeline, WorkingPrimariesOfNamedSpacesAreMeasured) {
    const auto cfg = ColourConfig::builtin_config();
    ColourOptions o;
    o.colorspace = "ACEScg";
    ColourPipeline p(cfg, o, exr(chromaticities(KnownPrimaries::Rec709)));  // --colorspace wins over the file
    EXPECT_EQ(p.input_space(), "ACEScg");
    EXPECT_EQ(identify_primaries(exr(p.working().primaries)), KnownPrimaries::AcesAP1);
    o.colorspace = "Linear Rec.2020";
    EXPECT_EQ(identify_primaries(exr(ColourPipeline(cfg, o, std::nullopt).working().primaries)),
              KnownPrimaries::Rec2020);
    // The matrix given to the renderer is that of the primaries: white (1,1,1) -> Y = 1.
    const Mat3& m = p.working().rgb_to_xyz;
    EXPECT_NEAR(m[3] + m[4] + m[5], 1.0, 1e-12);
}

TEST(Pipeline, NonLinearInputWorksInSceneLinear) {
    auto copy = ColourConfig::builtin_config().ocio()->createEditableCopy();
    auto cct = OCIO::ColorSpace::Create(OCIO::REFERENCE_SPACE_SCENE);
    cct->setName("ACEScct");
    auto to_ref = OCIO::BuiltinTransform::Create();
    to_ref->setStyle("ACEScct_to_ACES2065-1");
    cct->setTransform(to_ref, OCIO::COLORSPACE_DIR_TO_REFERENCE);
    copy->addColorSpace(cct);
    const fs::path file = fs::temp_directory_path() / "lensfx_colour_test_cct.ocio";
    {
        std::ofstream os(file);
        copy->serialize(os);
    }
    ColourOptions o;
    o.colorspace = "ACEScct";
    ColourPipeline p(ColourConfig::load(file.string()), o, std::nullopt);
    fs::remove(file);
    EXPECT_FALSE(p.working().is_input_space);
    EXPECT_EQ(p.working().name, "ACEScg");  // the scene_linear role
    // ACEScct 0.4135884 is linear 0.18 (ACES S-2016-001).
    float px[3] = {0.4135884f, 0.4135884f, 0.4135884f};
    p.to_working().apply_rgb(px, 1);
    EXPECT_NEAR(px[0], 0.18f, 1e-5);
    p.to_scene_output().apply_rgb(px, 1);
    EXPECT_NEAR(px[0], 0.4135884f, 1e-5);
}

TEST(Pipeline, RgbaAndStridedPixelsLeaveOtherChannelsAlone) {
    ColourPipeline p(ColourConfig::builtin_config(), ColourOptions{}, std::nullopt);
    for (int channels : {4, 5}) {
        const std::size_t w = 17, h = 5, stride = w * static_cast<std::size_t>(channels) + 3;
        std::vector<float> px(stride * h);
        std::iota(px.begin(), px.end(), 0.0f);
        for (float& v : px) v = v * 0.01f;
        auto out = px;
        p.to_display().apply(PixelSpan{out.data(), w, h, channels, stride});
        for (std::size_t y = 0; y < h; ++y) {
            for (std::size_t x = 0; x < w; ++x) {
                const std::size_t i = y * stride + x * static_cast<std::size_t>(channels);
                float rgb[3] = {px[i], px[i + 1], px[i + 2]};
                p.to_display().apply_rgb(rgb, 1);
                for (int c = 0; c < 3; ++c) EXPECT_NEAR(out[i + static_cast<std::size_t>(c)], rgb[c], 1e-6);
                for (int c = 3; c < channels; ++c)
                    EXPECT_EQ(out[i + static_cast<std::size_t>(c)], px[i + static_cast<std::size_t>(c)]) << channels << " ch " << c << " x " << x << " y " << y;
            }
            for (std::size_t i = y * stride + w * static_cast<std::size_t>(channels); i < (y + 1) * stride; ++i)
                EXPECT_EQ(out[i], px[i]);  // row padding
        }
    }
}

TEST(Pipeline, ThreadedFrameEqualsRowByRow) {
    ColourPipeline p(ColourConfig::builtin_config(), ColourOptions{}, std::nullopt);
    const std::size_t w = 640, h = 480;
    const auto pixels = random_hdr_pixels(w * h, 11);
    auto frame = pixels, rows = pixels;
    p.to_display().apply(PixelSpan{frame.data(), w, h, 3, 0});
    for (std::size_t y = 0; y < h; ++y) p.to_display().apply_rgb(rows.data() + y * w * 3, w);
    EXPECT_EQ(frame, rows);
}

// ----------------------------------------------------------------------------------------------------------

TEST(Errors, BadConfigNamesTheFile) {
    const fs::path file = fs::temp_directory_path() / "lensfx_colour_test_bad.ocio";
    std::ofstream(file) << "ocio_profile_version: 2\nroles: [this is not a config\n";
    const std::string e = error_of([&] { ColourConfig::load(file.string()); });
    EXPECT_NE(e.find(file.string()), std::string::npos) << e;
    fs::remove(file);
    const std::string missing = error_of([] { ColourConfig::load("/nonexistent/lensfx.ocio"); });
    EXPECT_NE(missing.find("/nonexistent/lensfx.ocio"), std::string::npos) << missing;
}

TEST(Errors, UnknownNamesAreNamedWithTheValidOnes) {
    const auto cfg = ColourConfig::builtin_config();
    auto try_options = [&](ColourOptions o) { return error_of([&] { ColourPipeline(cfg, o, std::nullopt); }); };
    ColourOptions o;
    o.colorspace = "Linear Rec.999";
    std::string e = try_options(o);
    EXPECT_NE(e.find("colour space 'Linear Rec.999'"), std::string::npos) << e;
    EXPECT_NE(e.find("ACEScg"), std::string::npos) << e;

    o = {};
    o.display = "cinema";
    e = try_options(o);
    EXPECT_NE(e.find("display 'cinema'"), std::string::npos) << e;
    EXPECT_NE(e.find("srgb, rec709, rec2100-pq"), std::string::npos) << e;

    o = {};
    o.display = "rec709";
    o.view = "Filmic";
    e = try_options(o);
    EXPECT_NE(e.find("view 'Filmic'"), std::string::npos) << e;
    EXPECT_NE(e.find(builtin::view_untonemapped), std::string::npos) << e;

    o = {};
    o.look = "+Blue Light Artifact Fix, -Bleach";
    e = try_options(o);
    EXPECT_NE(e.find("look 'Bleach'"), std::string::npos) << e;
    EXPECT_NE(e.find("Reference Gamut Compression"), std::string::npos) << e;
}

TEST(Errors, FileConfigWithoutMatchingSpaceAsksForColorspace) {
    auto copy = OCIO::Config::CreateRaw()->createEditableCopy();
    const fs::path file = fs::temp_directory_path() / "lensfx_colour_test_raw.ocio";
    {
        std::ofstream os(file);
        copy->serialize(os);
    }
    const auto cfg = ColourConfig::load(file.string());
    fs::remove(file);
    const std::string e = error_of([&] {
        ColourPipeline(cfg, ColourOptions{}, exr(chromaticities(KnownPrimaries::AcesAP0)));
    });
    EXPECT_NE(e.find("--colorspace"), std::string::npos) << e;
    EXPECT_NE(e.find("ACES AP0"), std::string::npos) << e;
    EXPECT_NE(e.find("raw"), std::string::npos) << e;
}

// ----------------------------------------------------------------------------------------------------------

TEST(Output, DisplayReferredFormats) {
    EXPECT_TRUE(is_display_referred_format("out.0001.png"));
    EXPECT_TRUE(is_display_referred_format("OUT.JPG"));
    EXPECT_TRUE(is_display_referred_format("jpeg"));
    EXPECT_FALSE(is_display_referred_format("out.exr"));
    EXPECT_FALSE(is_display_referred_format("out.hdr"));
    EXPECT_FALSE(is_display_referred_format("out.pfm"));
    EXPECT_FALSE(is_display_referred_format("-"));
}

TEST(Dither, QuantisedFlatFieldKeepsItsMean) {
    const std::size_t n = 64;
    for (float level : {0.3f, 0.5017f, 0.0021f}) {
        std::vector<float> px(n * n * 3, level);
        for (Dither d : {Dither::Ordered, Dither::BlueNoise}) {
            const auto q8 = quantise8(PixelSpan{px.data(), n, n, 3, 0}, d, 0);
            const double mean = std::accumulate(q8.begin(), q8.end(), 0.0) / static_cast<double>(q8.size());
            EXPECT_NEAR(mean / 255.0, static_cast<double>(level), 0.25 / 255.0) << static_cast<int>(d);
            const auto q16 = quantise16(PixelSpan{px.data(), n, n, 3, 0}, d, 3);
            const double mean16 = std::accumulate(q16.begin(), q16.end(), 0.0) / static_cast<double>(q16.size());
            EXPECT_NEAR(mean16 / 65535.0, static_cast<double>(level), 0.25 / 65535.0) << static_cast<int>(d);
        }
        const auto plain = quantise8(PixelSpan{px.data(), n, n, 3, 0}, Dither::None, 0);
        for (auto v : plain) EXPECT_EQ(v, static_cast<std::uint8_t>(std::lround(level * 255.0f)));
    }
}

TEST(Dither, PatternsAreUniformDeterministicAndBlue) {
    for (Dither d : {Dither::Ordered, Dither::BlueNoise}) {
        const std::size_t n = d == Dither::Ordered ? 16 : 64;
        std::vector<float> v;
        for (std::size_t y = 0; y < n; ++y)
            for (std::size_t x = 0; x < n; ++x) v.push_back(dither_offset(d, x, y, 0, 0));
        auto sorted = v;
        std::sort(sorted.begin(), sorted.end());
        for (std::size_t i = 0; i < sorted.size(); ++i)  // every threshold level exactly once
            EXPECT_NEAR(sorted[i], (static_cast<float>(i) + 0.5f) / static_cast<float>(sorted.size()) - 0.5f, 1e-6f);
        // Neighbouring thresholds anti-correlate (high-frequency noise); white noise would give ~0.
        double corr = 0.0, var = 0.0;
        for (std::size_t y = 0; y < n; ++y)
            for (std::size_t x = 0; x < n; ++x) {
                const double a = static_cast<double>(v[y * n + x]);
                corr += a * static_cast<double>(v[y * n + (x + 1) % n]) + a * static_cast<double>(v[((y + 1) % n) * n + x]);
                var += 2 * a * a;
            }
        EXPECT_LT(corr / var, -0.2) << static_cast<int>(d);
        EXPECT_EQ(dither_offset(d, 5, 9, 1, 7), dither_offset(d, 5, 9, 1, 7));
        EXPECT_NE(dither_offset(d, 5, 9, 0, 7), dither_offset(d, 5, 9, 0, 8));  // moves over time
    }
}

}  // namespace
