// `lensfx farm -i IN -o OUT --chunk N --engine slurm|local [--wait] [--retries K] [--resume] [filter options]`:
// a shot rendered as a job array. The lights are tracked once over the whole shot (`lensfx track`), so every
// chunk renders from the same track file and the frames are bit-identical to one process's. The plan is a
// plain bash job script (sbatch's #SBATCH lines; usable by hand), submitted as one Slurm array or run here
// as processes; failed chunks are resubmitted. A frame is complete when its final file exists (the filter
// writes a temporary and renames it), so finished frames are never rewritten and a rerun renders the rest.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <fmt/core.h>

#include <filter/sequence.h>
#include <measured/model_file.h>
#include <optics/lens_file.h>

#include "commands.h"

namespace lensfx::filter {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct FarmSettings {
    std::string input;
    std::string output;
    std::string frames;
    std::string tracks;  // a track file to render from instead of tracking the shot here
    int chunk = 10;
    std::string engine = "auto";
    bool wait = false;
    int retries = 1;
    bool resume = false;
    int local_jobs = 1;
    std::vector<std::string> sbatch_options;  // extra #SBATCH lines (--partition=x, --time=1:00:00)
    std::vector<std::string> filter_options;  // everything else: the filter's options, passed to every task
    // -q (--quiet) among them: the farm too says nothing but its errors (and, not waiting, the job it submitted).
    bool quiet() const {
        return std::any_of(filter_options.begin(), filter_options.end(), [](const std::string& o) { return o == "-q" || o == "--quiet"; });
    }
};

// One task of the array: its 1-based index (SLURM_ARRAY_TASK_ID) and frames.
struct Chunk {
    int id = 0;
    std::vector<std::int64_t> frames;
    std::vector<std::int64_t> missing;  // frames not complete when the farm started
};

// Everything a task needs, fixed before anything is submitted.
struct FarmPlan {
    std::string shot;
    fs::path dir;  // OUT's folder/lensfx-farm/<shot>: job script, tracks, logs
    fs::path script, tracks, logs;
    FramePattern in, out;
    std::vector<std::int64_t> frames;
    std::vector<Chunk> chunks;
    std::size_t complete = 0;  // frames complete before this run
};

// How one try of one chunk ended.
struct TaskResult {
    int chunk = 0;
    bool ok = false;
    std::string state;  // COMPLETED, FAILED, CANCELLED, TIMEOUT, NODE_FAIL... (Slurm's words, also for local)
    std::string node;
    double seconds = 0;
    std::string log;
};

struct CommandOutput {
    int status = -1;  // the exit code; -1 when it could not run or was killed
    std::string text;  // stdout and stderr together
};

// --- processes ---------------------------------------------------------------------------------------

std::string shell_quote(const std::string& s) {
    if (!s.empty() && s.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-+=/.,:@%") == std::string::npos)
        return s;
    std::string q = "'";
    for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
}

std::string shell_words(const std::vector<std::string>& words) {
    std::string line;
    for (const auto& w : words) line += (line.empty() ? "" : " ") + shell_quote(w);
    return line;
}

// Runs a command line through /bin/sh and returns its exit code and everything it printed.
CommandOutput run_command(const std::vector<std::string>& argv) {
    CommandOutput out;
    std::FILE* pipe = ::popen((shell_words(argv) + " 2>&1").c_str(), "r");
    if (!pipe) return out;
    char buf[4096];
    for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, pipe)) > 0;) out.text.append(buf, n);
    const int status = ::pclose(pipe);
    out.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return out;
}

// The last non-empty line of a command's output: what a failing tool says about why.
std::string last_line(const std::string& text) {
    std::istringstream in(text);
    std::string line, last;
    while (std::getline(in, line))
        if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
    return last.empty() ? "no output" : last;
}

fs::path self_executable() { return fs::read_symlink("/proc/self/exe"); }

std::string host_name() {
    char name[256] = {};
    ::gethostname(name, sizeof name - 1);
    return name;
}

// --- the plan ----------------------------------------------------------------------------------------

// "1-6" for a run of consecutive frames, else "1,3,5".
std::string frame_list_text(const std::vector<std::int64_t>& frames) {
    const bool consecutive = frames.size() > 1 && frames.back() - frames.front() + 1 == static_cast<std::int64_t>(frames.size());
    if (consecutive) return fmt::format("{}-{}", frames.front(), frames.back());
    std::string text;
    for (auto f : frames) text += fmt::format("{}{}", text.empty() ? "" : ",", f);
    return text;
}

// The shot's name: the output pattern's file name before its frame token, trimmed of separators.
std::string shot_name(const FramePattern& out) {
    std::string name = fs::path(out.prefix).filename().string();
    while (!name.empty() && (name.back() == '.' || name.back() == '_' || name.back() == '-')) name.pop_back();
    return name.empty() ? "shot" : name;
}

bool is_complete(const FarmPlan& plan, std::int64_t frame) { return fs::exists(plan.out.path(frame)); }

FarmPlan make_plan(const FarmSettings& s) {
    FarmPlan plan;
    plan.in = parse_pattern(s.input);
    plan.out = parse_pattern(s.output);
    if (!plan.in.is_sequence) throw std::runtime_error(fmt::format("farm: {}: the input must be a frame pattern (shot.####.exr)", s.input));
    if (!plan.out.is_sequence) throw std::runtime_error(fmt::format("farm: {}: the output must be a frame pattern (out.####.exr)", s.output));
    // A farm lists its chunks' frames in its job script: a shot of at most 2^20 frames.
    constexpr std::uint64_t kMaxShotFrames = std::uint64_t{1} << 20;
    const FrameList frames = frames_to_read(s.input, s.frames, true);
    if (frames.size() > kMaxShotFrames)
        throw std::runtime_error(fmt::format("farm: {}: {} frames; a farm shot holds at most {}", s.input, frames.size(), kMaxShotFrames));
    plan.frames = frames.listed(kMaxShotFrames);
    for (auto f : plan.frames)
        if (f < 0) throw std::runtime_error(fmt::format("farm: {}: frame {}: negative frame numbers are not supported", s.input, f));
    plan.shot = shot_name(plan.out);
    plan.dir = fs::absolute(fs::path(plan.out.prefix).parent_path()) / "lensfx-farm" / plan.shot;
    plan.script = plan.dir / "job.sh";
    plan.tracks = s.tracks.empty() ? plan.dir / "tracks.json" : fs::absolute(s.tracks);
    plan.logs = plan.dir / "logs";
    for (std::size_t i = 0; i < plan.frames.size(); i += static_cast<std::size_t>(s.chunk)) {
        Chunk c;
        c.id = static_cast<int>(plan.chunks.size()) + 1;
        const auto end = std::min(plan.frames.size(), i + static_cast<std::size_t>(s.chunk));
        c.frames.assign(plan.frames.begin() + static_cast<std::ptrdiff_t>(i), plan.frames.begin() + static_cast<std::ptrdiff_t>(end));
        std::copy_if(c.frames.begin(), c.frames.end(), std::back_inserter(c.missing), [&](auto f) { return !is_complete(plan, f); });
        plan.complete += c.frames.size() - c.missing.size();
        plan.chunks.push_back(std::move(c));
    }
    return plan;
}

// The output pattern as a printf format for the job script's completeness test.
std::string printf_format(const FramePattern& p) {
    auto escape = [](const std::string& s) {
        std::string e;
        for (char c : s) e += c == '%' ? std::string("%%") : c == '\\' ? std::string("\\\\") : std::string(1, c);
        return e;
    };
    return escape(p.prefix) + fmt::format("%0{}d", std::max(p.padding, 1)) + escape(p.suffix);
}

// --- the job script ----------------------------------------------------------------------------------

std::string chunk_cases(const FarmPlan& plan) {
    std::string cases;
    for (const auto& c : plan.chunks) {
        std::string numbers;
        for (auto f : c.frames) numbers += fmt::format("{}{}", numbers.empty() ? "" : " ", f);
        cases += fmt::format("  {}) frames=({}) ;;\n", c.id, numbers);
    }
    return cases;
}

std::string job_script(const FarmPlan& plan, const FarmSettings& s) {
    std::string sbatch_lines;
    for (const auto& o : s.sbatch_options) sbatch_lines += fmt::format("#SBATCH {}\n", o);
    return fmt::format(R"SCRIPT(#!/bin/bash
# lensfx farm: shot "{shot}", {n} frames ({list}) in {chunks} chunks of up to {size}, written by `lensfx farm`.
# Every chunk renders with the lights of one track file (tracked once over the whole shot), so the frames
# are bit-identical to a single `lensfx` run over the shot with --tracks.
#   all chunks on Slurm:   sbatch {script}
#   some chunks again:     sbatch --array=2,4 {script}
#   one chunk here:        SLURM_ARRAY_TASK_ID=2 bash {script}
# A task renders only the frames of its chunk whose final file does not exist yet (lensfx writes each frame
# to a temporary and renames it), so a task killed midway loses at most the frame it was writing.
#SBATCH --job-name=lensfx-{shot}
#SBATCH --array=1-{chunks}
#SBATCH --output={logs}/chunk-%a.%A.log
{sbatch_lines}set -euo pipefail
lensfx={exe}
input={input}
output={output}
output_printf={output_printf}
tracks={tracks}
filter_options=({filter_options})

# The chunk: the array index of Slurm, PBS Pro, Torque, SGE or LSF, or SLURM_ARRAY_TASK_ID=N by hand.
chunk=${{SLURM_ARRAY_TASK_ID:-${{PBS_ARRAY_INDEX:-${{PBS_ARRAYID:-${{SGE_TASK_ID:-${{LSB_JOBINDEX:-}}}}}}}}}}
[ -n "$chunk" ] || {{ echo "lensfx-farm: no array index: submit with sbatch --array, or run SLURM_ARRAY_TASK_ID=1 bash $0" >&2; exit 2; }}
case "$chunk" in
{cases}  *) echo "lensfx-farm: chunk $chunk: no such chunk (1-{chunks})" >&2; exit 2 ;;
esac

todo=()
for f in "${{frames[@]}}"; do
  [ -e "$(printf "$output_printf" "$f")" ] || todo+=("$f")
done
echo "lensfx-farm: chunk $chunk on ${{SLURMD_NODENAME:-$(hostname)}}: ${{#todo[@]}} of ${{#frames[@]}} frames to render"
[ "${{#todo[@]}}" -gt 0 ] || exit 0
render=("$lensfx" -i "$input" -o "$output" --frames "$(IFS=,; echo "${{todo[*]}}")" --tracks "$tracks" "${{filter_options[@]}}")
echo "lensfx-farm: ${{render[*]}}"

# Test hook (the farm test): LENSFX_FARM_TEST_KILL=N kills chunk N on its first try once a frame is complete.
if [ "${{LENSFX_FARM_TEST_KILL:-}}" = "$chunk" ] && [ "${{LENSFX_FARM_ATTEMPT:-1}}" = 1 ]; then
  "${{render[@]}}" & pid=$!
  while kill -0 "$pid" 2>/dev/null && [ ! -e "$(printf "$output_printf" "${{todo[0]}}")" ]; do sleep 0.05; done
  echo "lensfx-farm: test hook: killing chunk $chunk midway" >&2
  kill -9 "$pid" 2>/dev/null || true
  kill -9 $$
fi
exec "${{render[@]}}"
)SCRIPT",
                       fmt::arg("shot", plan.shot), fmt::arg("n", plan.frames.size()), fmt::arg("list", frame_list_text(plan.frames)),
                       fmt::arg("chunks", plan.chunks.size()), fmt::arg("size", s.chunk), fmt::arg("script", shell_quote(plan.script.string())),
                       fmt::arg("logs", plan.logs.string()), fmt::arg("sbatch_lines", sbatch_lines),
                       fmt::arg("exe", shell_quote(self_executable().string())),
                       fmt::arg("input", shell_quote(fs::absolute(s.input).string())),
                       fmt::arg("output", shell_quote(fs::absolute(s.output).string())),
                       fmt::arg("output_printf", shell_quote(printf_format(parse_pattern(fs::absolute(s.output).string())))),
                       fmt::arg("tracks", shell_quote(plan.tracks.string())), fmt::arg("filter_options", shell_words(s.filter_options)),
                       fmt::arg("cases", chunk_cases(plan)));
}

void write_job_script(const FarmPlan& plan, const FarmSettings& s) {
    fs::create_directories(plan.logs);
    const fs::path tmp = plan.script.string() + ".tmp";
    {
        std::ofstream f(tmp);
        f << job_script(plan, s);
        if (!f) throw std::runtime_error(fmt::format("farm: cannot write {}", tmp.string()));
    }
    fs::permissions(tmp, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
    fs::rename(tmp, plan.script);
}

// The value of `--name VALUE` or `--name=VALUE` among the filter options, if given.
std::optional<std::string> option_value(const std::vector<std::string>& options, const std::string& name) {
    for (std::size_t i = 0; i < options.size(); ++i) {
        if (options[i] == name && i + 1 < options.size()) return options[i + 1];
        if (options[i].starts_with(name + "=")) return options[i].substr(name.size() + 1);
    }
    return std::nullopt;
}

// The filter's --lens read as each task would read it: a missing or broken lens fails here, once.
void check_lens_option(const std::vector<std::string>& options) {
    const std::optional<std::string> lens = option_value(options, "--lens");
    if (!lens) return;
    try {
        if (measured::is_measured_file(*lens))
            static_cast<void>(measured::read_measured(*lens));
        else
            static_cast<void>(optics::load_lens(*lens));
    } catch (const std::exception& e) {
        throw std::runtime_error(fmt::format("farm: filter options: --lens {}", e.what()));
    }
}

// The filter options are checked here, once, rather than failing in every task on the farm.
void check_filter_options(const std::vector<std::string>& options) {
    CLI::App app;
    register_filter(app);
    std::vector<std::string> args(options.rbegin(), options.rend());  // CLI11 takes them last first
    try {
        app.parse(args);
    } catch (const CLI::CallForHelp&) {
        // parsed; the filter would run now if it had -i and -o
    } catch (const CLI::ParseError& e) {  // said as the filter would say it (an unknown option named, with a hint)
        throw std::runtime_error(fmt::format("farm: filter options: {}", usage_error_message(app, e, options)));
    }
    check_lens_option(options);
}

// `lensfx track` once over the whole shot (with the filter's detection options), unless the track file
// is given or a resumed run has it already.
void track_shot(const FarmPlan& plan, const FarmSettings& s) {
    if (!s.tracks.empty()) {
        if (!fs::exists(plan.tracks)) throw std::runtime_error(fmt::format("farm: {}: no such track file", plan.tracks.string()));
        return;
    }
    if (s.resume && fs::exists(plan.tracks)) return;
    fs::create_directories(plan.dir);
    std::vector<std::string> argv{self_executable().string(), "track", "-i", s.input, "--frames", frame_list_text(plan.frames),
                                  "--tracks-out", plan.tracks.string(), "-q"};
    for (const char* name : {"--threshold", "--max-lights"})
        if (auto v = option_value(s.filter_options, name)) argv.insert(argv.end(), {name, *v});
    const CommandOutput r = run_command(argv);
    if (r.status != 0) throw std::runtime_error(fmt::format("farm: tracking the shot failed: {}", last_line(r.text)));
}

// --- engines -----------------------------------------------------------------------------------------

std::string chunk_ids(const std::vector<int>& ids) {
    std::string text;
    for (int id : ids) text += fmt::format("{}{}", text.empty() ? "" : ",", id);
    return text;
}

// Runs the chunks of one try and says how each ended.
class Engine {
public:
    virtual ~Engine() = default;
    virtual std::string name() const = 0;
    virtual std::vector<TaskResult> run(const FarmPlan& plan, const std::vector<int>& chunks, int attempt) = 0;
};

// The job script's tasks as processes on this machine, up to `jobs` at a time.
class LocalEngine : public Engine {
public:
    explicit LocalEngine(int jobs) : jobs_(std::max(jobs, 1)) {}
    std::string name() const override { return "local"; }

    std::vector<TaskResult> run(const FarmPlan& plan, const std::vector<int>& chunks, int attempt) override {
        std::vector<TaskResult> results;
        std::map<pid_t, std::pair<TaskResult, Clock::time_point>> running;
        std::size_t next = 0;
        while (next < chunks.size() || !running.empty()) {
            while (next < chunks.size() && running.size() < static_cast<std::size_t>(jobs_)) {
                TaskResult r;
                r.chunk = chunks[next++];
                r.node = host_name();
                r.log = (plan.logs / fmt::format("chunk-{}.local-{}.log", r.chunk, attempt)).string();
                running.emplace(start_task(plan, r, attempt), std::make_pair(r, Clock::now()));
            }
            int status = 0;
            const pid_t pid = ::waitpid(-1, &status, 0);
            auto it = running.find(pid);
            if (it == running.end()) continue;
            TaskResult r = it->second.first;
            r.seconds = std::chrono::duration<double>(Clock::now() - it->second.second).count();
            r.ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
            r.state = r.ok                  ? "COMPLETED"
                      : WIFSIGNALED(status) ? fmt::format("KILLED (signal {})", WTERMSIG(status))
                                            : fmt::format("FAILED (exit {})", WEXITSTATUS(status));
            results.push_back(r);
            running.erase(it);
        }
        return results;
    }

private:
    static pid_t start_task(const FarmPlan& plan, const TaskResult& r, int attempt) {
        const std::string id = std::to_string(r.chunk), att = std::to_string(attempt);
        const pid_t pid = ::fork();
        if (pid < 0) throw std::runtime_error("farm: cannot start a local task: fork failed");
        if (pid == 0) {
            ::setenv("SLURM_ARRAY_TASK_ID", id.c_str(), 1);
            ::setenv("LENSFX_FARM_ATTEMPT", att.c_str(), 1);
            if (std::FILE* log = std::freopen(r.log.c_str(), "w", stdout)) {
                ::dup2(::fileno(log), 2);
            }
            ::execl("/bin/bash", "bash", plan.script.c_str(), static_cast<char*>(nullptr));
            ::_exit(127);
        }
        return pid;
    }
    int jobs_;
};

// Fields of `scontrol show job -o` lines: one line per array task (pending ones may share a line).
std::map<std::string, std::string> scontrol_fields(const std::string& line) {
    std::map<std::string, std::string> fields;
    std::istringstream in(line);
    std::string word;
    while (in >> word) {
        const auto eq = word.find('=');
        if (eq != std::string::npos) fields[word.substr(0, eq)] = word.substr(eq + 1);
    }
    return fields;
}

// "D-HH:MM:SS" or "HH:MM:SS" as seconds.
double slurm_seconds(const std::string& t) {
    int d = 0, h = 0, m = 0, s = 0;
    if (std::sscanf(t.c_str(), "%d-%d:%d:%d", &d, &h, &m, &s) == 4) return ((d * 24 + h) * 60 + m) * 60.0 + s;
    if (std::sscanf(t.c_str(), "%d:%d:%d", &h, &m, &s) == 3) return (h * 60 + m) * 60.0 + s;
    return 0;
}

bool is_final_state(const std::string& state) {
    for (const char* live : {"PENDING", "RUNNING", "CONFIGURING", "COMPLETING", "REQUEUED", "RESIZING", "SUSPENDED", "STAGE_OUT", "SIGNALING"})
        if (state == live) return false;
    return true;
}

// One sbatch --array per try, followed through scontrol (works without Slurm's accounting database).
class SlurmEngine : public Engine {
public:
    SlurmEngine(bool wait, bool quiet) : wait_(wait), quiet_(quiet) {}
    std::string name() const override { return "slurm"; }

    std::vector<TaskResult> run(const FarmPlan& plan, const std::vector<int>& chunks, int attempt) override {
        const std::string job = submit(plan, chunks, attempt);
        if (!wait_ && quiet_) {
            fmt::print("{}\n", job);  // the job id alone, as `sbatch --parsable` prints it
            return {};
        }
        if (!wait_) {
            fmt::print("lensfx farm: submitted job {} ({} tasks, chunks {}) from {}\n"
                       "  follow:  squeue -j {}   (sacct -j {} where accounting is on; scontrol show job {})\n"
                       "  logs:    {}/chunk-<N>.{}.log\n"
                       "  then:    the same lensfx farm command with --resume --wait renders whatever did not finish\n",
                       job, chunks.size(), chunk_ids(chunks), plan.script.string(), job, job, job, plan.logs.string(), job);
            return {};
        }
        if (!quiet_) fmt::print(stderr, "lensfx farm: job {} (chunks {}, try {})\n", job, chunk_ids(chunks), attempt);
        return follow(plan, job);
    }

private:
    static std::string submit(const FarmPlan& plan, const std::vector<int>& chunks, int attempt) {
        // The try number travels in sbatch's own environment (exported by default): `--export=ALL,VAR=x` would
        // make slurmd load the user's login environment for each task (seconds each, measured).
        const CommandOutput r = run_command({"env", "LENSFX_FARM_ATTEMPT=" + std::to_string(attempt), "sbatch", "--parsable",
                                             "--array=" + chunk_ids(chunks), plan.script.string()});
        if (r.status != 0) throw std::runtime_error(fmt::format("farm: sbatch rejected the job: {}", last_line(r.text)));
        const std::string job = last_line(r.text).substr(0, last_line(r.text).find(';'));
        if (job.empty() || job.find_first_not_of("0123456789") != std::string::npos)
            throw std::runtime_error(fmt::format("farm: sbatch answered \"{}\", not a job id", last_line(r.text)));
        return job;
    }

    // Polls until every task of the job has ended. The scheduler may be briefly unreachable; a minute
    // without an answer is an error.
    static std::vector<TaskResult> follow(const FarmPlan& plan, const std::string& job) {
        const auto started = Clock::now();
        auto last_answer = started;
        for (;;) {
            const CommandOutput r = run_command({"scontrol", "show", "job", "-o", job});
            if (r.status != 0) {
                if (Clock::now() - last_answer > std::chrono::seconds(60))
                    throw std::runtime_error(fmt::format("farm: lost the scheduler while following job {}: {}", job, last_line(r.text)));
                std::this_thread::sleep_for(std::chrono::seconds(2));
                continue;
            }
            last_answer = Clock::now();
            std::vector<TaskResult> results;
            bool all_final = true;
            std::istringstream lines(r.text);
            for (std::string line; std::getline(lines, line);) {
                auto f = scontrol_fields(line);
                if (f["JobState"].empty()) continue;
                if (!is_final_state(f["JobState"]) || f["ArrayTaskId"].find_first_not_of("0123456789") != std::string::npos) {
                    all_final = false;
                    continue;
                }
                TaskResult t;
                t.chunk = std::stoi(f["ArrayTaskId"]);
                t.ok = f["JobState"] == "COMPLETED";
                t.state = t.ok ? "COMPLETED" : fmt::format("{} (exit {}, {})", f["JobState"], f["ExitCode"], f["Reason"]);
                t.node = f["NodeList"];
                t.seconds = slurm_seconds(f["RunTime"]);
                t.log = (plan.logs / fmt::format("chunk-{}.{}.log", t.chunk, job)).string();
                results.push_back(t);
            }
            if (all_final) return results;
            // Every second at first, then less often (at most every 10 s) for long jobs on a busy controller.
            const auto waited = std::chrono::duration_cast<std::chrono::seconds>(Clock::now() - started).count();
            std::this_thread::sleep_for(std::chrono::seconds(std::clamp<long>(static_cast<long>(waited / 30), 1, 10)));
        }
    }
    bool wait_;
    bool quiet_;
};

// Whether a Slurm controller answers here (sinfo reaches it).
bool slurm_answers() { return run_command({"timeout", "10", "sinfo", "-h", "-o", "%a"}).status == 0; }

std::unique_ptr<Engine> make_engine(const FarmSettings& s) {
    std::string engine = s.engine;
    if (engine == "auto") {
        engine = slurm_answers() ? "slurm" : "local";
        if (engine == "local" && !s.quiet()) fmt::print(stderr, "lensfx farm: no Slurm scheduler answers (sinfo); running the chunks here\n");
    }
    if (engine == "slurm") return std::make_unique<SlurmEngine>(s.wait, s.quiet());
    return std::make_unique<LocalEngine>(s.local_jobs);
}

// --- following the tries -----------------------------------------------------------------------------

// A chunk's history over the tries.
struct ChunkRecord {
    TaskResult last;
    std::vector<std::string> failures;  // "try 1: FAILED (...), log PATH"
};

// A task that ended well but left frames missing failed all the same.
void check_frames(const FarmPlan& plan, TaskResult& r) {
    if (!r.ok) return;
    for (auto f : plan.chunks[static_cast<std::size_t>(r.chunk - 1)].frames) {
        if (!is_complete(plan, f)) {
            r.ok = false;
            r.state = fmt::format("COMPLETED without frame {}", f);
            return;
        }
    }
}

void print_report(const FarmPlan& plan, const std::map<int, ChunkRecord>& records, double seconds) {
    std::size_t rendered = 0, retries = 0;
    for (const auto& c : plan.chunks) {
        auto it = records.find(c.id);
        if (it == records.end()) {
            fmt::print("lensfx farm: chunk {} frames {}: complete already\n", c.id, frame_list_text(c.frames));
            continue;
        }
        const ChunkRecord& rec = it->second;
        const auto now = static_cast<std::size_t>(std::count_if(c.missing.begin(), c.missing.end(), [&](auto f) { return is_complete(plan, f); }));
        rendered += now;
        retries += rec.failures.size();
        fmt::print("lensfx farm: chunk {} frames {}: {}, node {}, {:.1f} s, {} rendered ({} complete already), {} failures{}\n", c.id,
                   frame_list_text(c.frames), rec.last.state, rec.last.node, rec.last.seconds, now, c.frames.size() - c.missing.size(),
                   rec.failures.size(), rec.failures.empty() ? "" : ": " + rec.failures.front() + (rec.failures.size() > 1 ? "..." : ""));
    }
    fmt::print("lensfx farm: {} of {} frames complete: {} rendered, {} complete already; {} chunks, {} retried; {:.1f} s\n", rendered + plan.complete,
               plan.frames.size(), rendered, plan.complete, plan.chunks.size(), retries, seconds);
    std::fflush(stdout);  // before the one-line error, if one follows
}

// Removes the temporaries that killed tasks left beside the frames (".pan.0014.lensfx-PID.exr", see
// image_io.cpp); called once no task of the shot runs.
std::size_t remove_stale_temporaries(const FarmPlan& plan) {
    std::vector<std::pair<std::string, std::string>> names;  // ".<stem>.lensfx-" and the extension
    for (auto f : plan.frames) {
        const fs::path p(plan.out.path(f));
        names.emplace_back("." + p.stem().string() + ".lensfx-", p.extension().string());
    }
    std::size_t removed = 0;
    const fs::path dir = fs::absolute(fs::path(plan.out.path(plan.frames.front())).parent_path());
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::string name = e.path().filename().string();
        for (const auto& [prefix, ext] : names) {
            if (name.starts_with(prefix) && name.ends_with(ext)) {
                removed += fs::remove(e.path(), ec) ? 1 : 0;
                break;
            }
        }
    }
    return removed;
}

std::string failure_text(const TaskResult& r, int attempt) { return fmt::format("try {} {} (log {})", attempt, r.state, r.log); }

// Refuses text bound for the job script that holds a control character: a line break in an #SBATCH line, a
// comment or the unquoted #SBATCH --output path would start a line of shell of its own (text after it run by
// bash on every node), and a NUL would cut it short. `what` names where it came from.
void check_script_text(const std::string& what, const std::string& text) {
    const auto control = [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; };
    if (std::none_of(text.begin(), text.end(), control)) return;
    std::string shown;  // control characters as \xNN, so the message stays one line
    for (char c : text) shown += control(c) ? fmt::format("\\x{:02x}", static_cast<int>(static_cast<unsigned char>(c))) : std::string(1, c);
    throw std::runtime_error(fmt::format("farm: {} \"{}\" holds a control character, which the job script cannot carry", what, shown));
}

// Everything the job script writes outside single quotes, or inside its comments: the paths, the shot's name,
// the program's path and the extra #SBATCH lines.
void check_job_script_text(const FarmPlan& plan, const FarmSettings& s) {
    check_script_text("the input pattern", fs::absolute(s.input).string());
    check_script_text("the output pattern", fs::absolute(s.output).string());
    check_script_text("the track file's path", plan.tracks.string());
    check_script_text("the farm folder", plan.dir.string());
    check_script_text("the program's path", self_executable().string());
    for (const auto& o : s.sbatch_options) check_script_text("--sbatch", o);
}

// Runs the missing chunks, then the failed ones again, up to `retries` more times.
void run_farm(FarmSettings& s) {
    if (s.chunk < 1) throw std::runtime_error("farm: --chunk must be at least 1");
    check_filter_options(s.filter_options);
    const auto start = Clock::now();
    const FarmPlan plan = make_plan(s);
    check_job_script_text(plan, s);
    if (plan.complete > 0 && !s.resume)
        throw std::runtime_error(fmt::format("farm: {}: {} of {} frames are complete already; --resume renders the rest (finished frames are never rewritten)",
                                             s.output, plan.complete, plan.frames.size()));
    std::vector<int> todo;
    for (const auto& c : plan.chunks)
        if (!c.missing.empty()) todo.push_back(c.id);
    track_shot(plan, s);
    write_job_script(plan, s);
    auto engine = make_engine(s);
    if (!s.quiet())
        fmt::print(stderr, "lensfx farm: {} frames in {} chunks ({} to render, {} complete already), engine {}, job script {}\n",
                   plan.frames.size(), plan.chunks.size(), todo.size(), plan.chunks.size() - todo.size(), engine->name(), plan.script.string());
    std::map<int, ChunkRecord> records;
    for (int attempt = 1; !todo.empty() && attempt <= s.retries + 1; ++attempt) {
        std::vector<TaskResult> results = engine->run(plan, todo, attempt);
        if (engine->name() == "slurm" && !s.wait) return;
        todo.clear();
        for (auto& r : results) {
            check_frames(plan, r);
            records[r.chunk].last = r;
            if (r.ok) continue;
            records[r.chunk].failures.push_back(failure_text(r, attempt));
            todo.push_back(r.chunk);
            if (!s.quiet()) fmt::print(stderr, "lensfx farm: chunk {} failed: {}\n", r.chunk, failure_text(r, attempt));
        }
        std::sort(todo.begin(), todo.end());
    }
    if (const std::size_t n = remove_stale_temporaries(plan); n > 0 && !s.quiet())
        fmt::print(stderr, "lensfx farm: removed {} temporary files left by killed tasks\n", n);
    if (!s.quiet()) print_report(plan, records, std::chrono::duration<double>(Clock::now() - start).count());
    if (!todo.empty()) {
        const ChunkRecord& rec = records[todo.front()];
        throw std::runtime_error(fmt::format("farm: chunk {} (frames {}) failed {} times, last {}; {} chunks unfinished, --resume renders them",
                                             todo.front(), frame_list_text(plan.chunks[static_cast<std::size_t>(todo.front() - 1)].frames),
                                             rec.failures.size(), rec.failures.back(), todo.size()));
    }
}

}  // namespace

void register_farm_command(CLI::App& app) {
    auto s = std::make_shared<FarmSettings>();
    auto* cmd = app.add_subcommand("farm", "Render a shot as a job array (Slurm, or processes here), bit-identical to one run");
    cmd->option_defaults()->always_capture_default();
    cmd->allow_extras();
    cmd->footer("Every other option is the filter's (lensfx --help) and goes to every chunk: lensfx farm -i IN -o OUT --chunk 10 --lens brendel-tessar");
    cmd->add_option("-i,--input", s->input, "Input frame pattern (shot.####.exr)")->required();
    cmd->add_option("-o,--output", s->output, "Output frame pattern; the job script, tracks and logs go to its folder/lensfx-farm/<shot>/")->required();
    cmd->add_option("--frames", s->frames, "Frames: 1-100, 1-100x2, 3,7,10-20 (default: those on disk)");
    cmd->add_option("--chunk", s->chunk, "Frames per task")->check(CLI::PositiveNumber);
    cmd->add_option("--engine", s->engine, "slurm (sbatch --array), local (processes here), auto (slurm when sinfo answers)")
        ->check(CLI::IsMember({"auto", "slurm", "local"}));
    cmd->add_flag("--wait", s->wait, "Follow the Slurm job to its end, report each chunk and resubmit failed ones (local always waits)");
    cmd->add_option("--retries", s->retries, "Tries again for a failed chunk")->check(CLI::Range(0, 100));
    cmd->add_flag("--resume", s->resume, "Render only the frames not complete yet (otherwise existing output frames are an error)");
    cmd->add_option("--tracks", s->tracks, "Render from this track file instead of tracking the shot first");
    cmd->add_option("--local-jobs", s->local_jobs, "Chunks run at once by the local engine")->check(CLI::Range(1, 1024));
    cmd->add_option("--sbatch", s->sbatch_options, "An extra #SBATCH line for the job script, e.g. --sbatch=--partition=render (repeatable)");
    cmd->callback([s, cmd] {
        s->filter_options = cmd->remaining();
        run_farm(*s);
    });
}

}  // namespace lensfx::filter
