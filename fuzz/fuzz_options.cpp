// Fuzz target: the lensfx command line. The bytes, split at newlines into arguments, go through the real
// CLI11 app (build_app, as main() builds it) with every command's callback removed, so that only the
// parsing, conversions and checks of the options run and no command does any work.
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "fuzz_input.h"

namespace {

// Removes the work each command does on a successful parse, in the app and every subcommand below it.
void disarm(CLI::App& app) {
    app.callback(nullptr);
    app.parse_complete_callback(nullptr);
    app.preparse_callback(nullptr);
    for (CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) disarm(*sub);
}

std::vector<std::string> arguments(std::string_view text) {
    std::vector<std::string> args{"lensfx"};
    while (!text.empty() && args.size() < 64) {
        const auto eol = text.find('\n');
        args.emplace_back(text.substr(0, eol));
        if (eol == std::string_view::npos) break;
        text.remove_prefix(eol + 1);
    }
    return args;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::vector<std::string> args = arguments(lensfx::fuzz::as_text(data, size));
    std::vector<const char*> argv;
    for (const std::string& a : args) argv.push_back(a.c_str());
    const std::unique_ptr<CLI::App> app = lensfx::filter::build_app();
    disarm(*app);
    try {
        app->parse(static_cast<int>(argv.size()), argv.data());
    } catch (const CLI::Error&) {
    } catch (const std::runtime_error&) {
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
