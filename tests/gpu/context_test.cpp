// The headless EGL context, named shader errors and the float render target.
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include <gpu/context.h>
#include <gpu/gl.h>

namespace lensfx::gpu {
namespace {

TEST(Context, SurfacelessGivesOpenGL43Core) {
    const Context context(Platform::Surfaceless);
    const ContextInfo& info = context.info();
    EXPECT_EQ(info.platform, Platform::Surfaceless);
    EXPECT_GE(info.gl_major * 10 + info.gl_minor, 43) << info.gl_version;
    EXPECT_FALSE(info.gl_renderer.empty());
    EXPECT_FALSE(info.egl_version.empty());
    EXPECT_NE(info.gl_version.find("Core"), std::string::npos) << info.gl_version;
}

TEST(Context, AutoPicksARealPlatform) {
    const Context context(Platform::Auto);
    EXPECT_NE(context.info().platform, Platform::Auto);
}

TEST(Context, PlatformNames) {
    EXPECT_EQ(parse_platform("auto"), Platform::Auto);
    EXPECT_EQ(parse_platform("device"), Platform::Device);
    EXPECT_EQ(parse_platform("surfaceless"), Platform::Surfaceless);
    EXPECT_THROW(parse_platform("x11"), std::invalid_argument);
}

TEST(Program, CompileErrorNamesTheShader) {
    const Context context(Platform::Surfaceless);
    try {
        const Program program("broken_test.comp",
                              {{ShaderStage::Type::Compute, "#version 430\nlayout(local_size_x = 1) in;\n"
                                                            "void main() { undefined_symbol = 1; }\n"}});
        FAIL() << "a broken shader compiled";
    } catch (const std::runtime_error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("broken_test.comp"), std::string::npos) << message;
        EXPECT_NE(message.find("compute"), std::string::npos) << message;
    }
}

TEST(Program, LinkErrorNamesTheProgram) {
    const Context context(Platform::Surfaceless);
    // The fragment stage reads a varying the vertex stage never writes: a link error.
    const char* vert = "#version 430\nvoid main() { gl_Position = vec4(0.0); }\n";
    const char* frag = "#version 430\nin vec3 missing;\nout vec4 c;\nvoid main() { c = vec4(missing, 1.0); }\n";
    try {
        const Program program("mismatch_test", {{ShaderStage::Type::Vertex, vert}, {ShaderStage::Type::Fragment, frag}});
        FAIL() << "mismatched stages linked";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("mismatch_test"), std::string::npos) << e.what();
    }
}

TEST(FloatTarget, ClearsAndReadsBackZeros) {
    const Context context(Platform::Surfaceless);
    const FloatTarget target(7, 5);
    target.clear();
    const auto pixels = target.read_rgba();
    ASSERT_EQ(pixels.size(), 7u * 5u * 4u);
    for (float v : pixels) EXPECT_EQ(v, 0.0f);
    EXPECT_THROW(FloatTarget(0, 4), std::invalid_argument);
}

}  // namespace
}  // namespace lensfx::gpu
