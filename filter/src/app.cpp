// The lensfx command line as one CLI11 app (build_app), and how its usage errors are reported (one
// `lensfx:` line, exit 2, with "did you mean" for unknown options and readable numbers).
#include "commands.h"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cctype>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/core.h>
#include <Imath/ImathConfig.h>
#include <OpenColorIO/OpenColorIO.h>
#include <OpenEXR/OpenEXRConfig.h>
#include <OpenImageIO/oiioversion.h>
#include <opencv2/core/version.hpp>

#include <gpu/context.h>

#include <filter/option_checks.h>
#include <filter/output_files.h>

#include "version_info.h"

namespace lensfx::filter {

namespace {

// The levenshtein distance between two option names.
std::size_t edit_distance(std::string_view a, std::string_view b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = up;
        }
    }
    return row[b.size()];
}

// Every long and short name ("--lens", "-o") of the app's options and its subcommands' names.
std::vector<std::string> option_names(const CLI::App& app) {
    std::vector<std::string> names;
    for (const CLI::Option* o : app.get_options()) {
        for (const auto& n : o->get_lnames()) names.push_back("--" + n);
        for (const auto& n : o->get_snames()) names.push_back("-" + n);
    }
    for (const CLI::App* sub : app.get_subcommands({})) names.push_back(sub->get_name());
    return names;
}

// The known name nearest to `unknown` when it is close enough to be a typo (or a prefix of one name).
std::string nearest(const std::string& unknown, const std::vector<std::string>& names) {
    std::string best;
    std::size_t best_distance = std::max<std::size_t>(2, unknown.size() / 4) + 1;
    for (const auto& n : names) {
        const std::size_t d = edit_distance(unknown, n);
        if (d < best_distance) best_distance = d, best = n;
    }
    if (best.empty() && unknown.size() >= 4) {
        std::vector<std::string> prefixed;
        for (const auto& n : names)
            if (n.rfind(unknown, 0) == 0) prefixed.push_back(n);
        if (prefixed.size() == 1) best = prefixed[0];
    }
    return best;
}

// Whether `app` takes an argument named `name` by position (lens info's LENS).
bool positional(const CLI::App& app, const std::string& name) {
    for (const CLI::Option* o : app.get_options())
        if (o->get_positional() && o->get_name(true, false) == name) return true;
    return false;
}

// "lensfx lens info": the command names from the app down to `app`.
std::string command_path(const CLI::App& app) {
    return app.get_parent() != nullptr ? command_path(*app.get_parent()) + " " + app.get_name() : app.get_name();
}

// The subcommand being parsed (the app when none was given).
const CLI::App& active(const CLI::App& app) {
    for (const CLI::App* sub : app.get_subcommands())
        if (sub->parsed()) return active(*sub);
    return app;
}

// The number starting at `at` (an optional '-', digits, an optional fraction) and its length; 0 when none.
std::size_t number_length(const std::string& text, std::size_t at, std::size_t& int_digits, std::size_t& frac_digits) {
    std::size_t i = at + (text[at] == '-' ? 1 : 0);
    const std::size_t int_start = i;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i;
    int_digits = i - int_start;
    frac_digits = 0;
    if (int_digits == 0) return 0;
    if (i + 1 < text.size() && text[i] == '.' && std::isdigit(static_cast<unsigned char>(text[i + 1]))) {
        const std::size_t frac_start = ++i;
        while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i;
        frac_digits = i - frac_start;
    }
    return i - at;
}

// `text` with "not in range LO to HI" worded as a bound when the other end is the largest double.
std::string bound_wording(std::string text) {
    const std::string range = "not in range ", top = " to 1.79769e+308", bottom = "-1.79769e+308 to ";
    for (std::size_t at = text.find(range); at != std::string::npos; at = text.find(range, at + 1)) {
        const std::size_t value = at + range.size();
        if (text.compare(value, bottom.size(), bottom) == 0) {
            text.replace(at, range.size() + bottom.size(), "must be at most ");
        } else if (const std::size_t end = text.find(top, value); end != std::string::npos && text.find(' ', value) == end) {
            // The value itself refused at the bound: the bound is strict (CLI::PositiveNumber's "0 to ...").
            const std::string bound = text.substr(value, end - value);
            const std::size_t said = text.rfind("Value ", at);
            const bool at_bound = said != std::string::npos && text.compare(said + 6, at - 1 - (said + 6), bound) == 0;
            text = text.substr(0, at) + (at_bound ? "must be above " : "must be at least ") + bound + text.substr(end + top.size());
        }
    }
    return text;
}

// Numbers CLI11 prints at full length (a range up to the largest double has 309 digits) as %g.
std::string readable_numbers(const std::string& text) {
    std::string out;
    for (std::size_t i = 0; i < text.size();) {
        const bool starts = (std::isdigit(static_cast<unsigned char>(text[i])) || text[i] == '-') &&
                            (i == 0 || !(std::isalnum(static_cast<unsigned char>(text[i - 1])) || text[i - 1] == '.'));
        std::size_t int_digits = 0, frac_digits = 0;
        const std::size_t n = starts ? number_length(text, i, int_digits, frac_digits) : 0;
        if (n == 0) {
            out += text[i++];
            continue;
        }
        const std::string number = text.substr(i, n);
        out += int_digits >= 10 || frac_digits >= 6 ? fmt::format("{:g}", std::stod(number)) : number;
        i += n;
    }
    return bound_wording(out);
}

// Every long option name of the app and its subcommands, at any depth.
void long_names(const CLI::App& app, std::set<std::string>& names) {
    for (const CLI::Option* o : app.get_options())
        for (const auto& n : o->get_lnames()) names.insert("--" + n);
    for (const CLI::App* sub : app.get_subcommands({})) long_names(*sub, names);
}

// `text` with "colour" spelled "color" and the other way round.
std::string other_spelling(const std::string& text) {
    std::string out = text;
    if (const auto at = out.find("colour"); at != std::string::npos) return out.replace(at, 6, "color");
    if (const auto at = out.find("color"); at != std::string::npos) return out.replace(at, 5, "colour");
    return out;
}

// The --config file the parse read, as given; "" when none was.
std::string config_file(const CLI::App& app) {
    const CLI::Option* config = app.get_config_ptr();
    return config != nullptr && !config->results().empty() ? config->results().back() : std::string();
}

// `text` without the spaces, tabs and one pair of double quotes round it.
std::string_view unquoted(std::string_view text) {
    while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
    while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\r')) text.remove_suffix(1);
    if (text.size() >= 2 && text.front() == '"' && text.back() == '"') text = text.substr(1, text.size() - 2);
    return text;
}

// The first line (from 1) of the TOML file that sets `key` ("key = ...", quoted or not, or "section.key = ..."),
// 0 when none does or the file cannot be read.
int config_line(const std::string& file, std::string_view key) {
    std::ifstream in(file);
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        const std::size_t equals = line.find('=');
        if (equals == std::string::npos) continue;
        std::string_view name = unquoted(std::string_view(line).substr(0, equals));
        if (const std::size_t dot = name.rfind('.'); dot != std::string_view::npos) name = unquoted(name.substr(dot + 1));
        if (name == key) return number;
    }
    return 0;
}

// "--config FILE, line N" (or without the line where no line sets `key`).
std::string config_place(const std::string& file, std::string_view key) {
    const int line = config_line(file, key);
    return line > 0 ? fmt::format("--config {}, line {}", file, line) : fmt::format("--config {}", file);
}

// A usage error that a --config file caused, said with the file and its line: a key no option has (CLI11: "INI was
// not able to parse KEY"), or a bad value of an option the command line did not give. "" when it is neither.
std::string config_error(const CLI::App& app, const std::string& message, const std::vector<std::string>& args) {
    const std::string file = config_file(app);
    if (file.empty()) return {};
    if (const std::string unknown = "INI was not able to parse "; message.rfind(unknown, 0) == 0) {
        std::string key = message.substr(unknown.size());
        if (const std::size_t dot = key.rfind('.'); dot != std::string::npos) key = key.substr(dot + 1);
        const std::string hint = nearest("--" + key, option_names(active(app)));
        return fmt::format("{}: unknown key {}{}", config_place(file, key), key,
                           hint.rfind("--", 0) == 0 ? fmt::format(" (did you mean {}?)", hint.substr(2)) : std::string());
    }
    if (const std::string not_allowed = ": This option is not allowed in a configuration file"; message.ends_with(not_allowed)) {
        const std::string key = message.substr(0, message.size() - not_allowed.size());
        return fmt::format("{}: {} cannot be set in a shot file", config_place(file, key), key);
    }
    if (message.rfind("--", 0) != 0) return {};
    const std::string option = message.substr(0, message.find_first_of(": "));
    const bool given = std::any_of(args.begin(), args.end(), [&](const std::string& a) { return a == option || a.rfind(option + "=", 0) == 0; });
    if (given || config_line(file, option.substr(2)) == 0) return {};
    return fmt::format("{}: {}", config_place(file, option.substr(2)), message);
}

// CLI11's wording of a missing --config file and of an option given twice, said as what to do; "" for others.
std::string reworded(const std::string& message) {
    if (const std::string unreadable = " was not readable (missing?)"; message.ends_with(unreadable))
        return fmt::format("--config {}: no such file", message.substr(0, message.size() - unreadable.size()));
    if (const std::string twice = ": At Most 1 required but received "; message.find(twice) != std::string::npos && message.rfind("--", 0) == 0)
        return fmt::format("{} is given more than once (give it once)", message.substr(0, message.find(twice)));
    return {};
}

}  // namespace

std::vector<std::string> normalise_spelling(const CLI::App& app, int argc, const char* const* argv) {
    std::set<std::string> names;
    long_names(app, names);
    std::vector<std::string> args;
    bool options_end = false;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        options_end = options_end || a == "--";
        if (!options_end && a.rfind("--", 0) == 0) {
            const auto eq = a.find('=');
            const std::string name = a.substr(0, eq);
            if (!names.count(name) && names.count(other_spelling(name))) a = other_spelling(name) + (eq == std::string::npos ? "" : a.substr(eq));
        }
        args.push_back(std::move(a));
    }
    return args;
}

std::string usage_error_message(const CLI::App& app, const CLI::ParseError& e, const std::vector<std::string>& args) {
    std::string message = readable_numbers(e.what());
    if (!message.empty() && message.back() == '\n') message.pop_back();
    if (std::string in_config = config_error(app, message, args); !in_config.empty()) return in_config;
    if (std::string plain = reworded(message); !plain.empty()) return plain;
    // An unknown option is the likelier cause of any error (a misspelt --angle is also a missing one).
    {
        const CLI::App& where = active(app);
        std::vector<std::string> hints;
        for (const std::string& extra : where.remaining()) {
            if (extra.empty() || extra[0] != '-') continue;
            const std::string name = extra.substr(0, extra.find('='));
            const std::string hint = nearest(name, option_names(where));
            if (const std::string bare = name.substr(std::min(name.size(), name.find_first_not_of('-'))); hint.empty() && positional(where, bare)) {
                std::string upper = bare;
                std::transform(upper.begin(), upper.end(), upper.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
                hints.push_back(fmt::format("unknown option {} (the {} goes without {}: {} {})", name, bare, name, command_path(where), upper));
            } else
                hints.push_back(hint.empty() ? fmt::format("unknown option {}", name) : fmt::format("unknown option {} (did you mean {}?)", name, hint));
        }
        if (!hints.empty()) {
            message.clear();
            for (const auto& h : hints) message += (message.empty() ? "" : "; ") + h;
        }
    }
    if (!message.empty() && message.back() == '\n') message.pop_back();
    return message;
}

std::string empty_value_option(int argc, const char* const* argv) {
    for (int i = 1; i < argc; ++i) {
        const std::string_view a = argv[i];
        if (a == "--") break;
        if (a.size() > 3 && a.rfind("--", 0) == 0 && a.back() == '=' && a.find('=') == a.size() - 1) return std::string(a.substr(0, a.size() - 1));
    }
    return {};
}

namespace {

// A shot file is a page of options: keys are option names, at most in a [subcommand] section ([lens.fit]).
constexpr std::uintmax_t kMaxConfigBytes = std::uintmax_t{1} << 20;
constexpr int kMaxConfigLevels = 8;

// How many levels deep a line's key ("a.b = ...": the dots before the '=') or [section] name goes, plus one; 0 for a
// line that is neither (a comment, or a value continued from the line before: an array of "10.5,20.5,100" strings).
int key_levels(std::string_view line) {
    const std::size_t start = line.find_first_not_of(" \t");
    if (start == std::string_view::npos || line[start] == '#') return 0;
    std::string_view key;
    if (const std::size_t equals = line.find('=', start); equals != std::string_view::npos)
        key = line.substr(start, equals - start);
    else if (const std::size_t close = line.find(']', start); line[start] == '[' && close != std::string_view::npos)
        key = line.substr(start, close - start);  // a [section] or [[array]] header (an array of arrays holds commas)
    if (key.find(',') != std::string_view::npos) return 0;
    return key.empty() ? 0 : 1 + static_cast<int>(std::count(key.begin(), key.end(), '.'));
}

// Refuses, as a usage error naming the file and line, what CLI11's reader would take all the memory or time
// for, or echo to the terminal: a file over kMaxConfigBytes, bytes that are not text, keys nested deeper than
// kMaxConfigLevels (its memory grows with the square of the depth: 100,000 levels filled 24 GB).
void check_config_text(const std::string& path) {
    std::error_code ec;
    if (const std::uintmax_t size = std::filesystem::file_size(path, ec); !ec && size > kMaxConfigBytes)
        throw CLI::ValidationError(fmt::format("--config {}", path), fmt::format("{} bytes, more than a shot file's 1 MiB", size));
    std::ifstream in(path, std::ios::binary);
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        const auto binary = std::find_if(line.begin(), line.end(), [](char c) {
            const auto u = static_cast<unsigned char>(c);
            return u < 0x20 && c != '\t' && c != '\r';
        });
        if (binary != line.end())
            throw CLI::ValidationError(fmt::format("--config {}, line {}", path, number),
                                       fmt::format("not a text file (byte 0x{:02x})", static_cast<unsigned char>(*binary)));
        if (const int levels = key_levels(line); levels > kMaxConfigLevels)
            throw CLI::ValidationError(fmt::format("--config {}, line {}", path, number),
                                       fmt::format("a key {} levels deep (at most {}: an option, in a [subcommand] section)", levels, kMaxConfigLevels));
    }
}

void check_config_file(const std::string& path) {
    require_regular_file(path, "--config");
    check_config_text(path);
}

}  // namespace

void refuse_special_config(int argc, const char* const* argv) {
    for (int i = 1; i < argc; ++i) {
        const std::string_view a = argv[i];
        if (a == "--") break;
        if (a == "--config" && i + 1 < argc) check_config_file(argv[i + 1]);
        if (a.rfind("--config=", 0) == 0) check_config_file(std::string(a.substr(9)));
    }
}

int wants_version(int argc, const char* const* argv) {
    bool version = false, verbose = false;
    for (int i = 1; i < argc; ++i) {
        const std::string_view a = argv[i];
        if (a == "--") break;
        version = version || a == "--version";
        verbose = verbose || a == "--verbose";
    }
    return version ? (verbose ? 2 : 1) : 0;
}

std::string version_text(bool with_gpu) {
    std::string text = fmt::format(
        "lensfx {} (commit {}, {} build)\nOpenEXR {}, Imath {}, OpenImageIO {}, OpenColorIO {}, OpenCV {}\n", LENSFX_VERSION_STRING,
        LENSFX_GIT_COMMIT, LENSFX_BUILD_TYPE, OPENEXR_VERSION_STRING, IMATH_VERSION_STRING, OIIO_VERSION_STRING, OCIO_NAMESPACE::GetVersion(), CV_VERSION);
    if (with_gpu) {
        try {
            const gpu::Context context(gpu::Platform::Auto);
            const gpu::ContextInfo& info = context.info();
            text += fmt::format("GL renderer {}{}, OpenGL {} ({} EGL)\n", info.gl_renderer, info.software ? " (software)" : "", info.gl_version,
                                gpu::platform_name(info.platform));
        } catch (const std::exception& e) {
            text += fmt::format("GL renderer: none ({})\n", e.what());
        }
    }
    return text;
}

std::unique_ptr<CLI::App> build_app() {
    auto app = std::make_unique<CLI::App>("lensfx: physically based lens flare for HDR frames and streams", "lensfx");
    app->require_subcommand(0, 1);
    app->set_config("--config", "", "Read options from a TOML shot file (every long option a key; [flare], [track]... for subcommands)");
    app->allow_config_extras(CLI::config_extras_mode::error);  // a misspelt key in a shot file is an error, not ignored
    // Both are handled by main() before parsing (see wants_version), so that nothing else runs.
    app->add_flag("--version")
        ->description("Print the version, the commit, the build type and the libraries (with --verbose: the GL renderer), and exit")
        ->configurable(false);
    app->add_flag("--verbose")->description("With --version: also open a GL context and print its renderer")->configurable(false);
    register_filter(*app);
    register_lens_commands(*app);
    register_gpu_command(*app);
    register_flare_command(*app);
    register_track_command(*app);
    register_bench_command(*app);
    register_farm_command(*app);
    register_predict_command(*app);
    check_every_number(*app);
    return app;
}

}  // namespace lensfx::filter
