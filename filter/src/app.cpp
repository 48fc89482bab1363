// The lensfx command line as one CLI11 app (build_app): what main() parses and what the option-parser
// fuzz target (fuzz/fuzz_options.cpp) parses with the commands' callbacks removed.
#include "commands.h"

namespace lensfx::filter {

std::unique_ptr<CLI::App> build_app() {
    auto app = std::make_unique<CLI::App>("lensfx: physically based lens flare for HDR frames and streams", "lensfx");
    app->require_subcommand(0, 1);
    register_filter(*app);
    register_lens_commands(*app);
    register_gpu_command(*app);
    register_flare_command(*app);
    register_track_command(*app);
    register_bench_command(*app);
    register_farm_command(*app);
    return app;
}

}  // namespace lensfx::filter
