// Entry point of the lensfx program: parses the command line and reports failures as one line on stderr
// (usage errors exit 2, failures of a run exit 1).
#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>
#include <vector>
#include <exception>
#include <iostream>
#include <new>

#include <CLI/CLI.hpp>
#include <fcntl.h>
#include <fmt/core.h>
#include <unistd.h>

#include <filter/output_files.h>
#include <filter/process_heap.h>
#include <gpu/address_space.h>

#include "commands.h"

namespace {

// Opens on /dev/null each of stdin, stdout and stderr the program was started without (`2>&-`): else the
// first file it opens (a cache file, the output) takes that number, and a message meant for stderr would
// land inside it. stdout is opened read-only, so that writing to it fails as writing a closed stdout did.
void keep_standard_streams_open() {
    for (const int fd : {STDIN_FILENO, STDOUT_FILENO, STDERR_FILENO}) {
        if (::fcntl(fd, F_GETFD) != -1 || errno != EBADF) continue;
        const int opened = ::open("/dev/null", fd == STDERR_FILENO ? O_WRONLY : O_RDONLY);
        if (opened >= 0 && opened != fd) {  // a lower number was free too: it is reopened in its turn
            ::dup2(opened, fd);
            ::close(opened);
        }
    }
}

extern "C" void ignore_broken_pipe(int) {}

// A reader that closes its end of an output pipe (`| head -c 1`) makes writes fail with EPIPE, reported in
// one line, instead of killing the program silently with SIGPIPE. A handler rather than SIG_IGN: programs
// lensfx starts (sbatch, its own chunks) get the default back when they are executed. A SIGPIPE the caller
// ignored stays ignored.
void report_broken_pipes() {
    struct sigaction old {};
    ::sigaction(SIGPIPE, nullptr, &old);
    if (old.sa_handler == SIG_IGN) return;
    struct sigaction sa {};
    sa.sa_handler = ignore_broken_pipe;
    sigemptyset(&sa.sa_mask);
    ::sigaction(SIGPIPE, &sa, nullptr);
}

// The failure line on stderr; a stderr that cannot take it (full, broken) does not abort the program.
void say(const std::string& line) noexcept {
    try {
        fmt::print(stderr, "lensfx: {}\n", line);
    } catch (...) {
    }
}

// `code`, once what was printed is written: a full or closed stdout is a failure (one line, exit 1), not a
// success, after --help and --version as after a command.
int flushed(int code) {
    std::cout.flush();
    if (!std::cout || std::fflush(stdout) != 0 || std::ferror(stdout)) {
        say(fmt::format("stdout: write failed: {}", lensfx::filter::write_failure(errno)));
        return 1;
    }
    return code;
}

}  // namespace

int main(int argc, char** argv) {
    using namespace lensfx::filter;
    keep_standard_streams_open();
    report_broken_pipes();
    handle_stopping_signals();  // one line on SIGINT/SIGTERM, whatever the command is doing
    const HeapTuning heap = tune_process_heap();  // before the first frame-sized allocation
    lensfx::gpu::set_default_llvmpipe_threads();  // before any thread and the GL driver
    const HeapWarmer warmer(heap);
    if (const int version = wants_version(argc, argv)) {
        fmt::print("{}", version_text(version == 2));
        return flushed(0);
    }
    if (const std::string empty = empty_value_option(argc, argv); !empty.empty()) {
        say(fmt::format("{}= has no value (write {}=VALUE or {} VALUE)", empty, empty, empty));
        return 2;
    }
    const std::unique_ptr<CLI::App> app = build_app();
    std::vector<std::string> args;
    try {
        refuse_special_config(argc, argv);
        args = normalise_spelling(*app, argc, argv);
        std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them last first
        app->parse(reversed);
    } catch (const CLI::CallForHelp& e) {
        return flushed(app->exit(e));
    } catch (const CLI::CallForAllHelp& e) {
        return flushed(app->exit(e));
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return flushed(app->exit(e));
        say(usage_error_message(*app, e, args));
        return 2;
    } catch (const std::bad_alloc&) {
        // An allocation no budget check foresaw: still one line, with what to do about it.
        say("out of memory (std::bad_alloc); give a lower --memory-limit so that lensfx refuses earlier");
        return 1;
    } catch (const std::system_error& e) {
        // A thread or process a library started (OpenEXR's and OpenImageIO's pools, the GL driver's) that the system
        // would not: its text alone ("Resource temporarily unavailable") does not say what to change.
        const bool limit = e.code() == std::errc::resource_unavailable_try_again;
        say(limit ? fmt::format("{}: the system would not start another thread (a limit on threads, processes or memory: ulimit -u, "
                                "ulimit -v); lower --threads or --queue-depth", e.what())
                  : std::string(e.what()));
        return 1;
    } catch (const std::exception& e) {
        say(e.what());
        return 1;
    }
    return flushed(0);  // what a command printed is only written now
}
