// Entry point of the lensfx program: parses the command line and reports failures as one line on stderr.
#include <cstdio>
#include <exception>
#include <new>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "commands.h"

int main(int argc, char** argv) {
    CLI::App app{"lensfx: physically based lens flare for HDR frames and streams"};
    app.set_version_flag("--version", LENSFX_VERSION);
    app.require_subcommand(0, 1);

    lensfx::filter::register_filter(app);
    lensfx::filter::register_lens_commands(app);
    lensfx::filter::register_gpu_command(app);
    lensfx::filter::register_flare_command(app);
    lensfx::filter::register_track_command(app);
    lensfx::filter::register_bench_command(app);

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    } catch (const std::bad_alloc&) {
        // An allocation no budget check foresaw: still one line, with what to do about it.
        fmt::print(stderr, "lensfx: out of memory (std::bad_alloc); give a lower --memory-limit so that lensfx refuses earlier\n");
        return 1;
    } catch (const std::exception& e) {
        fmt::print(stderr, "lensfx: {}\n", e.what());
        return 1;
    }
    return 0;
}
