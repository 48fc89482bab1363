// Running the lensfx program of this build (LENSFX_BINARY, defined for every test target) from a test: the
// one helper every suite uses, so each runs it the same way (quoted, optionally with its own cache folder).
#pragma once

#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace lensfx::test {

// The program, quoted for the shell.
// (Built with += throughout: GCC 12 warns of a restrict overlap in some chains of std::string +.)
inline std::string lensfx_path() {
    std::string path = "\"";
    path += LENSFX_BINARY;
    path += '"';
    return path;
}

// The shell command line that runs lensfx with `args` (shell syntax: quotes and redirections allowed), with
// its caches in `cache_dir` ($LENSFX_CACHE_DIR) when one is given, never the user's.
inline std::string lensfx_command(const std::string& args, const std::string& cache_dir = {}) {
    std::string line;
    if (!cache_dir.empty()) {
        line += "LENSFX_CACHE_DIR=\"";
        line += cache_dir;
        line += "\" ";
    }
    line += lensfx_path();
    line += ' ';
    line += args;
    return line;
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
    std::string line = lensfx_command(args, cache_dir);
    line += " 2>&1";
    FILE* pipe = popen(line.c_str(), "r");
    if (!pipe) return r;
    std::array<char, 4096> buf{};
    while (std::fgets(buf.data(), static_cast<int>(buf.size()), pipe)) r.output += buf.data();
    r.status = pclose(pipe);
    return r;
}

}  // namespace lensfx::test
