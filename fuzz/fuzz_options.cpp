// Fuzz target: the lensfx command line. The bytes, split at newlines into arguments, go through the real
// CLI11 app (build_app, as main() builds it): every option is parsed, converted and checked, and then,
// where the commands' callbacks would run, a hook on the app throws, so that no command does any work.
// (The callbacks stay installed: they own the options' storage.)
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "commands.h"
#include "fuzz_input.h"

namespace {

// Thrown by the app's parse-complete hook, which CLI11 runs after every option's conversion and check
// and before the callbacks of the commands (the app's own, then the subcommands').
struct Parsed {};

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
    app->parse_complete_callback([] { throw Parsed{}; });
    try {
        app->parse(static_cast<int>(argv.size()), argv.data());
    } catch (const Parsed&) {
    } catch (const CLI::Error&) {
    } catch (const std::runtime_error&) {
    } catch (const std::invalid_argument&) {
    }
    return 0;
}
