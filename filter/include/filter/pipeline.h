// The frame pipeline of `lensfx -i IN -o OUT`: a reader thread (read-ahead), the effect stages on the
// calling thread, a writer thread (write-behind), joined by bounded queues; frames are written in order.
// Failures name the file and frame; with skip_bad_frames a bad input frame is reported and left out.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <filter/frame.h>
#include <filter/image_io.h>
#include <filter/stream.h>
#include <optics/memory_budget.h>

namespace lensfx::filter {

// The default bound on the bytes a run holds in flight (PipelineOptions::in_flight_limit) when no
// --memory-limit is given: 2 GiB keeps an 8K sequence with a flare near the 2 GB a frame (frames
// of 4K and below never reach it with the default --queue-depth, so they read and write ahead as before).
inline constexpr std::size_t kDefaultInFlightBytes = std::size_t{2} << 30;

enum class Progress { automatic, on, off };  // automatic: on when stderr is a terminal and IN is a sequence or stream

struct PipelineOptions {
    std::string input;   // a file, a pattern (filter/sequence.h) or "-" for stdin
    std::string output;  // the same, "-" for stdout
    std::string frames;  // frame list for a pattern input ("1-100x2"); empty: every frame found on disk
    int threads = 0;     // OpenImageIO / OpenEXR worker threads; 0: one per core
    std::size_t queue_depth = 2;  // frames held between reader, stages and writer (each queue)
    bool skip_bad_frames = false;
    bool allow_empty = false;     // a stream of no frames is a success, not an error
    Progress progress = Progress::automatic;
    bool quiet = false;           // no progress line and no per-frame warnings
    std::string report_path;      // --report FILE.json ("-": stdout); empty: none
    std::string options_toml;     // the run's options as a shot file (--config), copied into the report
    WriteOptions write;           // EXR compression, PFM row order of output files
    PfmOrder pfm_order = PfmOrder::automatic;   // for PFM input and output (streams and files)
    std::optional<RawPixFmt> pix_fmt;           // raw planar float: the input's (with --size) and the output's
    int raw_width = 0, raw_height = 0;          // raw input frame size (--size): stdin is raw when given
    // What "-" as output carries; nothing: raw when pix_fmt is given, else the input stream's format, else EXR.
    std::optional<StreamFormat> stream_format;
    // --memory-limit: every frame is sized against it before it is read.
    MemoryBudget memory;
    // The most bytes held in flight, with `memory`'s limit (the smaller bounds; 0: the memory limit alone):
    // the reader waits before reading another frame while the frames held (pixels, and R, G, B as float
    // until stored) and the stages' buffers (the flare's GL targets), with the next frame, would exceed it.
    // The filter command sets kDefaultInFlightBytes when no --memory-limit is given.
    std::size_t in_flight_limit = 0;
    // The option that adds channels to every frame ("--layer flare"; empty: none). An output stream that cannot carry
    // them (PFM or raw, known only once a stream input's first bytes are read) is refused before any frame is read.
    std::string adds_channels;
};

// What happened to one frame. Times are wall-clock milliseconds spent in each stage on this frame.
struct FrameRecord {
    std::size_t index = 0;
    std::int64_t number = 0;
    std::string input, output;
    bool written = false;
    std::string error;  // why it was skipped, when it was
    double read_ms = 0, process_ms = 0, write_ms = 0;
    std::vector<std::pair<std::string, double>> stage_ms;  // process_ms broken down by effect stage
    std::vector<std::pair<std::string, double>> figures;   // what the stages found (Stage::frame_figures)
};

struct RunReport {
    std::string input, output;
    int threads = 0;
    std::vector<FrameRecord> frames;  // in frame order; skipped frames only the first kListedSkips
    // Skipped frames beyond the first kListedSkips, counted but not kept or printed: --skip-bad-frames over a
    // range of a billion missing files would otherwise hold a record (and print a line) for each.
    static constexpr std::size_t kListedSkips = 1000;
    std::size_t skipped_unlisted = 0;
    double wall_seconds = 0;
    std::string error;  // the failure that stopped the run, if one did
    std::string options_toml;  // the options of the run as a TOML shot file: `--config` repeats it
    // The most bytes the memory budget counted at once: frames in flight (pixels, and R, G, B as float
    // while the stages run) and the stages' buffers (Stage::held_bytes).
    std::size_t peak_held_bytes = 0;
    std::size_t written() const;
    std::size_t skipped() const;
};

// Runs the filter. `stages` run in order on each frame (none: a pass-through). Throws std::runtime_error
// with a one-line message naming the file and frame when the run fails; frames already written stay, a
// frame being written leaves nothing. The report (when asked for) is written in both cases.
RunReport run_pipeline(const PipelineOptions& options, const std::vector<Stage*>& stages = {});

// The report as JSON: the run's totals and one record per frame; to stdout when `path` is "-".
void write_report(const RunReport& report, const std::string& path);

}  // namespace lensfx::filter
