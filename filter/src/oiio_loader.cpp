// Finding and loading liblensfx_oiio (see oiio_module.h).
#include "oiio_module.h"

#include <dlfcn.h>

#include <atomic>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/core.h>

namespace lensfx::filter {

namespace {

namespace fs = std::filesystem;

constexpr char kModuleName[] = "liblensfx_oiio.so";

// The module is loaded once per process and stays loaded; like OpenImageIO's and OpenEXR's own settings,
// its thread count belongs to the whole process.
struct Loader {
    std::mutex mutex;
    const OiioModule* module = nullptr;
    int threads = 0;  // asked for before loading; 0: OpenImageIO's default
};

Loader& loader() {
    static Loader l;
    return l;
}

const OiioModule& load(int threads) {
    std::vector<fs::path> candidates;
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) {
        candidates.push_back(exe.parent_path() / kModuleName);
        candidates.push_back((exe.parent_path() / ".." / "lib" / "lensfx" / kModuleName).lexically_normal());
    }
    candidates.emplace_back(LENSFX_OIIO_MODULE_BUILD_PATH);
    std::string tried;
    for (const fs::path& path : candidates) {
        if (!fs::exists(path, ec)) {
            tried += fmt::format("\n  {}: not there", path.string());
            continue;
        }
        void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (!handle) {
            tried += fmt::format("\n  {}: {}", path.string(), dlerror());
            continue;
        }
        using Entry = const OiioModule* (*)();
        if (auto entry = reinterpret_cast<Entry>(dlsym(handle, "lensfx_oiio_module"))) {
            const OiioModule& module = *entry();
            if (threads > 0) module.set_threads(threads);
            return module;
        }
        tried += fmt::format("\n  {}: no lensfx_oiio_module symbol", path.string());
    }
    throw std::runtime_error(fmt::format("cannot load {}, which reads and writes formats other than EXR and PFM:{}",
                                         kModuleName, tried));
}

}  // namespace

const OiioModule& oiio_module() {
    Loader& l = loader();
    const std::lock_guard lock(l.mutex);
    if (!l.module) l.module = &load(l.threads);
    return *l.module;
}

void set_oiio_threads(int threads) {
    Loader& l = loader();
    const std::lock_guard lock(l.mutex);
    l.threads = threads;
    if (l.module) l.module->set_threads(threads);
}

}  // namespace lensfx::filter
