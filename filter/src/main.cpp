// Entry point of the lensfx program: parses the command line and reports failures as one line on stderr.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <new>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "commands.h"

int main(int argc, char** argv) {
    const std::unique_ptr<CLI::App> app = lensfx::filter::build_app();
    app->set_version_flag("--version", LENSFX_VERSION);

    try {
        app->parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app->exit(e);
    } catch (const std::bad_alloc&) {
        // An allocation no budget check foresaw: still one line, with what to do about it.
        fmt::print(stderr, "lensfx: out of memory (std::bad_alloc); give a lower --memory-limit so that lensfx refuses earlier\n");
        return 1;
    } catch (const std::exception& e) {
        fmt::print(stderr, "lensfx: {}\n", e.what());
        return 1;
    }
    // What a command printed is only written now: a full or closed stdout is a failure, not a success.
    if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
        fmt::print(stderr, "lensfx: stdout: write failed: {}\n", std::strerror(errno));
        return 1;
    }
    return 0;
}
