// `lensfx farm`: the sample shot (samples/pan, 24 frames) in chunks of 6, through Slurm (the one-node cluster
// of scripts/slurm-local.sh; skipped when none answers) and as local processes. Every frame must be
// bit-identical to one `lensfx` process rendering the shot with a track file of `lensfx track`, also when
// a chunk is killed midway and retried, and after an interrupted run resumed with --resume, which must
// leave the frames complete before it untouched.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <fmt/core.h>
#include <gtest/gtest.h>

#include "../filter/filter_test_util.h"

namespace {

namespace fs = std::filesystem;
using lensfx::test::lensfx_cmd;
using lensfx::test::run;

constexpr int kFrames = 24;
constexpr int kChunk = 6;

// A cheap flare: the starburst alone (0.1-0.3 s a frame here, against about 1 s with the ghosts on
// llvmpipe), still drawn at each tracked light with its weight, so a chunk that tracked on its own or
// rendered other lights would differ.
const std::string kFilterOptions = "--lens brendel-tessar --fstop 5.6 --parts starburst --gain 20 --starburst-scale 20";

const std::string kInput = std::string(LENSFX_SOURCE_DIR) + "/samples/pan/pan.####.exr";

std::string frame_name(int f) { return fmt::format("pan.{:04d}.exr", f); }

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

std::string last_line(const std::string& text) {
    std::string t = text;
    while (!t.empty() && t.back() == '\n') t.pop_back();
    const auto nl = t.rfind('\n');
    return nl == std::string::npos ? t : t.substr(nl + 1);
}

bool slurm_answers() { return std::system("timeout 5 sinfo -h -o %a >/dev/null 2>&1") == 0; }

// The reference: `lensfx track`, then one `lensfx` process over the whole shot. Made once for all the
// test processes of this build (ctest runs each test alone): kept in the build folder under a name of the
// program's build time and the options (earlier ones removed), written aside and renamed into place.
fs::path reference_dir() {
    const auto built = fs::last_write_time(LENSFX_BINARY).time_since_epoch().count();
    const fs::path build = fs::path(LENSFX_BINARY).parent_path();
    const std::string name = fmt::format("farm-test-reference-{:x}", std::hash<std::string>{}(std::to_string(built) + kFilterOptions));
    const fs::path dir = build / name;
    if (fs::exists(dir)) return dir;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(build)) {
        const std::string other = e.path().filename().string();
        if (other.starts_with("farm-test-reference-") && !other.starts_with(name)) fs::remove_all(e.path(), ec);
    }
    const fs::path tmp = build / fmt::format("{}.{}", name, ::getpid());
    fs::create_directories(tmp);
    const auto t = run(fmt::format("{} track -i {} --tracks-out {}/tracks.json -q && {} -i {} -o {}/pan.####.exr --tracks {}/tracks.json {} -q", lensfx_cmd(), kInput,
                                   tmp.string(), lensfx_cmd(), kInput, tmp.string(), tmp.string(), kFilterOptions));
    if (t.exit_code != 0) throw std::runtime_error("the reference run failed: " + t.stderr_text);
    fs::rename(tmp, dir, ec);  // another test process may have been first: its frames are the same
    if (ec) fs::remove_all(tmp);
    if (!fs::exists(dir)) throw std::runtime_error(fmt::format("cannot rename {} to {}: {}", tmp.string(), dir.string(), ec.message()));
    return dir;
}

class FarmTest : public ::testing::TestWithParam<std::string> {
protected:
    static void SetUpTestSuite() { ref_ = reference_dir(); }

    void SetUp() override {
        if (GetParam() == "slurm" && !slurm_answers())
            GTEST_SKIP() << "no Slurm cluster answers (sinfo fails): start one with `bash scripts/slurm-local.sh start` (as root)";
        std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
        std::replace(name.begin(), name.end(), '/', '-');
        out_ = lensfx::test::scratch_dir("farm-" + name);
    }
    void TearDown() override {
        if (!HasFailure() && !out_.empty()) fs::remove_all(out_);
    }

    // `lensfx farm` over the shot; stdout and stderr together.
    lensfx::test::RunResult farm(const std::string& extra, const std::string& env = "") {
        return run(fmt::format("{} {} farm -i {} -o {}/pan.####.exr --chunk {} --engine {} --wait {} {} 1>&2", env, lensfx_cmd(), kInput, out_.string(), kChunk,
                               GetParam(), extra, kFilterOptions));
    }

    // "" when every frame is byte for byte the reference's, else the first that is not.
    std::string differences() const {
        for (int f = 1; f <= kFrames; ++f) {
            const fs::path a = ref_ / frame_name(f), b = out_ / frame_name(f);
            if (!fs::exists(b)) return b.string() + " missing";
            if (slurp(a) != slurp(b)) return fmt::format("{} differs from one process's: {}", b.string(), lensfx::test::compare_images(a, b));
        }
        return "";
    }

    // Inode and modification time of the complete frames: a frame rewritten gets a new inode (renamed into place).
    std::map<int, std::pair<ino_t, std::int64_t>> complete_frames() const {
        std::map<int, std::pair<ino_t, std::int64_t>> frames;
        for (int f = 1; f <= kFrames; ++f) {
            struct stat st {};
            if (::stat((out_ / frame_name(f)).c_str(), &st) == 0)
                frames[f] = {st.st_ino, static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec};
        }
        return frames;
    }

    static inline fs::path ref_;
    fs::path out_;
};

// Cancels chunk 2's Slurm task (scancel JOB_2) once it has written its first frame, as an operator or a
// lost node would; the job id is read from the task's log name (logs/chunk-2.JOB.log).
void cancel_chunk_two_midway(const fs::path& out, const std::atomic<bool>& done) {
    const fs::path logs = out / "lensfx-farm/pan/logs";
    while (!done) {
        std::error_code ec;
        for (const auto& e : fs::directory_iterator(logs, ec)) {
            const std::string name = e.path().filename().string();
            if (!name.starts_with("chunk-2.") || !fs::exists(out / frame_name(7))) continue;
            const std::string job = name.substr(8, name.size() - 8 - 4);
            EXPECT_EQ(std::system(("scancel " + job + "_2").c_str()), 0);
            return;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
}

TEST_P(FarmTest, KilledChunkIsRetriedAndFramesMatchOneProcess) {
    // Slurm: chunk 2 cancelled by scancel; local: killed by the job script's test hook (SIGKILL).
    std::atomic<bool> done{false};
    std::thread canceller;
    if (GetParam() == "slurm") canceller = std::thread(cancel_chunk_two_midway, out_, std::cref(done));
    const auto r = farm("--retries 1", GetParam() == "slurm" ? "" : "LENSFX_FARM_TEST_KILL=2");
    done = true;
    if (canceller.joinable()) canceller.join();
    ASSERT_EQ(r.exit_code, 0) << r.stderr_text;
    EXPECT_NE(r.stderr_text.find(GetParam() == "slurm" ? "chunk 2 failed: try 1 CANCELLED" : "chunk 2 failed: try 1 KILLED"), std::string::npos)
        << r.stderr_text;
    EXPECT_NE(r.stderr_text.find("24 of 24 frames complete: 24 rendered, 0 complete already; 4 chunks, 1 retried"), std::string::npos) << r.stderr_text;
    EXPECT_EQ(differences(), "");

    // The job script is kept beside the logs: one array of four chunks of six frames, a log per task.
    const fs::path dir = out_ / "lensfx-farm/pan";
    const std::string script = slurp(dir / "job.sh");
    EXPECT_NE(script.find("#SBATCH --array=1-4"), std::string::npos) << script;
    EXPECT_NE(script.find("  4) frames=(19 20 21 22 23 24) ;;"), std::string::npos) << script;
    std::size_t logs = 0;
    for (const auto& e : fs::directory_iterator(dir / "logs")) logs += e.path().filename().string().starts_with("chunk-") ? 1 : 0;
    EXPECT_EQ(logs, 5u);  // four chunks, one of them twice
    for (const auto& e : fs::directory_iterator(out_))
        EXPECT_FALSE(e.path().filename().string().starts_with(".")) << e.path() << ": a temporary of the killed task was left";

    // Nothing left to do: nothing is submitted, no frame is touched.
    const auto before = complete_frames();
    const auto again = farm("--resume");
    EXPECT_EQ(again.exit_code, 0) << again.stderr_text;
    EXPECT_NE(again.stderr_text.find("24 of 24 frames complete: 0 rendered, 24 complete already"), std::string::npos) << again.stderr_text;
    EXPECT_EQ(complete_frames(), before);
    // -q: the farm says nothing either (stdout and stderr together here).
    const auto quiet = farm("--resume -q");
    EXPECT_EQ(quiet.exit_code, 0) << quiet.stderr_text;
    EXPECT_EQ(quiet.stderr_text, "");
}

TEST_P(FarmTest, ResumeRendersOnlyWhatIsMissing) {
    // Interrupted: chunk 3 is killed after its first frame and not retried; the run fails in one line.
    const auto r = farm("--retries 0", "LENSFX_FARM_TEST_KILL=3");
    ASSERT_NE(r.exit_code, 0) << r.stderr_text;
    const std::string last = last_line(r.stderr_text);
    EXPECT_TRUE(last.starts_with("lensfx: farm: chunk 3 (frames 13-18) failed 1 times")) << r.stderr_text;
    const auto before = complete_frames();
    ASSERT_GE(before.size(), 19u);  // chunks 1, 2, 4 and at least frame 13
    ASSERT_LT(before.size(), 24u);
    EXPECT_NE(r.stderr_text.find(fmt::format("{} of 24 frames complete", before.size())), std::string::npos) << r.stderr_text;

    // A rerun without --resume refuses to touch the output.
    const auto refused = farm("");
    EXPECT_NE(refused.exit_code, 0);
    EXPECT_NE(last_line(refused.stderr_text).find("--resume renders the rest"), std::string::npos) << refused.stderr_text;

    const auto resumed = farm("--resume");
    ASSERT_EQ(resumed.exit_code, 0) << resumed.stderr_text;
    const std::string summary = fmt::format("24 of 24 frames complete: {} rendered, {} complete already", 24 - before.size(), before.size());
    EXPECT_NE(resumed.stderr_text.find(summary), std::string::npos) << resumed.stderr_text;
    const auto after = complete_frames();
    for (const auto& [frame, id] : before) EXPECT_EQ(after.at(frame), id) << "frame " << frame << " was rewritten";
    EXPECT_EQ(differences(), "");
}

INSTANTIATE_TEST_SUITE_P(Engines, FarmTest, ::testing::Values("slurm", "local"), [](const auto& p) { return p.param; });

// With no controller to answer, a Slurm submission ends in one `lensfx:` line naming sbatch, exit non-zero.
TEST(FarmErrors, NoSchedulerIsOneClearLine) {
    const fs::path dir = lensfx::test::scratch_dir("farm-errors");
    std::ofstream(dir / "slurm.conf") << "ClusterName=none\nSlurmctldHost=localhost\nSlurmctldPort=1\nMessageTimeout=1\nNodeName=localhost\nPartitionName=p Nodes=localhost\n";
    const auto r = run(fmt::format("SLURM_CONF={}/slurm.conf {} farm -i {} -o {}/pan.####.exr --frames 1-2 --chunk 1 --engine slurm --tracks /dev/null 1>&2", dir.string(),
                                   lensfx_cmd(), kInput, dir.string()));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_TRUE(last_line(r.stderr_text).starts_with("lensfx: farm: sbatch rejected the job: ")) << r.stderr_text;
    std::size_t lines = 0;
    for (std::size_t p = 0; (p = r.stderr_text.find("lensfx:", p)) != std::string::npos; ++p) ++lines;
    EXPECT_EQ(lines, 1u) << r.stderr_text;
    EXPECT_FALSE(fs::exists(dir / "pan.0001.exr"));

    // A filter option the filter does not know is caught before anything is submitted.
    const auto bad = run(fmt::format("{} farm -i {} -o {}/pan.####.exr --chunk 1 --engine slurm --tracks /dev/null --no-such-option 1>&2", lensfx_cmd(), kInput,
                                     dir.string()));
    EXPECT_NE(bad.exit_code, 0);
    EXPECT_TRUE(last_line(bad.stderr_text).starts_with("lensfx: farm: filter options: ")) << bad.stderr_text;
    // So is a lens no task could read (each failed and was retried, leaving the farm's folder behind).
    const auto lens = run(fmt::format("{} farm -i {} -o {}/lens/pan.####.exr --frames 1-2 --chunk 1 --engine local --tracks /dev/null --lens no-such-lens",
                                      lensfx_cmd(), kInput, dir.string()));
    EXPECT_NE(lens.exit_code, 0);
    EXPECT_TRUE(lens.stderr_text.starts_with("lensfx: farm: filter options: --lens no-such-lens: no such lens file or preset")) << lens.stderr_text;
    EXPECT_EQ(std::count(lens.stderr_text.begin(), lens.stderr_text.end(), '\n'), 1) << lens.stderr_text;
    EXPECT_FALSE(fs::exists(dir / "lens"));
    fs::remove_all(dir);
}

// A line break in text the job script carries outside quotes (an #SBATCH line, the output folder in its comments and
// #SBATCH --output) would start a shell line of its own that every task runs: refused before anything is written.
TEST(FarmErrors, ControlCharactersNeverReachTheJobScript) {
    const fs::path dir = lensfx::test::scratch_dir("farm-inject");
    const fs::path marker = dir / "injected";
    const fs::path folder = dir / ("out\ntouch " + marker.string() + " #");
    fs::create_directories(folder);
    const std::string sbatch = "$'--partition=x\ntouch " + marker.string() + "'";
    const auto via_sbatch = run(fmt::format("{} farm -i {} -o {}/pan.####.exr --frames 1-2 --chunk 1 --engine local --tracks /dev/null --sbatch {} {} 1>&2",
                                            lensfx_cmd(), kInput, dir.string(), sbatch, kFilterOptions));
    EXPECT_NE(via_sbatch.exit_code, 0);
    EXPECT_TRUE(last_line(via_sbatch.stderr_text).starts_with("lensfx: farm: --sbatch ")) << via_sbatch.stderr_text;
    const auto via_folder = run(fmt::format("{} farm -i {} -o $'{}/pan.####.exr' --frames 1-2 --chunk 1 --engine local --tracks /dev/null {} 1>&2",
                                            lensfx_cmd(), kInput, folder.string(), kFilterOptions));
    EXPECT_NE(via_folder.exit_code, 0);
    EXPECT_TRUE(last_line(via_folder.stderr_text).starts_with("lensfx: farm: the output pattern ")) << via_folder.stderr_text;
    EXPECT_NE(last_line(via_folder.stderr_text).find("\\x0a"), std::string::npos) << via_folder.stderr_text;  // shown, on one line
    EXPECT_FALSE(fs::exists(marker));
    EXPECT_FALSE(fs::exists(dir / "lensfx-farm"));
    EXPECT_FALSE(fs::exists(folder / "lensfx-farm"));
    fs::remove_all(dir);
}

}  // namespace
