// Entry point of the lensfx program: parses the command line and reports failures as one line on stderr
// (usage errors exit 2, failures of a run exit 1).
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>
#include <exception>
#include <new>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <filter/process_heap.h>

#include "commands.h"

int main(int argc, char** argv) {
    using namespace lensfx::filter;
    tune_process_heap();  // before the first frame-sized allocation
    if (const int version = wants_version(argc, argv)) {
        fmt::print("{}", version_text(version == 2));
        return 0;
    }
    if (const std::string empty = empty_value_option(argc, argv); !empty.empty()) {
        fmt::print(stderr, "lensfx: {}= has no value (write {}=VALUE or {} VALUE)\n", empty, empty, empty);
        return 2;
    }
    const std::unique_ptr<CLI::App> app = build_app();
    try {
        refuse_special_config(argc, argv);
        std::vector<std::string> args = normalise_spelling(*app, argc, argv);
        std::reverse(args.begin(), args.end());  // CLI11 takes them last first
        app->parse(args);
    } catch (const CLI::CallForHelp& e) {
        return app->exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app->exit(e);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app->exit(e);
        fmt::print(stderr, "lensfx: {}\n", usage_error_message(*app, e));
        return 2;
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
