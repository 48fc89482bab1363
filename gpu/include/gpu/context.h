// A headless OpenGL 4.x core context through EGL, with no window system: the EGL device platform
// (a GPU driver's device) or Mesa's surfaceless platform (llvmpipe). One object owns display + context.
#pragma once

#include <string>
#include <string_view>

namespace lensfx::gpu {

enum class Platform { Auto, Device, Surfaceless };

// "auto", "device", "surfaceless"; throws on anything else.
Platform parse_platform(std::string_view name);
std::string_view platform_name(Platform platform);

struct ContextInfo {
    Platform platform = Platform::Auto;  // the one actually used (never Auto)
    std::string device;                  // EGL device extensions / DRM node, empty on surfaceless
    bool software = false;               // llvmpipe / softpipe / a software EGL device
    std::string egl_vendor;
    std::string egl_version;
    std::string gl_vendor;
    std::string gl_renderer;
    std::string gl_version;
    std::string glsl_version;
    int gl_major = 0;
    int gl_minor = 0;
};

// Creates a display, an OpenGL 4.3+ core context (compute shaders) and makes it current on the
// calling thread. Throws std::runtime_error naming the platform and the EGL call that failed.
class Context {
public:
    explicit Context(Platform platform = Platform::Auto);
    ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;
    Context(Context&&) = delete;
    Context& operator=(Context&&) = delete;

    const ContextInfo& info() const { return info_; }
    void make_current() const;
    // Leaves the calling thread without a current context, so that another thread can make this one current.
    void release() const;

private:
    void* display_ = nullptr;  // EGLDisplay
    void* context_ = nullptr;  // EGLContext
    ContextInfo info_;
};

}  // namespace lensfx::gpu
