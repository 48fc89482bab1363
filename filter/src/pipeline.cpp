// The frame pipeline (see filter/pipeline.h).
#include <filter/pipeline.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <condition_variable>
#include <mutex>
#include <new>
#include <set>
#include <stdexcept>
#include <system_error>
#include <thread>

#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <unistd.h>

#include <filter/bounded_queue.h>
#include <filter/output_files.h>
#include <filter/sequence.h>
#include <optics/stopwatch.h>

#include "exr_io.h"
#include "oiio_module.h"

namespace lensfx::filter {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::size_t RunReport::written() const {
    std::size_t n = 0;
    for (const auto& f : frames) n += f.written ? 1 : 0;
    return n;
}

std::size_t RunReport::skipped() const { return frames.size() - written() + skipped_unlisted; }

namespace {

// The bytes held in the pipeline, against the memory limit: the frames between reader and writer and the
// stages' own buffers (Stage::held_bytes). The reader waits before reading another frame while those held
// and the next would exceed the limit. A frame is always let through when no frame is held, so one that
// fits the limit alone never waits forever (the readers and stages refuse larger ones).
class FrameBytes {
public:
    // Bytes held for one frame until it is written or dropped (moving with the frame through the queues),
    // or for the stages' buffers.
    class Hold {
    public:
        Hold() = default;
        Hold(FrameBytes* owner, std::size_t bytes, bool frame) : owner_(owner), bytes_(bytes), frame_(frame) {}
        Hold(Hold&& other) noexcept
            : owner_(std::exchange(other.owner_, nullptr)), bytes_(other.bytes_), frame_(other.frame_) {}
        Hold& operator=(Hold&& other) noexcept {
            if (this != &other) {
                release();
                owner_ = std::exchange(other.owner_, nullptr);
                bytes_ = other.bytes_;
                frame_ = other.frame_;
            }
            return *this;
        }
        Hold(const Hold&) = delete;
        Hold& operator=(const Hold&) = delete;
        ~Hold() { release(); }
        // What is held turned out to be `bytes` (a frame once it is read or stored): held without waiting.
        void resize(std::size_t bytes) {
            if (owner_) owner_->change(bytes_, bytes, false);
            bytes_ = bytes;
        }
        std::size_t bytes() const { return bytes_; }

    private:
        void release() {
            if (owner_) owner_->change(bytes_, 0, frame_);
            owner_ = nullptr;
        }
        FrameBytes* owner_ = nullptr;
        std::size_t bytes_ = 0;
        bool frame_ = false;
    };

    explicit FrameBytes(std::size_t limit) : limit_(limit) {}

    // Waits until a frame of `bytes` fits under the limit (or no frame is held); nothing when cancelled.
    std::optional<Hold> acquire(std::size_t bytes) {
        std::unique_lock lock(mutex_);
        freed_.wait(lock, [&] { return cancelled_ || limit_ == 0 || frames_ == 0 || held_ + bytes <= limit_; });
        if (cancelled_) return std::nullopt;
        ++frames_;
        add(bytes);
        return Hold(this, bytes, true);
    }
    // The stages' buffers: held at once, resized as they grow.
    Hold stages() { return Hold(this, 0, false); }
    void cancel() {
        std::lock_guard lock(mutex_);
        cancelled_ = true;
        freed_.notify_all();
    }
    std::size_t peak() {
        std::lock_guard lock(mutex_);
        return peak_;
    }

private:
    void change(std::size_t from, std::size_t to, bool frame_released) {
        std::lock_guard lock(mutex_);
        held_ -= from;
        add(to);
        if (frame_released) --frames_;
        if (to < from || frame_released) freed_.notify_all();
    }
    void add(std::size_t bytes) {
        held_ += bytes;
        peak_ = std::max(peak_, held_);
    }
    std::size_t limit_;
    std::size_t held_ = 0, peak_ = 0;
    std::size_t frames_ = 0;  // frames held (the stages' buffers are not one)
    bool cancelled_ = false;
    std::mutex mutex_;
    std::condition_variable freed_;
};

// A frame on its way through the queues; `frame` is empty when the input was bad (record.error says why).
struct Item {
    std::optional<Frame> frame;
    FrameRecord record;
    bool fatal = false;  // a bad stream cannot be resynchronised: never skipped
    FrameBytes::Hold held;  // its bytes against the memory limit, released when it is written or dropped
};

// What a frame holds while it is in the pipeline: its pixels, and R, G, B as float while the stages run.
std::size_t frame_bytes(const Frame& frame, bool wants_rgb) {
    return frame.spec.image_bytes() + (wants_rgb && frame.has_rgb() ? frame.pixel_count() * 3 * sizeof(float) : 0);
}

// An exception's text for the one-line report; std::bad_alloc (an allocation the budget did not foresee)
// in words, with what to do about it.
std::string error_text(const std::exception& e) {
    if (dynamic_cast<const std::bad_alloc*>(&e))
        return "out of memory (std::bad_alloc); give a lower --memory-limit so that lensfx refuses or waits earlier";
    return e.what();
}

// One line: library messages (OpenImageIO's) may hold several.
std::string one_line(std::string text) {
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    std::string out;
    for (char c : text) {
        if (c == '\n' || c == '\r') {
            if (!out.empty() && out.back() != ' ') out += "; ";
        } else {
            out += c;
        }
    }
    return out;
}

// The first failure of a run; later ones (consequences of cancelling) are dropped.
class Failure {
public:
    void set(std::string message) {
        std::lock_guard lock(mutex_);
        if (message_.empty()) message_ = one_line(std::move(message));
    }
    std::string get() {
        std::lock_guard lock(mutex_);
        return message_;
    }

private:
    std::mutex mutex_;
    std::string message_;
};

using FileId = std::pair<dev_t, ino_t>;

std::optional<FileId> file_id(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return std::nullopt;
    return FileId{st.st_dev, st.st_ino};
}

// What to read and where to write, resolved before any thread starts. The frames are a lazy list: a
// range of any length is read one frame at a time.
struct Plan {
    bool stream_in = false, stream_out = false;
    FramePattern in_pattern, out_pattern;
    FrameList numbers;                  // file input: the frames to read
    std::set<FileId> input_ids;         // the input files on disk: never written to
    PfmOrder in_order = PfmOrder::bottom_first, out_order = PfmOrder::bottom_first;
    StreamFormat in_format = StreamFormat::pfm, out_format = StreamFormat::exr;  // of streams on stdin, stdout

    std::string input_path(std::int64_t number) const { return in_pattern.path(number); }
    std::string output_path(std::int64_t number) const { return stream_out ? "-" : out_pattern.path(number); }
};

// --pfm-order auto: top row first on a pipe (ffmpeg's), bottom first in a file (the format's), stdin or stdout
// redirected to one included.
PfmOrder resolve(PfmOrder order, bool stream, int fd) {
    if (order != PfmOrder::automatic) return order;
    struct stat st {};
    const bool file = !stream || (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode));  // `< shot.pfm` is a file too
    return file ? PfmOrder::bottom_first : PfmOrder::top_first;
}

// The ids of the files on disk that a pattern names (a directory's worth at most).
std::set<FileId> files_of(const FramePattern& pattern) {
    std::set<FileId> ids;
    if (!pattern.is_sequence) {
        if (auto id = file_id(pattern.prefix)) ids.insert(*id);
        return ids;
    }
    for (std::int64_t n : scan_frames(pattern))
        if (auto id = file_id(pattern.path(n))) ids.insert(*id);
    return ids;
}

// Refuses, before the first frame is read, an output of the pattern already on disk that is a directory, device
// or named pipe (a stream's frame numbers are not known before it ends: every such output of the pattern).
void refuse_special_outputs(const FramePattern& out) {
    if (!out.is_sequence) return refuse_special_output(out.path(0), "-o");
    for (std::int64_t n : scan_frames(out)) refuse_special_output(out.path(n), "-o");
}

// Refuses, before anything is written, an output that is one of the inputs: the output files already on
// disk (a directory's worth) are compared with the input files, so a list of any length costs the same.
void refuse_overwriting_inputs(const Plan& plan) {
    const std::int64_t first = plan.numbers[0];
    if (plan.output_path(first) == plan.input_path(first)) {
        throw std::runtime_error(fmt::format("{}: frame {}: refusing to overwrite an input file", plan.output_path(first), first));
    }
    const std::vector<std::int64_t> existing =
        plan.out_pattern.is_sequence ? scan_frames(plan.out_pattern) : std::vector<std::int64_t>{first};
    for (std::int64_t n : existing) {
        if (!plan.numbers.contains(n)) continue;
        refuse_special_output(plan.output_path(n), "-o");
        const auto id = file_id(plan.output_path(n));
        if (id && plan.input_ids.count(*id)) {
            throw std::runtime_error(fmt::format("{}: frame {}: refusing to overwrite an input file", plan.output_path(n), n));
        }
    }
}

// Stream options apply to "-" only; raw streams need their pixel format (and, read, their size).
void check_stream_options(const PipelineOptions& o, Plan& plan) {
    const bool raw_in = o.raw_width > 0 || o.raw_height > 0;
    if (raw_in && !plan.stream_in) throw std::runtime_error("--size gives the frame size of raw input on stdin; the input is not -");
    if (raw_in && !o.pix_fmt) throw std::runtime_error("raw input (--size) needs --pix-fmt gbrpf32le or gbrapf32le");
    if (o.stream_format && !plan.stream_out) throw std::runtime_error("--stream-format says what - carries as output; the output is not -");
    if (o.pix_fmt && !raw_in && !plan.stream_out) throw std::runtime_error("--pix-fmt applies to raw streams on - (input with --size, output)");
    if (o.stream_format == StreamFormat::raw && !o.pix_fmt) throw std::runtime_error("--stream-format raw needs --pix-fmt gbrpf32le or gbrapf32le");
    if (o.stream_format && *o.stream_format != StreamFormat::raw && o.pix_fmt && !raw_in)
        throw std::runtime_error(fmt::format("--pix-fmt applies to raw streams, not --stream-format {}", to_string(*o.stream_format)));
    if (raw_in) plan.in_format = StreamFormat::raw;
}

// The format of the stream on stdout: --stream-format, else raw with --pix-fmt, else the input stream's.
StreamFormat output_stream_format(const PipelineOptions& o, const Plan& plan) {
    if (o.stream_format) return *o.stream_format;
    if (o.pix_fmt) return StreamFormat::raw;
    return plan.stream_in ? plan.in_format : StreamFormat::exr;
}

// Every frame a frame list names (--frames, or frames in the pattern) exists, or the run is refused before it
// writes anything: a missing frame found by the reader stopped the run after the frames before it had replaced
// their outputs. Stops at the first missing one, so a range of billions costs what its frames on disk do. A list
// scanned from the disk (no list given) holds only frames it found there, and is not looked at again.
void require_listed_frames(const Plan& plan, const PipelineOptions& o) {
    if (!plan.in_pattern.is_sequence || (o.frames.empty() && plan.in_pattern.frames.empty())) return;
    for (std::uint64_t i = 0; i < plan.numbers.size(); ++i) {
        const std::string path = plan.in_pattern.path(plan.numbers[i]);
        std::error_code ec;
        if (!fs::exists(path, ec)) throw std::runtime_error(fmt::format("{}: frame {}: file does not exist", path, plan.numbers[i]));
    }
}

// A frame stream on a terminal is refused: binary frames would scroll over it, and one read from it would wait for
// typing.
void refuse_terminal_streams(const Plan& plan) {
    if (plan.stream_out && ::isatty(STDOUT_FILENO))
        throw std::runtime_error("-o -: stdout is a terminal; pipe the frames on (| ffmpeg ...) or redirect them (> file)");
    if (plan.stream_in && ::isatty(STDIN_FILENO))
        throw std::runtime_error("-i -: stdin is a terminal; pipe frames in (ffmpeg ... |) or redirect a file (< file)");
}

Plan make_plan(const PipelineOptions& o) {
    Plan plan;
    plan.stream_in = o.input == "-";
    plan.stream_out = o.output == "-";
    plan.in_order = resolve(o.pfm_order, plan.stream_in, STDIN_FILENO);
    plan.out_order = resolve(o.pfm_order, plan.stream_out, STDOUT_FILENO);
    check_stream_options(o, plan);
    refuse_terminal_streams(plan);
    if (!plan.stream_out) {
        plan.out_pattern = parse_pattern(o.output);
        require_output_directory(o.output);
        refuse_special_outputs(plan.out_pattern);  // before its format: -o /dev/full is a device, whatever its name
        require_output_format(o.output);
    }
    if (plan.stream_in) {
        if (!o.frames.empty()) throw std::runtime_error("--frames selects files of a pattern; it does not apply to a stream on stdin");
        return plan;
    }
    plan.in_pattern = parse_pattern(o.input);
    plan.numbers = frames_to_read(o.input, o.frames, true);
    if (!o.skip_bad_frames) require_listed_frames(plan, o);
    if (!plan.stream_out && !plan.out_pattern.is_sequence && plan.numbers.size() > 1) {
        throw std::runtime_error(fmt::format("{}: the output has no frame-number token but the input has {} frames", o.output, plan.numbers.size()));
    }
    plan.input_ids = files_of(plan.in_pattern);
    if (!plan.stream_out) refuse_overwriting_inputs(plan);
    if (!o.quiet) warn_of_gaps(o.input, o.frames, plan.numbers);  // after the checks: a refused run says one line
    return plan;
}

bool same_display_window(const ImageSpec& a, const ImageSpec& b) {
    return a.full_x == b.full_x && a.full_y == b.full_y && a.full_width == b.full_width && a.full_height == b.full_height;
}

std::string format_duration(double seconds) {
    const auto s = static_cast<long>(seconds + 0.5);
    return fmt::format("{}:{:02}", s / 60, s % 60);
}

class ProgressLine {
public:
    ProgressLine(bool enabled, std::size_t total) : enabled_(enabled), total_(total), start_(Clock::now()) {}
    void update(std::size_t done) {
        if (!enabled_) return;
        const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
        const double fps = elapsed > 0 ? static_cast<double>(done) / elapsed : 0.0;
        if (total_ > 0) {
            const double eta = fps > 0 ? static_cast<double>(total_ - done) / fps : 0.0;
            fmt::print(stderr, "\rlensfx: frame {}/{}  {:.1f} fps  ETA {}  ", done, total_, fps, format_duration(eta));
        } else {
            fmt::print(stderr, "\rlensfx: frame {}  {:.1f} fps  ", done, fps);
        }
        std::fflush(stderr);
        printed_ = true;
    }
    void finish() {
        if (printed_) fmt::print(stderr, "\n");
    }

private:
    bool enabled_;
    std::size_t total_;
    Clock::time_point start_;
    bool printed_ = false;
};

// Where the frames come from: a stream on stdin (frame i is the stream's (i+1)-th, read until it ends) or
// the files of the input pattern (the plan's frame numbers).
struct FrameSource {
    const PipelineOptions& o;
    const Plan& plan;

    bool has(std::uint64_t i) const { return plan.stream_in || i < plan.numbers.size(); }
    FrameRecord record(std::uint64_t i) const {
        FrameRecord r;
        r.index = i;
        r.number = plan.stream_in ? static_cast<std::int64_t>(i) + 1 : plan.numbers[i];
        r.input = plan.stream_in ? "-" : plan.input_path(r.number);
        r.output = plan.output_path(r.number);
        return r;
    }
    // The frame a record names; nothing at the end of a stream. Throws on a bad frame.
    std::optional<Frame> read(const FrameRecord& record) const {
        if (!plan.stream_in) return read_image(record.input, plan.in_order, o.memory);
        std::optional<Frame> frame = plan.in_format == StreamFormat::raw ? read_raw(stdin, *o.pix_fmt, o.raw_width, o.raw_height, o.memory)
                                     : plan.in_format == StreamFormat::exr ? read_exr_stream(stdin)
                                                                           : read_pfm(stdin, plan.in_order == PfmOrder::top_first, o.memory);
        if (frame) frame->source.assign(1, '-');  // (not = "-": GCC 12 warns of a false -Wrestrict there)
        return frame;
    }
};

// The stages' buffers for frames of `spec` counted in `held`, as soon as a frame of that size is read (before
// the next is): the most any frame so far needs, since what a stage keeps for the next frame (or a driver
// keeps for it) does not shrink.
void hold_stage_buffers(FrameBytes::Hold& held, const std::vector<Stage*>& stages, const ImageSpec& spec) {
    std::size_t bytes = 0;
    for (const Stage* s : stages) bytes += s->held_bytes(spec);
    if (bytes > held.bytes()) held.resize(bytes);
}

// The reader's wait for memory, expecting the size of the frame before; then what the frame holds, and
// the stages' buffers for frames of its size.
class ReadBudget {
public:
    ReadBudget(FrameBytes& held, const std::vector<Stage*>& stages, bool wants_rgb)
        : held_(held), stages_(stages), wants_rgb_(wants_rgb), stage_buffers_(held.stages()) {}
    bool hold(Item& item) {
        std::optional<FrameBytes::Hold> hold = held_.acquire(expected_);
        if (hold) item.held = std::move(*hold);
        return hold.has_value();
    }
    void account(Item& item) {
        if (!item.frame) return;
        expected_ = frame_bytes(*item.frame, wants_rgb_);
        item.held.resize(expected_);
        hold_stage_buffers(stage_buffers_, stages_, item.frame->spec);
    }

private:
    FrameBytes& held_;
    const std::vector<Stage*>& stages_;
    bool wants_rgb_;
    std::size_t expected_ = 0;
    FrameBytes::Hold stage_buffers_;
};

// The reader thread: every frame of the source into the queue, a bad one as an item without a frame (the
// last, in a stream: it cannot be resynchronised).
void read_frames(const FrameSource& source, ReadBudget& budget, BoundedQueue<Item>& queue) {
    for (std::uint64_t i = 0; source.has(i); ++i) {
        Item item;
        item.record = source.record(i);
        if (!budget.hold(item)) break;
        const auto t0 = Clock::now();
        try {
            item.frame = source.read(item.record);
            if (!item.frame) break;  // the stream ended
        } catch (const std::exception& e) {
            item.frame.reset();
            item.record.error = one_line(error_text(e));
            item.fatal = source.plan.stream_in;
        }
        budget.account(item);
        item.record.read_ms = ms_since(t0);
        if (item.frame) {
            item.frame->index = i;
            item.frame->number = item.record.number;
        }
        const bool stop = item.fatal;
        if (!queue.push(std::move(item)) || stop) break;
    }
    queue.close();
}

// One frame to stdout (the plan's stream format) or to its file; throws on failure.
// `staged`: where the frame goes instead of rec.output (null: rec.output itself).
void write_frame(const PipelineOptions& o, const Plan& plan, const Frame& frame, const FrameRecord& rec, std::size_t done,
                 TempFile* staged = nullptr) {
    if (plan.stream_out) {
        if (plan.out_format == StreamFormat::raw) {
            write_raw(stdout, frame, *o.pix_fmt, o.memory);
        } else if (plan.out_format == StreamFormat::exr) {
            write_exr_stream(stdout, frame, o.write);
        } else {
            write_pfm(stdout, frame, plan.out_order == PfmOrder::top_first, o.memory);
        }
        if (std::fflush(stdout) != 0) throw std::runtime_error(fmt::format("write failed: {}", write_failure(errno)));
        return;
    }
    if (!plan.out_pattern.is_sequence && done > 0) {
        throw std::runtime_error("the output has no frame-number token but the input has more than one frame");
    }
    if (const auto id = file_id(rec.output); id && plan.input_ids.count(*id)) {
        throw std::runtime_error("refusing to overwrite an input file");
    }
    WriteOptions w = o.write;
    w.pfm_order = plan.out_order;
    w.memory = o.memory;
    if (staged) write_image(frame, *staged, w);
    else write_image(frame, rec.output, w);
}

// A skipped frame reported: its line (the first RunReport::kListedSkips, then one saying the rest are counted) and
// its record, or past those only its count.
void report_skipped(const PipelineOptions& o, bool show_progress, FrameRecord& rec, std::size_t& listed_skips, RunReport& report) {
    const bool listed = listed_skips++ < RunReport::kListedSkips;
    if (!o.quiet && (listed || report.skipped_unlisted == 0))
        fmt::print(stderr, "{}lensfx: skipped {}: frame {}: {}{}\n", show_progress ? "\n" : "", rec.input, rec.number, rec.error,
                   listed ? "" : fmt::format(" (and any later skipped frames: counted, not listed past the first {})", RunReport::kListedSkips));
    if (listed)
        report.frames.push_back(std::move(rec));
    else
        ++report.skipped_unlisted;
}

// The writer thread: each processed frame written in order, a skipped one reported; the first failure
// to write stops the run (`fail`). A stream into one file (no frame-number token) writes its frame beside the
// file and renames it into place once the stream has ended: a second frame, or any other failure, leaves the
// file as it was.
void write_frames(const PipelineOptions& o, const Plan& plan, bool show_progress, BoundedQueue<Item>& queue, RunReport& report,
                  const std::function<void(std::string)>& fail) {
    ProgressLine progress(show_progress, plan.stream_in ? 0 : plan.numbers.size());
    std::size_t done = 0, listed_skips = 0;
    const bool one_file_from_stream = plan.stream_in && !plan.stream_out && !plan.out_pattern.is_sequence;
    std::unique_ptr<TempFile> staged;  // that file's frame, until the stream ends
    while (auto item = queue.pop()) {
        FrameRecord& rec = item->record;
        if (!item->frame) {
            report_skipped(o, show_progress, rec, listed_skips, report);
            continue;
        }
        const auto t0 = Clock::now();
        try {
            if (one_file_from_stream && done == 0) staged = std::make_unique<TempFile>(rec.output);
            write_frame(o, plan, *item->frame, rec, done, staged.get());
        } catch (const std::exception& e) {
            fail(fmt::format("{}: frame {}: {}", rec.output == "-" ? "stdout" : rec.output, rec.number, error_text(e)));
            staged.reset();
            break;
        }
        rec.write_ms = ms_since(t0);
        rec.written = true;
        report.frames.push_back(std::move(rec));
        progress.update(++done);
    }
    try {
        if (staged && !queue.cancelled()) staged->commit();
    } catch (const std::exception& e) {
        fail(fmt::format("{}: {}", o.output, error_text(e)));
    }
    progress.finish();
}

// What working on a frame's R, G, B as float holds before any effect runs: the frame as read and its float copy;
// checked before the copy is made, so a frame too big for --memory-limit is refused before it grows (an 8K half
// frame under 300M reached 710 MB before the flare's own check refused it, after the copy and the detection).
// The effects check their own buffers (the flare's over the display window) when they make them.
void check_working_bytes(const Frame& frame, const MemoryBudget& memory) {
    memory.check(static_cast<double>(frame_bytes(frame, true)),
                 fmt::format("the {}x{} frame as float R, G, B", frame.spec.width, frame.spec.height));
}

// Every stage on one frame, with their times and figures in its record; R, G, B as float meanwhile when a
// stage wants them (refused first when they would not fit `memory`). Throws when the frame's display window
// differs from the first frame's.
void process_frame(Frame& frame, const std::vector<Stage*>& stages, bool wants_rgb, const MemoryBudget& memory,
                   std::optional<ImageSpec>& first, FrameRecord& rec) {
    if (!first) {
        first = frame.spec;
    } else if (!same_display_window(*first, frame.spec)) {
        throw std::runtime_error(fmt::format("frame size {}x{} differs from the first frame's {}x{}",
                                             frame.spec.full_width, frame.spec.full_height,
                                             first->full_width, first->full_height));
    }
    const bool load = wants_rgb && frame.has_rgb();
    if (load) {
        check_working_bytes(frame, memory);
        load_rgb(frame);
        release_rgb_pixels(frame);  // an RGB-only frame is held once, as float, until store_rgb
    }
    for (Stage* stage : stages) {
        const auto ts = Clock::now();
        stage->process(frame);
        rec.stage_ms.emplace_back(std::string(stage->name()), ms_since(ts));
        for (const auto& [part, ms] : stage->part_times())
            rec.stage_ms.emplace_back(fmt::format("{}.{}", stage->name(), part), ms);
        for (const auto& [figure, value] : stage->frame_figures())
            rec.figures.emplace_back(fmt::format("{}.{}", stage->name(), figure), value);
    }
    if (load) store_rgb_and_drop(frame);
}

// The plan, checked, with the formats of the streams: the input's read from stdin.
Plan prepared_plan(const PipelineOptions& o) {
    Plan plan = make_plan(o);
    refuse_overwrite(o.report_path, "--report", o.input, o.output);
    refuse_special_output(o.report_path, "--report");
    if (!plan.stream_out) remove_stale_temporaries(fs::path(plan.out_pattern.prefix).parent_path().string());
    try {
        if (plan.stream_in && plan.in_format != StreamFormat::raw) plan.in_format = detect_stream_format(stdin);
    } catch (const std::exception& e) {
        throw std::runtime_error(fmt::format("stdin: frame 1: {}", e.what()));
    }
    plan.out_format = output_stream_format(o, plan);
    if (plan.stream_out && plan.out_format != StreamFormat::exr && !o.adds_channels.empty())
        throw std::runtime_error(fmt::format("{} adds channels, which a {} stream cannot carry: give --stream-format exr", o.adds_channels,
                                             to_string(plan.out_format)));
    return plan;
}

bool any_wants_rgb(const std::vector<Stage*>& stages) {
    bool wants_rgb = false;
    for (const Stage* s : stages) wants_rgb = wants_rgb || s->wants_rgb();
    return wants_rgb;
}

// The main thread's part: every frame read through the stages into the write queue, holding then the
// bytes of its stored pixels. A bad frame stops the run (`stop`, with the line saying why) unless
// --skip-bad-frames lets it be skipped.
void process_frames(const PipelineOptions& o, const std::vector<Stage*>& stages, bool wants_rgb, BoundedQueue<Item>& read_queue,
                    BoundedQueue<Item>& write_queue, const std::function<void(std::string)>& stop) {
    std::optional<ImageSpec> first;
    while (auto item = read_queue.pop()) {
        FrameRecord& rec = item->record;
        if (item->frame) {
            const auto t0 = Clock::now();
            try {
                process_frame(*item->frame, stages, wants_rgb, o.memory, first, rec);
                item->held.resize(frame_bytes(*item->frame, false));
            } catch (const std::exception& e) {
                item->frame.reset();
                rec.error = one_line(error_text(e));
            }
            rec.process_ms = ms_since(t0);
        }
        if (!item->frame && (item->fatal || !o.skip_bad_frames)) {
            stop(fmt::format("{}: frame {}: {}", rec.input == "-" ? "stdin" : rec.input, rec.number, rec.error));
            break;
        }
        if (!write_queue.push(std::move(*item))) break;
    }
}

// The bytes a run may hold in flight: the memory limit, and the in-flight limit when smaller (0: none).
std::size_t in_flight_bound(const PipelineOptions& o) {
    if (o.in_flight_limit == 0) return o.memory.limit;
    return o.memory.limit == 0 ? o.in_flight_limit : std::min(o.memory.limit, o.in_flight_limit);
}

// The report's fields known before the first frame; sets the readers' and writers' thread counts.
RunReport started_report(const PipelineOptions& o) {
    RunReport report;
    report.input = o.input;
    report.output = o.output;
    report.options_toml = o.options_toml;
    report.threads = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    set_oiio_threads(report.threads);
    set_exr_threads(report.threads);
    return report;
}

// Whether the progress line is drawn: asked for, or a sequence on a terminal.
bool progress_shown(const PipelineOptions& o, const Plan& plan) {
    const bool sequence = plan.stream_in || plan.numbers.size() > 1;
    return !o.quiet && (o.progress == Progress::on || (o.progress == Progress::automatic && sequence && ::isatty(STDERR_FILENO)));
}

// The run's time and outcome; the report file written when asked for; throws the failure, if there was one.
void finish_report(RunReport& report, const PipelineOptions& o, const Plan& plan, std::string error, Clock::time_point start) {
    report.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
    report.error = std::move(error);
    if (report.error.empty() && plan.stream_in && report.frames.empty() && !o.allow_empty) {
        report.error = "stdin: no frames read (an empty stream: did the program before lensfx fail?); --allow-empty accepts it";
    }
    if (!o.report_path.empty()) write_report(report, o.report_path);
    if (!report.error.empty()) throw std::runtime_error(report.error);
}

// A thread of the run started; a system that will not start one (a thread limit, no memory for its stack)
// says so in a line naming it.
template <class Body>
std::thread start_thread(const char* name, Body body) {
    try {
        return std::thread(std::move(body));
    } catch (const std::system_error& e) {
        throw std::runtime_error(fmt::format("cannot start the {} thread: {} (a limit on threads or processes, or on memory)", name, e.what()));
    }
}

}  // namespace

RunReport run_pipeline(const PipelineOptions& o, const std::vector<Stage*>& stages) {
    const auto start = Clock::now();
    RunReport report = started_report(o);
    const Plan plan = prepared_plan(o);
    const bool show_progress = progress_shown(o, plan);
    const bool wants_rgb = any_wants_rgb(stages);

    FrameBytes frame_bytes_held(in_flight_bound(o));  // before the queues: their items release into it
    BoundedQueue<Item> read_queue(o.queue_depth), write_queue(o.queue_depth);
    Failure failure;
    auto fail = [&](std::string message) {
        failure.set(std::move(message));
        frame_bytes_held.cancel();
        read_queue.cancel();
        write_queue.cancel();
    };
    ReadBudget budget(frame_bytes_held, stages, wants_rgb);
    std::thread reader = start_thread("reader", [&] { read_frames(FrameSource{o, plan}, budget, read_queue); });
    std::thread writer;
    try {
        writer = start_thread("writer", [&] { write_frames(o, plan, show_progress, write_queue, report, fail); });
        process_frames(o, stages, wants_rgb, read_queue, write_queue, [&](std::string message) {
            // The frames before this one are complete: let the writer finish them, read nothing more.
            failure.set(std::move(message));
            frame_bytes_held.cancel();
            read_queue.cancel();
        });
    } catch (...) {
        // Nothing more is read or written: the threads stop waiting, and are joined before the error goes on.
        fail("stopped");
        reader.join();
        if (writer.joinable()) writer.join();
        throw;
    }
    write_queue.close();
    reader.join();
    writer.join();
    report.peak_held_bytes = frame_bytes_held.peak();

    finish_report(report, o, plan, failure.get(), start);
    return report;
}

void write_report(const RunReport& report, const std::string& path) {
    nlohmann::ordered_json frames = nlohmann::ordered_json::array();
    for (const auto& f : report.frames) {
        nlohmann::ordered_json stages = nlohmann::ordered_json::object();
        for (const auto& [name, ms] : f.stage_ms) stages[name] = ms;
        nlohmann::ordered_json j = {{"index", f.index},       {"number", f.number},         {"input", f.input},
                            {"output", f.output},     {"status", f.written ? "written" : "skipped"},
                            {"read_ms", f.read_ms},   {"process_ms", f.process_ms}, {"write_ms", f.write_ms},
                            {"stages_ms", stages}};
        if (!f.figures.empty()) {
            nlohmann::ordered_json figures = nlohmann::ordered_json::object();
            for (const auto& [name, value] : f.figures) figures[name] = value;
            j["figures"] = std::move(figures);
        }
        if (!f.error.empty()) j["error"] = f.error;
        frames.push_back(std::move(j));
    }
    const double fps = report.wall_seconds > 0 ? static_cast<double>(report.written()) / report.wall_seconds : 0.0;
    nlohmann::ordered_json j = {{"input", report.input},
                        {"output", report.output},
                        {"threads", report.threads},
                        {"frames_written", report.written()},
                        {"frames_skipped", report.skipped()},
                        {"frames_skipped_unlisted", report.skipped_unlisted},
                        {"wall_seconds", report.wall_seconds},
                        {"frames_per_second", fps},
                        {"peak_held_bytes", report.peak_held_bytes},
                        {"frames", std::move(frames)}};
    if (!report.error.empty()) j["error"] = report.error;
    if (!report.options_toml.empty()) j["options"] = report.options_toml;
    if (path == "-") {
        const std::string text = j.dump(2) + "\n";
        if (std::fwrite(text.data(), 1, text.size(), stdout) != text.size() || std::fflush(stdout) != 0)
            throw std::runtime_error(fmt::format("cannot write the report to stdout: {}", write_failure(errno)));
        return;
    }
    write_file(path, j.dump(2) + "\n");
}

}  // namespace lensfx::filter
