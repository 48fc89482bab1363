// Milliseconds since a moment on the steady clock: the timings of run reports and command output.
#pragma once

#include <chrono>

namespace lensfx {

inline double ms_since(std::chrono::steady_clock::time_point since) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace lensfx
