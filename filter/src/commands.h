// The lensfx program's commands. Each register_* adds its options or subcommand to the CLI11 app and
// installs a callback that does the work; failures are thrown as std::exception with a one-line message
// naming the file, frame or surface at fault, and main() turns them into "lensfx: <message>", exit 1.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include <flare/flare.h>
#include <measured/model.h>
#include <optics/memory_budget.h>

namespace lensfx::filter {

// The whole command line: every command and option, their callbacks installed, nothing run or parsed.
std::unique_ptr<CLI::App> build_app();
// A usage error (unknown option, bad value) as the one line after "lensfx: ": "did you mean" for an
// unknown option near a known one, numbers printed short, and the --config file and line where a shot file's
// key caused it. args: the command line after argv[0] (an option given there is not the file's).
std::string usage_error_message(const CLI::App& app, const CLI::ParseError& e, const std::vector<std::string>& args);
// The first "--name=" with nothing after the '=' (CLI11 would take the next argument as its value), or "".
std::string empty_value_option(int argc, const char* const* argv);
// The arguments after argv[0] with each unknown long option spelled "colour" or "color" replaced by the
// other spelling when that one is known (both spellings work for every option, present and future).
std::vector<std::string> normalise_spelling(const CLI::App& app, int argc, const char* const* argv);
// Refuses a --config that names a FIFO, a device or a directory (CLI11 would read /dev/zero for ever), and one
// whose text CLI11's reader would take unbounded memory or time for (over 1 MiB, not text, keys nested deeply).
void refuse_special_config(int argc, const char* const* argv);
// 0: no --version; 1: --version; 2: --version --verbose (before any "--").
int wants_version(int argc, const char* const* argv);
// What --version prints: lensfx's version, commit and build type, the libraries' versions and, when
// `with_gpu`, the GL renderer (opening a GL context, which takes a while).
std::string version_text(bool with_gpu);

// `lensfx -i IN -o OUT [options]`: the frame filter (the app's own options; runs when no subcommand is given).
void register_filter(CLI::App& app);
// `lensfx lens info|trace|list|convert`.
void register_lens_commands(CLI::App& app);
// `lensfx gpu`: the EGL/GL vendor, renderer and version.
void register_gpu_command(CLI::App& app);
// `lensfx flare --lens LENS --angle AX,AY ... -o OUT.exr`.
void register_flare_command(CLI::App& app);
// `lensfx track -i IN --tracks-out tracks.json`: detected and tracked lights of a shot as a track file.
void register_track_command(CLI::App& app);
// `lensfx bench time-vs-error --csv FILE`: the ghost renderer's time per flare next to its error.
void register_bench_command(CLI::App& app);
// `lensfx farm -i IN -o OUT --chunk N --engine slurm|local`: a shot as a job array (cmd_farm.cpp).
void register_farm_command(CLI::App& app);

// `lensfx lens fit SWEEP --angles A:B:S -o MODEL.toml` under the `lens` command (cmd_measured.cpp).
void register_lens_fit_command(CLI::App& lens);
// `lensfx predict --lens LENS --angles A:B:S [--json] [--map OUT.png]`.
void register_predict_command(CLI::App& app);
// "START:END:STEP" in degrees (0..89) as the list of angles; a CLI::ValidationError naming `option` otherwise.
std::vector<double> parse_angles(const std::string& text, const char* option);
// A measured preset's ghosts for one light of the view, scaled by paper equation 2 from its capture to
// `target` (f-number, ISO, exposure): on the GPU, or by the CPU reference.
flare::FlareImage render_measured_flare(const std::string& path, const flare::FlareView& view, const measured::Capture& target, bool reference,
                                      const std::string& gpu_platform);
measured::MeasuredView measured_view(const flare::FlareView& view);

// --memory-limit's check: a value parse_memory_limit refuses is a usage error (exit 2).
inline CLI::Validator memory_limit_check() {
    return CLI::Validator(
        [](std::string& text) -> std::string {
            try {
                parse_memory_limit(text);
            } catch (const std::exception&) {
                return "must be a size such as 4G, 512M or none, not \"" + text + "\"";
            }
            return {};
        },
        "SIZE");
}

// --memory-limit's value: parse_memory_limit(text), or default_memory_budget() when it was not given.
inline MemoryBudget memory_budget_option(const std::string& text) {
    return text.empty() ? default_memory_budget() : parse_memory_limit(text);
}

}  // namespace lensfx::filter
