// Running the lensfx program of this build (LENSFX_BINARY, defined for every test target) from a test: the
// one helper every suite uses, so each runs it the same way (quoted, optionally with its own cache folder).
#pragma once

#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace lensfx::test {

// The program, quoted for the shell.
inline std::string lensfx_path() { return std::string("\"") + LENSFX_BINARY + "\""; }

// The shell command line that runs lensfx with `args` (shell syntax: quotes and redirections allowed), with
// its caches in `cache_dir` ($LENSFX_CACHE_DIR) when one is given, never the user's.
inline std::string lensfx_command(const std::string& args, const std::string& cache_dir = {}) {
    const std::string env = cache_dir.empty() ? std::string() : "LENSFX_CACHE_DIR=\"" + cache_dir + "\" ";
    return env + lensfx_path() + " " + args;
}

// Runs it; std::system's wait status (0 when the program exited 0).
inline int run_lensfx_status(const std::string& args, const std::string& cache_dir = {}) {
    return std::system(lensfx_command(args, cache_dir).c_str());
}

// A run's wait status and its standard output and error together.
struct ProgramRun {
    int status = -1;
    std::string output;
};

inline ProgramRun run_lensfx(const std::string& args, const std::string& cache_dir = {}) {
    ProgramRun r;
    FILE* pipe = popen((lensfx_command(args, cache_dir) + " 2>&1").c_str(), "r");
    if (!pipe) return r;
    std::array<char, 4096> buf{};
    while (std::fgets(buf.data(), static_cast<int>(buf.size()), pipe)) r.output += buf.data();
    r.status = pclose(pipe);
    return r;
}

}  // namespace lensfx::test
