// The headless EGL context, named shader errors and the float render target.
#include <stdexcept>
#include <string>
#include <vector>

#include <epoxy/gl.h>

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

// A buffer read by texel fetches (the ghost shaders' traced vertices, steps, tables, jobs and lists): its texels come
// back as written, and a view of more texels than the GL's largest buffer texture is refused by name rather than
// read past the limit, where a texel fetch's result is undefined.
TEST(BufferTexels, ReadBackAsWrittenAndOverTheLimitRefused) {
    const Context context(Platform::Surfaceless);
    const std::vector<float> written{1.5f, -2.0f, 3.25f, 4.0f, 5.0f, 6.0f, 7.0f, 8.0f};
    GlObject buffer = GlObject::buffer();
    glNamedBufferStorage(buffer.get(), static_cast<GLsizeiptr>(written.size() * sizeof(float)), written.data(), 0);
    GlObject texels = GlObject::buffer_texture();
    view_buffer_texels(texels, GL_RGBA32F, buffer, 2, "the test's vertices");
    const Program program("texel_copy.comp", {{ShaderStage::Type::Compute, R"GLSL(#version 430
layout(local_size_x = 2) in;
uniform samplerBuffer texels;
layout(std430, binding = 0) writeonly buffer Out { vec4 copied[]; };
void main() { copied[gl_LocalInvocationID.x] = texelFetch(texels, int(gl_LocalInvocationID.x)); }
)GLSL"}});
    GlObject out = GlObject::buffer();
    glNamedBufferStorage(out.get(), static_cast<GLsizeiptr>(written.size() * sizeof(float)), nullptr, 0);
    glUseProgram(program.get());
    glProgramUniform1i(program.get(), program.uniform("texels"), 2);
    glBindTextureUnit(2, texels.get());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, out.get());
    glDispatchCompute(1, 1, 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    std::vector<float> copied(written.size());
    glGetNamedBufferSubData(out.get(), 0, static_cast<GLsizeiptr>(copied.size() * sizeof(float)), copied.data());
    EXPECT_EQ(copied, written);

    GLint most = 0;
    glGetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &most);
    try {
        view_buffer_texels(texels, GL_RGBA32F, buffer, static_cast<std::size_t>(most) + 1, "the test's vertices");
        FAIL() << "a view past the limit was taken";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("the test's vertices"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("largest buffer texture"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace lensfx::gpu
