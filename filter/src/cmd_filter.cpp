// `lensfx -i IN -o OUT [options]`: the frame filter's command line, turned into PipelineOptions.
// Effect stages (detection, flare, colour) are built in make_stages() from their own options.
#include "commands.h"

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/core.h>

#include <filter/colour.h>
#include <filter/dof_stage.h>
#include <filter/flare_stage.h>
#include <filter/pipeline.h>

namespace lensfx::filter {

namespace {

struct FilterArgs {
    PipelineOptions pipeline;
    std::string pfm_order = "auto";
    std::string pix_fmt;
    std::string size;
    std::string memory_limit;  // empty: default_memory_budget()
    bool progress = false;
    colour::ColourArgs colour;
    FlareSettings flare;
    DofSettings dof;
    bool gpu_given = false;  // --gpu on the command line: the GPU path is active from the first frame
};

void parse_size(const std::string& text, int& width, int& height) {
    const auto x = text.find('x');
    try {
        std::size_t used_w = 0, used_h = 0;
        if (x == std::string::npos) throw std::invalid_argument(text);
        width = std::stoi(text.substr(0, x), &used_w);
        height = std::stoi(text.substr(x + 1), &used_h);
        if (used_w != x || used_h != text.size() - x - 1 || width < 1 || height < 1) throw std::invalid_argument(text);
    } catch (const std::exception&) {
        throw std::runtime_error(fmt::format("--size must be WIDTHxHEIGHT, not \"{}\"", text));
    }
}

// The effects to run on each frame, in order: colour-in (to the working space) first, colour-out (to the
// display or back to the input's space) last; the other effects go between them.
// One GL context serves the flare renderer and the GPU colour transform; the flare is rendered in the
// working space's primaries, which the colour session knows from the first frame.
std::vector<std::unique_ptr<Stage>> make_stages(const FilterArgs& args, const FlareStage*& flare) {
    std::vector<std::unique_ptr<Stage>> stages;
    auto colour_session = std::make_shared<colour::ColourSession>(args.colour, args.pipeline.output);
    auto gpu = std::make_shared<GpuSession>();
    gpu->platform = args.flare.gpu;
    gpu->requested = args.gpu_given;
    stages.push_back(std::make_unique<colour::ColourInputStage>(colour_session));
    bool flare_runs = false;
    DofStages dof = make_dof_stages(args.dof, args.flare, gpu, flare_runs);
    if (dof.blur) stages.push_back(std::move(dof.blur));
    if (flare_runs) {
        auto primaries = [colour_session]() -> std::optional<std::array<double, 9>> {
            if (const colour::ColourPipeline* p = colour_session->pipeline()) return p->working().rgb_to_xyz;
            return std::nullopt;
        };
        auto stage = std::make_unique<FlareStage>(args.flare, gpu, primaries);
        flare = stage.get();
        stages.push_back(std::move(stage));
    }
    if (dof.compose) stages.push_back(std::move(dof.compose));
    stages.push_back(std::make_unique<colour::ColourOutputStage>(colour_session, gpu, args.colour.device));
    return stages;
}

void run_filter(FilterArgs& args) {
    PipelineOptions& o = args.pipeline;
    o.pfm_order = parse_pfm_order(args.pfm_order);
    o.write.pfm_order = o.pfm_order;
    if (!args.pix_fmt.empty()) o.pix_fmt = parse_raw_pix_fmt(args.pix_fmt);
    if (!args.size.empty()) parse_size(args.size, o.raw_width, o.raw_height);
    o.memory = memory_budget_option(args.memory_limit);
    args.flare.memory = o.memory;
    if (args.progress) o.progress = Progress::on;
    o.write.display_bits = args.colour.bits;
    o.write.dither = args.colour.dither_mode();

    const FlareStage* flare = nullptr;
    auto owned = make_stages(args, flare);
    std::vector<Stage*> stages;
    for (auto& s : owned) stages.push_back(s.get());
    const RunReport report = run_pipeline(o, stages);
    if (flare && !flare->summary().lights_per_frame.empty() && !o.quiet) fmt::print(stderr, "{}\n", describe(flare->summary()));
    if (report.skipped() > 0 && !o.quiet) {
        std::string numbers;  // the first few: a long run's list would fill the terminal
        std::size_t listed = 0;
        for (const auto& f : report.frames) {
            if (f.written) continue;
            if (++listed > 20) {
                numbers += ", ...";
                break;
            }
            numbers += fmt::format("{}{}", numbers.empty() ? "" : ", ", f.number);
        }
        fmt::print(stderr, "lensfx: {} frames written, {} skipped (frames {})\n", report.written(), report.skipped(), numbers);
    }
}

}  // namespace

void register_filter(CLI::App& app) {
    auto args = std::make_shared<FilterArgs>();
    PipelineOptions& o = args->pipeline;
    app.footer(
        "IN/OUT: a file; a sequence pattern (# = 4-digit frame, #### = 4, @ = unpadded, %04d); or - for a\n"
        "stream of PFM images on stdin/stdout (raw planar float with --pix-fmt). Only R, G, B are changed:\n"
        "every other channel, the windows and the metadata pass through.");
    app.add_option("-i,--input", o.input, "Input file, pattern or - (stdin)");
    app.add_option("-o,--output", o.output, "Output file, pattern or - (stdout)");
    app.add_option("--frames", o.frames, "Frames of a pattern input: 1-100, 1-100x2, 3,7,10-20 (default: those on disk)");
    app.add_option("--threads", o.threads, "Worker threads for decoding and encoding (0: one per core)")->check(CLI::Range(0, 1024));
    app.add_option("--queue-depth", o.queue_depth, "Frames held between reader, effects and writer")->check(CLI::PositiveNumber);
    app.add_option("--compression", o.write.compression, "EXR compression: piz, zip, zips, dwaa[:level], none... (default: the input's, else piz)");
    app.add_option("--pfm-order", args->pfm_order, "PFM row order: top (ffmpeg 5.1), bottom (the PFM spec), auto (top on pipes, bottom in files)")
        ->check(CLI::IsMember({"auto", "top", "bottom"}));
    app.add_option("--pix-fmt", args->pix_fmt, "Raw planar float on - instead of PFM: gbrpf32le or gbrapf32le")
        ->check(CLI::IsMember({"gbrpf32le", "gbrapf32le"}));
    app.add_option("--size", args->size, "Frame size of raw input, WIDTHxHEIGHT");
    app.add_flag("--skip-bad-frames", o.skip_bad_frames, "Leave out unreadable or mismatched input frames and report them");
    app.add_flag("--allow-empty", o.allow_empty, "An input stream of no frames is a success (default: an error)");
    app.add_flag("-q,--quiet", o.quiet, "No progress line, no warnings");
    app.add_flag("--progress", args->progress, "Show progress even when stderr is not a terminal");
    app.add_option("--report", o.report_path, "Write per-frame stage times as JSON");
    app.add_option("--memory-limit", args->memory_limit, kMemoryLimitHelp);
    colour::add_colour_options(app, args->colour);
    add_flare_options(app, args->flare);
    add_dof_options(app, args->dof);

    app.callback([&app, args] {
        if (!app.get_subcommands().empty()) return;
        if (args->pipeline.input.empty() && args->pipeline.output.empty()) throw CLI::CallForHelp();
        if (args->pipeline.input.empty() || args->pipeline.output.empty()) {
            throw std::runtime_error("the filter needs both -i IN and -o OUT");
        }
        args->gpu_given = app.get_option("--gpu")->count() > 0;
        run_filter(*args);
    });
}

}  // namespace lensfx::filter
