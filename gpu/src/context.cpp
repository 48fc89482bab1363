// EGL headless context: device platform (hardware first) or Mesa surfaceless, OpenGL 4.3+ core.
#include <gpu/context.h>

#include <gpu/address_space.h>

#include <cstring>
#include <stdexcept>
#include <vector>

#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <fmt/core.h>

namespace lensfx::gpu {
namespace {

constexpr int required_major = 4;
constexpr int required_minor = 3;  // compute shaders and shader storage buffers

bool has_extension(const char* list, const char* name) {
    if (!list) return false;
    const std::size_t len = std::strlen(name);
    for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += len) {
        const bool starts = p == list || p[-1] == ' ';
        const bool ends = p[len] == '\0' || p[len] == ' ';
        if (starts && ends) return true;
    }
    return false;
}

std::string egl_error_name(EGLint code) {
    switch (code) {
        case EGL_SUCCESS: return "EGL_SUCCESS";
        case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
        case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
        case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
        case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
        case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
        case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
        case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
        case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
        case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
        default: return fmt::format("EGL error 0x{:04x}", code);
    }
}

[[noreturn]] void fail(Platform platform, const std::string& what) {
    throw std::runtime_error(fmt::format("EGL ({} platform): {} ({})", platform_name(platform), what,
                                         egl_error_name(eglGetError())));
}

struct DeviceChoice {
    EGLDeviceEXT device = EGL_NO_DEVICE_EXT;
    std::string description;
    bool software = false;
};

// Hardware devices first; a software device (Mesa's llvmpipe device) only when nothing else exists.
DeviceChoice pick_device() {
    EGLint count = 0;
    if (!eglQueryDevicesEXT(0, nullptr, &count) || count <= 0) return {};
    std::vector<EGLDeviceEXT> devices(static_cast<std::size_t>(count));
    eglQueryDevicesEXT(count, devices.data(), &count);
    DeviceChoice best;
    for (EGLint i = 0; i < count; ++i) {
        const char* ext = eglQueryDeviceStringEXT(devices[static_cast<std::size_t>(i)], EGL_EXTENSIONS);
        const bool software = has_extension(ext, "EGL_MESA_device_software");
        std::string description = fmt::format("EGL device {} of {}", i, count);
        if (has_extension(ext, "EGL_EXT_device_drm")) {
            if (const char* node = eglQueryDeviceStringEXT(devices[static_cast<std::size_t>(i)],
                                                           EGL_DRM_DEVICE_FILE_EXT)) {
                description += fmt::format(" ({})", node);
            }
        }
        if (software) description += " (software)";
        if (best.device == EGL_NO_DEVICE_EXT || (best.software && !software)) {
            best = {devices[static_cast<std::size_t>(i)], description, software};
        }
    }
    return best;
}

struct ClientPlatforms {
    bool device = false;       // EGL_EXT_platform_device with device enumeration
    bool surfaceless = false;  // EGL_MESA_platform_surfaceless
};

// The platforms this EGL client library offers; throws when it offers no client extensions at all.
ClientPlatforms query_client_platforms() {
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!client) {
        throw std::runtime_error("EGL: no client extensions (EGL 1.5 or EGL_EXT_client_extensions needed); "
                                 "is an EGL driver (libEGL + Mesa) installed?");
    }
    return {has_extension(client, "EGL_EXT_platform_device") && has_extension(client, "EGL_EXT_device_enumeration"),
            has_extension(client, "EGL_MESA_platform_surfaceless")};
}

struct OpenDisplay {
    EGLDisplay display = EGL_NO_DISPLAY;
    Platform platform = Platform::Auto;
    std::string device;     // the device's description (device platform only)
    bool software = false;  // the device is a software one
};

// A device display when one is requested or (for auto) a hardware device exists or surfaceless is missing;
// an empty OpenDisplay when auto falls back to surfaceless.
OpenDisplay open_device_display(Platform requested, const ClientPlatforms& client) {
    const DeviceChoice choice = client.device ? pick_device() : DeviceChoice{};
    const bool take = choice.device != EGL_NO_DEVICE_EXT &&
                      (requested == Platform::Device || !choice.software || !client.surfaceless);
    if (take) {
        const EGLDisplay display = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, choice.device, nullptr);
        if (display == EGL_NO_DISPLAY) fail(Platform::Device, "eglGetPlatformDisplayEXT failed");
        return {display, Platform::Device, choice.description, choice.software};
    }
    if (requested == Platform::Device) {
        throw std::runtime_error(client.device ? "EGL (device platform): no EGL device found"
                                               : "EGL (device platform): EGL_EXT_platform_device is not supported "
                                                 "by this EGL; try --gpu surfaceless");
    }
    return {};
}

OpenDisplay open_surfaceless_display(const ClientPlatforms& client) {
    if (!client.surfaceless) {
        throw std::runtime_error("EGL: neither a usable EGL device nor EGL_MESA_platform_surfaceless is "
                                 "available; install Mesa's EGL (libegl-mesa0) or a GPU driver");
    }
    const EGLDisplay display = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display == EGL_NO_DISPLAY) fail(Platform::Surfaceless, "eglGetPlatformDisplayEXT failed");
    return {display, Platform::Surfaceless, {}, false};
}

// The requested platform's display; auto tries a device first, then surfaceless.
OpenDisplay open_display(Platform requested) {
    const ClientPlatforms client = query_client_platforms();
    if (requested == Platform::Device || requested == Platform::Auto) {
        OpenDisplay opened = open_device_display(requested, client);
        if (opened.display != EGL_NO_DISPLAY) return opened;
    }
    return open_surfaceless_display(client);
}

// A config for the context, or none where the display takes contexts without one
// (EGL_KHR_no_config_context); the display must allow contexts without a surface.
EGLConfig choose_config(EGLDisplay display, Platform used) {
    const char* display_ext = eglQueryString(display, EGL_EXTENSIONS);
    if (!has_extension(display_ext, "EGL_KHR_surfaceless_context")) {
        throw std::runtime_error(fmt::format("EGL ({} platform): EGL_KHR_surfaceless_context is missing",
                                             platform_name(used)));
    }
    EGLConfig config = EGL_NO_CONFIG_KHR;
    if (!has_extension(display_ext, "EGL_KHR_no_config_context")) {
        const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0, EGL_NONE};
        EGLint n = 0;
        if (!eglChooseConfig(display, config_attribs, &config, 1, &n) || n < 1) {
            fail(used, "eglChooseConfig found no OpenGL config");
        }
    }
    return config;
}

// An OpenGL core context of the required version (with the debug flag in debug builds).
EGLContext create_core_context(EGLDisplay display, EGLConfig config, Platform used) {
    const EGLint context_attribs[] = {
        EGL_CONTEXT_MAJOR_VERSION, required_major,
        EGL_CONTEXT_MINOR_VERSION, required_minor,
        EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
#ifndef NDEBUG
        EGL_CONTEXT_OPENGL_DEBUG, EGL_TRUE,
#endif
        EGL_NONE};
    EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
    if (context == EGL_NO_CONTEXT) {
        fail(used, fmt::format("eglCreateContext could not create an OpenGL {}.{} core context",
                               required_major, required_minor));
    }
    return context;
}

// The current context's GL strings and version numbers.
void read_gl_info(ContextInfo& info) {
    auto gl_string = [](GLenum name) {
        const auto* s = reinterpret_cast<const char*>(glGetString(name));
        return std::string(s ? s : "");
    };
    info.gl_vendor = gl_string(GL_VENDOR);
    info.gl_renderer = gl_string(GL_RENDERER);
    info.gl_version = gl_string(GL_VERSION);
    info.glsl_version = gl_string(GL_SHADING_LANGUAGE_VERSION);
    glGetIntegerv(GL_MAJOR_VERSION, &info.gl_major);
    glGetIntegerv(GL_MINOR_VERSION, &info.gl_minor);
}

bool meets_required_version(const ContextInfo& info) {
    return info.gl_major * 10 + info.gl_minor >= required_major * 10 + required_minor;
}

bool is_software_renderer(const std::string& renderer) {
    return renderer.find("llvmpipe") != std::string::npos || renderer.find("softpipe") != std::string::npos;
}

void destroy_context(EGLDisplay display, EGLContext context) {
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display, context);
}

}  // namespace

Platform parse_platform(std::string_view name) {
    if (name == "auto") return Platform::Auto;
    if (name == "device") return Platform::Device;
    if (name == "surfaceless") return Platform::Surfaceless;
    throw std::invalid_argument(fmt::format("--gpu {}: expected auto, device or surfaceless", name));
}

std::string_view platform_name(Platform platform) {
    switch (platform) {
        case Platform::Auto: return "auto";
        case Platform::Device: return "device";
        case Platform::Surfaceless: return "surfaceless";
    }
    return "?";
}

Context::Context(Platform requested) {
    require_address_space();  // below it llvmpipe aborts the process instead of failing
    require_cgroup_memory();   // below it the kernel kills the process
    const OpenDisplay opened = open_display(requested);
    const Platform used = opened.platform;
    info_.platform = used;
    info_.device = opened.device;
    info_.software = opened.software;

    // Initialise the display and bind desktop OpenGL.
    EGLint egl_major = 0;
    EGLint egl_minor = 0;
    if (!eglInitialize(opened.display, &egl_major, &egl_minor)) fail(used, "eglInitialize failed");
    display_ = opened.display;
    if (!eglBindAPI(EGL_OPENGL_API)) fail(used, "eglBindAPI(EGL_OPENGL_API) failed: no desktop OpenGL");
    if (const char* v = eglQueryString(display_, EGL_VENDOR)) info_.egl_vendor = v;
    if (const char* v = eglQueryString(display_, EGL_VERSION)) info_.egl_version = v;

    context_ = create_core_context(display_, choose_config(display_, used), used);
    make_current();

    // Check the version the driver gave; a software renderer counts as software whatever the device.
    read_gl_info(info_);
    if (!meets_required_version(info_)) {
        destroy_context(display_, context_);
        throw std::runtime_error(fmt::format("OpenGL {}.{} found ({}), {}.{} core needed", info_.gl_major,
                                             info_.gl_minor, info_.gl_renderer, required_major, required_minor));
    }
    if (is_software_renderer(info_.gl_renderer)) info_.software = true;
}

Context::~Context() {
    // The EGLDisplay of a platform is shared by every Context in the process, so it is not terminated here.
    if (context_) destroy_context(display_, context_);
}

void Context::make_current() const {
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_)) {
        fail(info_.platform, "eglMakeCurrent failed");
    }
}

void Context::release() const {
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT)) fail(info_.platform, "eglMakeCurrent (release) failed");
}

}  // namespace lensfx::gpu
