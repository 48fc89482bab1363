// The frame pipeline (see filter/pipeline.h).
#include <filter/pipeline.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>
#include <unistd.h>

#include <filter/bounded_queue.h>
#include <filter/sequence.h>

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

std::size_t RunReport::skipped() const { return frames.size() - written(); }

namespace {

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// A frame on its way through the queues; `frame` is empty when the input was bad (record.error says why).
struct Item {
    std::optional<Frame> frame;
    FrameRecord record;
    bool fatal = false;  // a bad stream cannot be resynchronised: never skipped
};

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

// What to read and where to write, resolved before any thread starts.
struct Plan {
    bool stream_in = false, stream_out = false;
    FramePattern out_pattern;
    std::vector<std::int64_t> numbers;  // file input: the frames to read
    std::vector<std::string> inputs;    // their paths
    std::set<FileId> input_ids;         // never written to
    PfmOrder in_order = PfmOrder::bottom_first, out_order = PfmOrder::bottom_first;
    StreamFormat in_format = StreamFormat::pfm, out_format = StreamFormat::exr;  // of streams on stdin, stdout

    std::string output_path(std::int64_t number) const { return stream_out ? "-" : out_pattern.path(number); }
};

PfmOrder resolve(PfmOrder order, bool stream) {
    if (order != PfmOrder::automatic) return order;
    return stream ? PfmOrder::top_first : PfmOrder::bottom_first;
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

Plan make_plan(const PipelineOptions& o) {
    Plan plan;
    plan.stream_in = o.input == "-";
    plan.stream_out = o.output == "-";
    plan.in_order = resolve(o.pfm_order, plan.stream_in);
    plan.out_order = resolve(o.pfm_order, plan.stream_out);
    check_stream_options(o, plan);
    if (!plan.stream_out) {
        plan.out_pattern = parse_pattern(o.output);
        fs::path dir = fs::path(plan.out_pattern.prefix).parent_path();
        if (dir.empty()) dir = ".";
        if (!fs::is_directory(dir)) throw std::runtime_error(fmt::format("{}: output directory {} does not exist", o.output, dir.string()));
        if (::access(dir.c_str(), W_OK) != 0) throw std::runtime_error(fmt::format("{}: output directory {} is not writable", o.output, dir.string()));
        if (!is_known_output_format(o.output)) {
            throw std::runtime_error(fmt::format("{}: unknown output format \"{}\"", o.output, fs::path(o.output).extension().string()));
        }
    }
    if (plan.stream_in) {
        if (!o.frames.empty()) throw std::runtime_error("--frames selects files of a pattern; it does not apply to a stream on stdin");
        return plan;
    }
    const FramePattern in = parse_pattern(o.input);
    if (in.is_sequence) {
        if (!o.frames.empty() && !in.frames.empty())
            throw std::runtime_error(fmt::format("{}: the pattern names frames {} and --frames names {}: give one", o.input, in.frames, o.frames));
        const std::string& list = o.frames.empty() ? in.frames : o.frames;
        plan.numbers = list.empty() ? scan_frames(in) : parse_frame_list(list);
        if (plan.numbers.empty()) throw std::runtime_error(fmt::format("{}: no frames match the pattern", o.input));
    } else {
        if (!o.frames.empty()) throw std::runtime_error(fmt::format("{}: --frames needs a pattern (#, @ or %0Nd) in the input", o.input));
        plan.numbers = {1};
    }
    if (!plan.stream_out && !plan.out_pattern.is_sequence && plan.numbers.size() > 1) {
        throw std::runtime_error(fmt::format("{}: the output has no frame-number token but the input has {} frames", o.output, plan.numbers.size()));
    }
    for (auto n : plan.numbers) {
        plan.inputs.push_back(in.path(n));
        if (auto id = file_id(plan.inputs.back())) plan.input_ids.insert(*id);
    }
    if (!plan.stream_out) {
        for (std::size_t i = 0; i < plan.numbers.size(); ++i) {
            const std::string out = plan.output_path(plan.numbers[i]);
            const auto id = file_id(out);
            if (out == plan.inputs[i] || (id && plan.input_ids.count(*id))) {
                throw std::runtime_error(fmt::format("{}: frame {}: refusing to overwrite an input file", out, plan.numbers[i]));
            }
        }
    }
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

}  // namespace

RunReport run_pipeline(const PipelineOptions& o, const std::vector<Stage*>& stages) {
    const auto start = Clock::now();
    RunReport report;
    report.input = o.input;
    report.output = o.output;
    report.options_toml = o.options_toml;
    report.threads = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    set_oiio_threads(report.threads);
    set_exr_threads(report.threads);

    Plan plan = make_plan(o);
    try {
        if (plan.stream_in && plan.in_format != StreamFormat::raw) plan.in_format = detect_stream_format(stdin);
    } catch (const std::exception& e) {
        throw std::runtime_error(fmt::format("stdin: frame 1: {}", e.what()));
    }
    plan.out_format = output_stream_format(o, plan);
    const bool sequence = plan.stream_in || plan.numbers.size() > 1;
    const bool show_progress = !o.quiet && (o.progress == Progress::on ||
                                            (o.progress == Progress::automatic && sequence && ::isatty(STDERR_FILENO)));
    bool wants_rgb = false;
    for (const Stage* s : stages) wants_rgb = wants_rgb || s->wants_rgb();

    BoundedQueue<Item> read_queue(o.queue_depth), write_queue(o.queue_depth);
    Failure failure;
    auto fail = [&](std::string message) {
        failure.set(std::move(message));
        read_queue.cancel();
        write_queue.cancel();
    };

    std::thread reader([&] {
        if (plan.stream_in) {
            for (std::size_t i = 0;; ++i) {
                Item item;
                item.record.index = i;
                item.record.number = static_cast<std::int64_t>(i) + 1;
                item.record.input = "-";
                item.record.output = plan.output_path(item.record.number);
                const auto t0 = Clock::now();
                try {
                    item.frame = plan.in_format == StreamFormat::raw   ? read_raw(stdin, *o.pix_fmt, o.raw_width, o.raw_height)
                                 : plan.in_format == StreamFormat::exr ? read_exr_stream(stdin)
                                                                       : read_pfm(stdin, plan.in_order == PfmOrder::top_first);
                    if (!item.frame) break;
                    item.frame->source = "-";
                } catch (const std::exception& e) {
                    item.frame.reset();
                    item.record.error = one_line(e.what());
                    item.fatal = true;
                }
                item.record.read_ms = ms_since(t0);
                if (item.frame) {
                    item.frame->index = i;
                    item.frame->number = item.record.number;
                }
                const bool stop = item.fatal;
                if (!read_queue.push(std::move(item)) || stop) break;
            }
        } else {
            for (std::size_t i = 0; i < plan.numbers.size(); ++i) {
                Item item;
                item.record.index = i;
                item.record.number = plan.numbers[i];
                item.record.input = plan.inputs[i];
                item.record.output = plan.output_path(plan.numbers[i]);
                const auto t0 = Clock::now();
                try {
                    item.frame = read_image(plan.inputs[i], plan.in_order);
                    item.frame->index = i;
                    item.frame->number = plan.numbers[i];
                } catch (const std::exception& e) {
                    item.frame.reset();
                    item.record.error = one_line(e.what());
                }
                item.record.read_ms = ms_since(t0);
                if (!read_queue.push(std::move(item))) break;
            }
        }
        read_queue.close();
    });

    std::thread writer([&] {
        ProgressLine progress(show_progress, plan.stream_in ? 0 : plan.numbers.size());
        std::size_t done = 0;
        while (auto item = write_queue.pop()) {
            FrameRecord& rec = item->record;
            if (!item->frame) {
                if (!o.quiet) fmt::print(stderr, "{}lensfx: skipped {}: frame {}: {}\n", show_progress ? "\n" : "", rec.input, rec.number, rec.error);
                report.frames.push_back(std::move(rec));
                continue;
            }
            const auto t0 = Clock::now();
            try {
                if (plan.stream_out) {
                    if (plan.out_format == StreamFormat::raw) {
                        write_raw(stdout, *item->frame, *o.pix_fmt);
                    } else if (plan.out_format == StreamFormat::exr) {
                        write_exr_stream(stdout, *item->frame, o.write);
                    } else {
                        write_pfm(stdout, *item->frame, plan.out_order == PfmOrder::top_first);
                    }
                    if (std::fflush(stdout) != 0) throw std::runtime_error("write failed");
                } else {
                    if (!plan.out_pattern.is_sequence && done > 0) {
                        throw std::runtime_error("the output has no frame-number token but the input has more than one frame");
                    }
                    if (const auto id = file_id(rec.output); id && plan.input_ids.count(*id)) {
                        throw std::runtime_error("refusing to overwrite an input file");
                    }
                    WriteOptions w = o.write;
                    w.pfm_order = plan.out_order;
                    write_image(*item->frame, rec.output, w);
                }
            } catch (const std::exception& e) {
                fail(fmt::format("{}: frame {}: {}", rec.output == "-" ? "stdout" : rec.output, rec.number, e.what()));
                break;
            }
            rec.write_ms = ms_since(t0);
            rec.written = true;
            report.frames.push_back(std::move(rec));
            progress.update(++done);
        }
        progress.finish();
    });

    std::optional<ImageSpec> first;
    while (auto item = read_queue.pop()) {
        FrameRecord& rec = item->record;
        if (item->frame) {
            const auto t0 = Clock::now();
            Frame& frame = *item->frame;
            try {
                if (!first) {
                    first = frame.spec;
                } else if (!same_display_window(*first, frame.spec)) {
                    throw std::runtime_error(fmt::format("frame size {}x{} differs from the first frame's {}x{}",
                                                         frame.spec.full_width, frame.spec.full_height,
                                                         first->full_width, first->full_height));
                }
                const bool load = wants_rgb && frame.has_rgb();
                if (load) load_rgb(frame);
                for (Stage* stage : stages) {
                    const auto ts = Clock::now();
                    stage->process(frame);
                    rec.stage_ms.emplace_back(std::string(stage->name()), ms_since(ts));
                    for (const auto& [part, ms] : stage->part_times())
                        rec.stage_ms.emplace_back(fmt::format("{}.{}", stage->name(), part), ms);
                }
                if (load) {
                    store_rgb(frame);
                    frame.rgb = {};
                }
            } catch (const std::exception& e) {
                item->frame.reset();
                rec.error = one_line(e.what());
            }
            rec.process_ms = ms_since(t0);
        }
        if (!item->frame && (item->fatal || !o.skip_bad_frames)) {
            // The frames before this one are complete: let the writer finish them, read nothing more.
            failure.set(fmt::format("{}: frame {}: {}", rec.input == "-" ? "stdin" : rec.input, rec.number, rec.error));
            read_queue.cancel();
            break;
        }
        if (!write_queue.push(std::move(*item))) break;
    }
    write_queue.close();
    reader.join();
    writer.join();

    report.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
    report.error = failure.get();
    if (!o.report_path.empty()) write_report(report, o.report_path);
    if (!report.error.empty()) throw std::runtime_error(report.error);
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
        if (!f.error.empty()) j["error"] = f.error;
        frames.push_back(std::move(j));
    }
    const double fps = report.wall_seconds > 0 ? static_cast<double>(report.written()) / report.wall_seconds : 0.0;
    nlohmann::ordered_json j = {{"input", report.input},
                        {"output", report.output},
                        {"threads", report.threads},
                        {"frames_written", report.written()},
                        {"frames_skipped", report.skipped()},
                        {"wall_seconds", report.wall_seconds},
                        {"frames_per_second", fps},
                        {"frames", std::move(frames)}};
    if (!report.error.empty()) j["error"] = report.error;
    if (!report.options_toml.empty()) j["options"] = report.options_toml;
    if (path == "-") {
        const std::string text = j.dump(2) + "\n";
        if (std::fwrite(text.data(), 1, text.size(), stdout) != text.size() || std::fflush(stdout) != 0)
            throw std::runtime_error("cannot write the report to stdout");
        return;
    }
    std::ofstream out(path);
    out << j.dump(2) << '\n';
    out.close();
    if (!out) throw std::runtime_error(fmt::format("{}: cannot write the report", path));
}

}  // namespace lensfx::filter
