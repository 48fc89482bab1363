// `lensfx track -i IN --tracks-out tracks.json`: detects and tracks the light sources of a shot and writes
// them as a track file (docs/detection.md) that `lensfx -i IN -o OUT --tracks tracks.json` renders from.
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/core.h>

#include <detect/detector.h>
#include <detect/track_file.h>
#include <detect/tracker.h>
#include <filter/frame.h>
#include <filter/frame_view.h>
#include <filter/image_io.h>
#include <filter/option_checks.h>
#include <filter/output_files.h>
#include <filter/sequence.h>
#include <filter/stream.h>

#include "commands.h"

namespace lensfx::filter {

namespace {

struct TrackSettings {
    std::string input;
    std::string frames;
    std::string tracks_out;
    std::string threshold = "20";
    detect::DetectorOptions detector;
    detect::TrackerOptions tracker;
    int fade_frames = detect::TrackerOptions{}.fade_in_frames;
    bool quiet = false;
    bool allow_empty = false;
    std::string memory_limit;  // empty: default_memory_budget()
};

class ShotTracker {
public:
    explicit ShotTracker(const TrackSettings& s) : settings_(s), detector_(s.detector), tracker_(s.tracker) {}

    void add(Frame& frame, const std::string& where) {
        find_rgb_channels(frame);
        if (!frame.has_rgb()) throw std::runtime_error(fmt::format("{}: frame {}: no R, G, B channels", where, frame.number));
        load_rgb(frame);
        if (file_.width == 0) {
            file_.width = frame.spec.full_width;
            file_.height = frame.spec.full_height;
        } else if (file_.width != frame.spec.full_width || file_.height != frame.spec.full_height) {
            throw std::runtime_error(fmt::format("{}: frame {}: {}x{} frames after {}x{} ones", where, frame.number, frame.spec.full_width,
                                                 frame.spec.full_height, file_.width, file_.height));
        }
        const auto lights = tracker_.update(detector_.detect(rgb_view(frame)));
        cuts_ += tracker_.last_was_cut() ? 1 : 0;
        ++frames_;
        file_.append(frame.number, lights);
    }

    void finish() {
        if (frames_ == 0 && !settings_.allow_empty) {
            throw std::runtime_error(fmt::format("{}: no frames read (an empty stream: did the program before lensfx fail?); "
                                                 "--allow-empty accepts it", settings_.input == "-" ? "stdin" : settings_.input));
        }
        const bool to_stdout = settings_.tracks_out == "-";  // as --report -: a full or closed stdout is an error
        if (to_stdout) write_stdout(detect::to_json_text(file_));
        else write_file(settings_.tracks_out, detect::to_json_text(file_));
        if (!settings_.quiet)
            fmt::print(stderr, "lensfx track: {} frame{}, {} track{}, {} cut{} -> {}\n", frames_, frames_ == 1 ? "" : "s", file_.tracks.size(),
                       file_.tracks.size() == 1 ? "" : "s", cuts_, cuts_ == 1 ? "" : "s",
                       to_stdout ? "stdout" : settings_.tracks_out);
    }

private:
    const TrackSettings& settings_;
    detect::Detector detector_;
    detect::Tracker tracker_;
    detect::TrackFile file_;
    int frames_ = 0;
    int cuts_ = 0;
};

void run_track(TrackSettings& s) {
    s.detector.threshold = detect::Threshold::parse(s.threshold);
    s.tracker.fade_in_frames = s.fade_frames;
    s.tracker.fade_out_frames = s.fade_frames;
    refuse_overwrite(s.tracks_out, "--tracks-out", s.input);
    refuse_special_output(s.tracks_out, "--tracks-out");
    ShotTracker shot(s);
    const MemoryBudget memory = memory_budget_option(s.memory_limit);
    if (s.input == "-") {
        if (!s.frames.empty()) throw std::runtime_error("--frames selects files of a pattern; it does not apply to a stream on stdin");
        for (std::int64_t n = 1;; ++n) {
            std::optional<Frame> frame = read_pfm(stdin, true, memory);
            if (!frame) break;
            frame->number = n;
            shot.add(*frame, "stdin");
        }
    } else {
        const FramePattern pattern = parse_pattern(s.input);
        const FrameList numbers = frames_to_read(s.input, s.frames, s.quiet);
        for (std::uint64_t i = 0; i < numbers.size(); ++i) {
            const std::string path = pattern.path(numbers[i]);
            try {
                Frame frame = read_image(path, PfmOrder::automatic, memory);
                frame.number = numbers[i];
                frame.index = i;
                shot.add(frame, path);
            } catch (const std::exception& e) {
                const std::string what = e.what();
                if (what.starts_with(path)) throw;
                throw std::runtime_error(fmt::format("{}: frame {}: {}", path, numbers[i], what));
            }
        }
    }
    shot.finish();
}

}  // namespace

void register_track_command(CLI::App& app) {
    auto s = std::make_shared<TrackSettings>();
    auto* cmd = app.add_subcommand("track", "Detect and track the light sources of a shot and write them as a track file");
    cmd->option_defaults()->always_capture_default();
    cmd->add_option("-i,--input", s->input, "Input: a file, a pattern (shot.####.exr) or - for a PFM stream on stdin")->required();
    cmd->add_option("--frames", s->frames, "Frames of a pattern input (1-100, 1-100x2, 3,7,10-20); default: all on disk");
    cmd->add_option("--tracks-out", s->tracks_out, "The track file to write (JSON; - : stdout)")->required();
    cmd->add_option("--threshold", s->threshold, "Birth threshold: a luminance (20) or stops above the frame's median (+6ev)")->check(threshold_check());
    cmd->add_option("--max-lights", s->detector.max_lights, "Brightest sources kept per frame")->check(CLI::Range(0, 4096));
    cmd->add_option("--hysteresis", s->detector.hysteresis_ev, "Stops below the threshold where a tracked light lives on")
        ->check(CLI::NonNegativeNumber);
    cmd->add_option("--merge-radius", s->detector.merge_radius, "Pixels: components closer than this are one source")
        ->check(CLI::NonNegativeNumber);
    cmd->add_option("--visibility", s->detector.visibility, "Skip sources with less than this fraction of the frame's luminous flux")
        ->check(CLI::Range(0.0, 1.0));
    cmd->add_option("--clip-level", s->detector.clip_level, "Channel value at which the camera clipped (0: flat-top test only)")
        ->check(CLI::NonNegativeNumber);
    cmd->add_option("--gate", s->tracker.gate_px, "Pixels: farthest a light moves between frames beyond its prediction")
        ->check(CLI::PositiveNumber);
    cmd->add_option("--coast", s->tracker.coast_frames, "Frames a light keeps its weight while undetected (occlusion)")
        ->check(CLI::NonNegativeNumber);
    cmd->add_option("--fade", s->fade_frames, "Frames of the weight ramps at births and deaths")->check(CLI::NonNegativeNumber);
    cmd->add_option("--cut-threshold", s->tracker.cut_threshold, "Histogram change (L1, 0-2) between frames that is a cut")
        ->check(CLI::PositiveNumber);
    cmd->add_flag("--allow-empty", s->allow_empty, "An input stream of no frames writes an empty track file (default: an error)");
    cmd->add_option("--memory-limit", s->memory_limit, kMemoryLimitHelp)->check(memory_limit_check());
    cmd->add_flag("-q,--quiet", s->quiet, "No summary line");
    cmd->callback([s] { run_track(*s); });
}

}  // namespace lensfx::filter
