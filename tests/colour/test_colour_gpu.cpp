// The GPU path of the colour transforms (OCIO's GLSL in a compute shader on the project's EGL context,
// GpuColourTransform) against the CPU path: every display/view of the built-in config within 1e-4,
// NaN/Inf included; strided RGBA spans keep their alpha.
#include <filter/colour.h>
#include <gpu/context.h>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>

namespace {

using namespace lensfx::colour;
namespace gpu = lensfx::gpu;

std::unique_ptr<gpu::Context> make_context(std::string& why) {
    try {
        return std::make_unique<gpu::Context>();
    } catch (const std::exception& e) {
        why = e.what();
        return nullptr;
    }
}

// Runs the transform over packed RGB pixels through the library's GPU path.
std::vector<float> run_on_gpu(const ColourTransform& transform, std::vector<float> rgb) {
    GpuColourTransform gpu_transform(transform);
    gpu_transform.apply_rgb(rgb.data(), rgb.size() / 3);
    return rgb;
}

std::vector<float> test_pixels() {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> stops(-10.0f, 12.0f), mix(-0.05f, 1.0f);
    std::vector<float> v;
    for (int i = 0; i < 4000; ++i) {
        const float level = 0.18f * std::exp2(stops(rng));
        for (int c = 0; c < 3; ++c) v.push_back(level * mix(rng));
    }
    const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
    for (float x : {0.0f, 0.18f, 1.0f, 1e4f, nan, inf, -inf, -0.5f}) v.insert(v.end(), {x, x, x});
    v.insert(v.end(), {nan, inf, -inf, 0.18f, nan, 2.0f});
    return v;
}

TEST(ColourGpu, EveryDisplayViewMatchesTheCpuPath) {
    std::string why;
    auto context = make_context(why);
    if (!context) GTEST_SKIP() << "no EGL/OpenGL 4.3 context: " << why;
    const auto cfg = ColourConfig::builtin_config();
    const auto pixels = test_pixels();
    for (const auto& d : cfg.displays())
        for (const auto& v : cfg.views(d)) {
            ColourOptions o;
            o.display = d;
            o.view = v;
            o.exposure_ev = 0.5;
            ColourPipeline p(cfg, o, std::nullopt);
            auto cpu = pixels;
            p.to_display().apply_rgb(cpu.data(), cpu.size() / 3);
            const auto shader = gpu_shader(p.to_display());
            const auto gpu_out = run_on_gpu(p.to_display(), pixels);
            float worst = 0.0f;
            for (std::size_t i = 0; i < cpu.size(); ++i) {
                ASSERT_TRUE(std::isfinite(gpu_out[i])) << d << " / " << v << " value " << i;
                worst = std::max(worst, std::abs(cpu[i] - gpu_out[i]));
            }
            EXPECT_LT(worst, 1e-4f) << d << " / " << v << " (" << shader.textures.size() << " LUT textures)";
        }
}

TEST(ColourGpu, SceneConversionMatchesTheCpuPath) {
    std::string why;
    auto context = make_context(why);
    if (!context) GTEST_SKIP() << "no EGL/OpenGL 4.3 context: " << why;
    const auto cfg = ColourConfig::builtin_config();
    const auto t = make_transform(cfg, "Linear Rec.709 (sRGB)", "ACEScg");
    const auto pixels = test_pixels();
    auto cpu = pixels;
    t.apply_rgb(cpu.data(), cpu.size() / 3);
    const auto gpu_out = run_on_gpu(t, pixels);
    for (std::size_t i = 0; i < cpu.size(); ++i)
        EXPECT_NEAR(gpu_out[i], cpu[i], 1e-4f * std::max(1.0f, std::abs(cpu[i]))) << i;
}

TEST(ColourGpu, StridedRgbaSpanMatchesTheCpuPathAndKeepsAlpha) {
    std::string why;
    auto context = make_context(why);
    if (!context) GTEST_SKIP() << "no EGL/OpenGL 4.3 context: " << why;
    ColourOptions o;
    o.display = "srgb";
    ColourPipeline p(ColourConfig::builtin_config(), o, std::nullopt);
    const auto rgb = test_pixels();
    const std::size_t count = rgb.size() / 3, width = 40, height = count / width, stride = width * 4 + 3;
    std::vector<float> rgba(height * stride, -7.0f);
    for (std::size_t y = 0; y < height; ++y)
        for (std::size_t x = 0; x < width; ++x)
            for (std::size_t c = 0; c < 3; ++c) rgba[y * stride + x * 4 + c] = rgb[(y * width + x) * 3 + c];
    auto cpu = rgba;
    p.to_display().apply({cpu.data(), width, height, 4, stride});
    GpuColourTransform gpu_transform(p.to_display());
    gpu_transform.apply({rgba.data(), width, height, 4, stride});
    for (std::size_t i = 0; i < rgba.size(); ++i) {
        if (i % stride >= width * 4 || (i % stride) % 4 == 3) {
            ASSERT_EQ(rgba[i], -7.0f) << i;  // alpha and row padding untouched
        } else {
            ASSERT_NEAR(rgba[i], cpu[i], 1e-4f) << i;
        }
    }
}

}  // namespace
