// Real OpenEXR samples (../shared/data) through the lensfx program's colour path: a file with its own
// (non-standard) chromaticities, and a file holding NaN and Inf pixels.
#include <filter/colour.h>

#include <gtest/gtest.h>

#include "run_lensfx.h"

#include <filter/image_io.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace {

using namespace lensfx::colour;
namespace fs = std::filesystem;

const fs::path hdr = fs::path(LENSFX_SHARED_DIR) / "data" / "hdr";

struct Image {
    OIIO::ImageSpec spec;
    std::vector<float> px;
};

Image read(const fs::path& file) {
    Image img;
    auto in = OIIO::ImageInput::open(file.string());
    if (!in) return img;
    img.spec = in->spec();
    img.px.resize(img.spec.image_pixels() * static_cast<std::size_t>(img.spec.nchannels));
    in->read_image(0, 0, 0, img.spec.nchannels, OIIO::TypeFloat, img.px.data());
    return img;
}

fs::path temp(const std::string& name) { return fs::temp_directory_path() / ("lensfx_colour_data_" + name); }

int lensfx(const std::string& args) { return lensfx::test::run_lensfx_status(args); }

TEST(ColourData, OwnChromaticitiesAreHonoured) {
    const fs::path tree = hdr / "ScanLines" / "Tree.exr";
    if (!fs::exists(tree)) GTEST_SKIP() << tree << " not found (../shared/data absent)";
    const Image in = read(tree);
    const auto chroma = lensfx::filter::read_image(tree.string()).spec.chromaticities;  // lensfx's own EXR reader
    ASSERT_TRUE(chroma) << "Tree.exr is expected to carry chromaticities";
    EXPECT_FALSE(identify_primaries(*chroma)) << "Tree.exr's primaries are not a standard set";

    const fs::path out = temp("tree.exr");
    ASSERT_EQ(lensfx("-i " + tree.string() + " -o " + out.string() + " --display srgb"), 0);
    const Image shown = read(out);
    fs::remove(out);
    ASSERT_EQ(shown.px.size() / static_cast<std::size_t>(shown.spec.nchannels), in.px.size() / static_cast<std::size_t>(in.spec.nchannels));

    // Independently: the file's RGB -> XYZ -> Bradford to D65 -> linear Rec.709, then the Rec.709 display path.
    const Chromaticities c{(*chroma)[0], (*chroma)[1], (*chroma)[2], (*chroma)[3],
                           (*chroma)[4], (*chroma)[5], (*chroma)[6], (*chroma)[7]};
    const Mat3 m = multiply(inverse(rgb_to_xyz(chromaticities(KnownPrimaries::Rec709))),
                            multiply(bradford(c.wx, c.wy, 0.3127, 0.3290), rgb_to_xyz(c)));
    ColourPipeline rec709(ColourConfig::builtin_config(), ColourOptions{}, std::nullopt);
    const std::size_t n = in.px.size() / static_cast<std::size_t>(in.spec.nchannels);
    const auto nc = static_cast<std::size_t>(in.spec.nchannels), oc = static_cast<std::size_t>(shown.spec.nchannels);
    double worst = 0.0;
    for (std::size_t i = 0; i < n; i += 97) {  // a spread sample of pixels
        const double r = static_cast<double>(in.px[i * nc]), g = static_cast<double>(in.px[i * nc + 1]),
                     b = static_cast<double>(in.px[i * nc + 2]);
        float rgb[3];
        for (int k = 0; k < 3; ++k) rgb[k] = static_cast<float>(m[3 * k] * r + m[3 * k + 1] * g + m[3 * k + 2] * b);
        rec709.to_display().apply_rgb(rgb, 1);
        for (std::size_t k = 0; k < 3; ++k)
            worst = std::max(worst, std::abs(static_cast<double>(shown.px[i * oc + k]) - static_cast<double>(rgb[k])));
    }
    EXPECT_LT(worst, 2e-3);  // the output EXR is half float
}

TEST(ColourData, NanAndInfPixelsBecomeFiniteDisplayValues) {
    const fs::path rings = hdr / "TestImages" / "BrightRingsNanInf.exr";
    if (!fs::exists(rings)) GTEST_SKIP() << rings << " not found (../shared/data absent)";
    const Image in = read(rings);
    std::size_t non_finite = 0;
    for (float v : in.px) non_finite += std::isfinite(v) ? 0 : 1;
    ASSERT_GT(non_finite, 0u) << "the sample is expected to hold NaN/Inf";
    const fs::path out = temp("rings.exr");
    ASSERT_EQ(lensfx("-i " + rings.string() + " -o " + out.string() + " --display rec709"), 0);
    const Image shown = read(out);
    fs::remove(out);
    ASSERT_EQ(shown.px.size(), in.px.size());
    for (float v : shown.px) {
        ASSERT_TRUE(std::isfinite(v));
        ASSERT_GE(v, 0.0f);
        ASSERT_LE(v, 1.0f);
    }
}

}  // namespace
