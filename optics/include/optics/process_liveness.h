// Whether the process that left a file behind still runs: the temporaries of outputs (filter/) and of cache
// files (flare/) carry their writer's PID, and a later run removes those whose writer is gone.
#pragma once

#include <cerrno>

#include <signal.h>
#include <sys/types.h>

namespace lensfx {

// True only when no process `pid` exists (kill with signal 0 fails with ESRCH); a live process, or one this
// process may not signal (EPERM: another user's), is not gone.
inline bool process_is_gone(long pid) { return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH; }

}  // namespace lensfx
