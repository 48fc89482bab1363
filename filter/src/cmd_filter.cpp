// `lensfx -i IN -o OUT [options]`: the frame filter's command line, turned into PipelineOptions.
// Effect stages (detection, flare, colour) are built in make_stages() from their own options.
#include "commands.h"
#include "exr_io.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <fmt/core.h>

#include <filter/colour.h>
#include <filter/dof_stage.h>
#include <filter/flare_stage.h>
#include <filter/option_checks.h>
#include <filter/sequence.h>
#include <filter/output_files.h>
#include <filter/pipeline.h>
#include <filter/views.h>
#include <optics/text_pairs.h>

namespace lensfx::filter {

namespace {

struct FilterArgs {
    PipelineOptions pipeline;
    std::string pfm_order = "auto";
    std::string pix_fmt;
    std::string stream_format;
    std::string size;
    std::string memory_limit;  // empty: default_memory_budget()
    bool progress = false;
    colour::ColourArgs colour;
    FlareSettings flare;
    DofSettings dof;
    bool gpu_given = false;  // --gpu on the command line: the GPU path is active from the first frame
    std::vector<std::string> views;  // --views: the views of a multi-view EXR to flare (empty: all)
};

void parse_size(const std::string& text, int& width, int& height) {
    const auto size = parse_pair_of<int>(text, 'x');
    if (!size || (*size)[0] < 1 || (*size)[1] < 1)
        throw std::runtime_error(fmt::format("--size must be WIDTHxHEIGHT, not \"{}\"", text));
    width = (*size)[0];
    height = (*size)[1];
}

// The effects of one view, in order: colour-in (to the working space) first, colour-out (to the display
// or back to the input's space) last; the other effects go between them. `layer`: the flare's --layer
// for this view; `flare_stage`: where to say which stage is the flare. One GL context serves the flare renderer and the GPU colour transform of every view; the
// flare is rendered in the working space's primaries, which the colour session knows from the first frame.
std::vector<std::unique_ptr<Stage>> make_view_stages(const FilterArgs& args, const std::shared_ptr<colour::ColourSession>& colour_session,
                                                     const std::shared_ptr<GpuSession>& gpu, const std::string& layer,
                                                     const FlareStage** flare_stage = nullptr) {
    std::vector<std::unique_ptr<Stage>> stages;
    stages.push_back(std::make_unique<colour::ColourInputStage>(colour_session));
    bool flare_runs = false;
    auto primaries = [colour_session]() -> std::optional<std::array<double, 9>> {
        if (const colour::ColourPipeline* p = colour_session->pipeline()) return p->working().rgb_to_xyz;
        return std::nullopt;
    };
    DofStages dof = make_dof_stages(args.dof, args.flare, gpu, flare_runs, primaries);
    if (dof.blur) stages.push_back(std::move(dof.blur));
    if (flare_runs) {
        FlareSettings flare = args.flare;
        flare.layer = layer;
        auto stage = std::make_unique<FlareStage>(flare, gpu, primaries);
        if (flare_stage) *flare_stage = stage.get();
        stages.push_back(std::move(stage));
    }
    if (dof.compose) stages.push_back(std::move(dof.compose));
    stages.push_back(std::make_unique<colour::ColourOutputStage>(colour_session, gpu, args.colour.device));
    return stages;
}

// The default view's effects (every frame's, when it has no views), each run only when --views selects
// it, then the "views" stage with the other views' own effects (made at their first frame).
std::vector<std::unique_ptr<Stage>> make_stages(const FilterArgs& args, const FlareStage*& flare) {
    auto colour_session = std::make_shared<colour::ColourSession>(args.colour, args.pipeline.output);
    auto gpu = std::make_shared<GpuSession>();
    gpu->platform = args.flare.gpu;
    gpu->requested = args.gpu_given;
    auto views = std::make_shared<const ViewSelection>(args.views);
    std::vector<std::unique_ptr<Stage>> stages;
    for (auto& stage : make_view_stages(args, colour_session, gpu, args.flare.layer, &flare))
        stages.push_back(std::make_unique<DefaultViewStage>(std::move(stage), views));
    auto other_view = [&args, colour_session, gpu](const std::string& view) {
        return make_view_stages(args, colour_session, gpu, args.flare.layer.empty() ? "" : args.flare.layer + "." + view);
    };
    stages.push_back(std::make_unique<OtherViewsStage>(other_view, views));
    return stages;
}

std::string lower_extension(const std::string& path) {
    const auto dot = path.rfind('.');
    std::string ext = dot == std::string::npos || path.find('/', dot) != std::string::npos ? std::string() : path.substr(dot + 1);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

// What the output can hold: extra channels (EXR, TIFF, an EXR stream) and display code values (8/16 bits).
struct OutputKind {
    bool extra_channels = false;
    bool display_referred = false;
    bool exr = false;  // an EXR file or stream (a stream input's format, not known yet, counts)
    std::string name;  // for messages: "PNG", "EXR stream"...
};

OutputKind output_kind(const PipelineOptions& o) {
    OutputKind k;
    if (o.output == "-") {
        const StreamFormat f = o.stream_format ? *o.stream_format : o.pix_fmt ? StreamFormat::raw : StreamFormat::exr;
        k.name = fmt::format("{} stream", to_string(f));
        // Without --stream-format a stream input's format goes on: known once its first byte is read.
        k.extra_channels = f == StreamFormat::exr && (o.stream_format.has_value() || o.input != "-");
        k.exr = f == StreamFormat::exr;
        return k;
    }
    const std::string ext = lower_extension(o.output);
    k.name = ext.empty() ? o.output : ext;
    std::transform(k.name.begin(), k.name.end(), k.name.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
    k.exr = ext == "exr" || ext == "sxr" || ext == "mxr";
    k.extra_channels = k.exr || ext == "tif" || ext == "tiff";
    k.display_referred = colour::is_display_referred_format(o.output);
    return k;
}

// Options that cannot apply to this output are usage errors (--layer into a PNG, --bits into an EXR, 16 bits into
// a JPEG); PQ quantised to 8 bits bands, which is only a warning.
void check_output_options(const FilterArgs& args, const CLI::App& app) {
    const OutputKind out = output_kind(args.pipeline);
    const bool stream_in_out = args.pipeline.output == "-" && !args.pipeline.stream_format && !args.pipeline.pix_fmt && args.pipeline.input == "-";
    if (!args.flare.layer.empty() && !out.extra_channels && !stream_in_out)
        throw CLI::ValidationError(fmt::format("--layer {} adds channels, which {} output cannot hold (EXR or TIFF can; on - give --stream-format exr)",
                                               args.flare.layer, out.name));
    if (app.get_option("--bits")->count() > 0 && !out.display_referred)
        throw CLI::ValidationError(fmt::format("--bits sets the code values of display files (PNG, JPEG...); {} output keeps float values", out.name));
    if (args.colour.bits != 8 && lower_extension(args.pipeline.output).rfind("jp", 0) == 0)
        throw CLI::ValidationError(fmt::format("--bits {}: {} holds 8-bit code values (PNG or TIFF hold 16)", args.colour.bits, out.name));
    std::string display = args.colour.options.display;
    std::transform(display.begin(), display.end(), display.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    const bool pq = display.find("pq") != std::string::npos || display.find("2084") != std::string::npos;
    const bool eight_bits = out.display_referred && (args.colour.bits == 8 || lower_extension(args.pipeline.output).rfind("jp", 0) == 0);
    if (pq && eight_bits && !args.pipeline.quiet)
        fmt::print(stderr, "lensfx: warning: PQ ({}) in an 8-bit {} bands visibly; use --bits 16 (PNG) or a float output\n",
                   args.colour.options.display, out.name);
}

// Options that mean something only with another, or for another output, are refused without it: they were accepted
// and did nothing (the lens blur's without --dof, --dither into a float file, --compression outside EXR, --pfm-order
// with no PFM on either side).
void refuse_idle_options(const FilterArgs& args, const CLI::App& app) {
    const auto given = [&](const char* name) { return app.get_option(name)->count() > 0; };
    if (!args.dof.enabled)
        for (const char* name : {"--focus", "--tilt", "--focus-point", "--depth-scale", "--depth-channel", "--deep", "--dof-rays", "--dof-max-rays",
                                 "--no-chromatic-blur", "--dof-only"})
            if (given(name)) throw CLI::ValidationError(name, "applies to the lens blur, which is off: add --dof");
    if (args.dof.enabled && args.flare.lens.empty()) throw CLI::ValidationError(std::string("--dof needs --lens"));  // usage errors: exit 2
    if (args.dof.enabled && !args.dof.focus_m && args.dof.focus_points.empty())
        throw CLI::ValidationError(std::string("--dof needs --focus METRES (or --focus-point X,Y,METRES)"));
    const PipelineOptions& o = args.pipeline;
    const OutputKind out = output_kind(o);
    if (given("--dither") && args.colour.dither_mode() != colour::Dither::None && !out.display_referred && o.output != "-")
        throw CLI::ValidationError("--dither", fmt::format("dithers display files' code values (PNG, JPEG...); {} output keeps float values", out.name));
    const std::string in_ext = lower_extension(o.input), out_ext = lower_extension(o.output);
    if (given("--compression") && !out.exr)
        throw CLI::ValidationError("--compression", fmt::format("sets EXR compression; {} output is not EXR", out.name));
    const bool pfm = o.input == "-" || o.output == "-" || in_ext == "pfm" || out_ext == "pfm";
    if (given("--pfm-order") && !pfm) throw CLI::ValidationError("--pfm-order", "orders PFM rows; neither the input nor the output is PFM");
}

// A flare whose gains leave nothing (--gain 0, or every part's gain 0) is legal, as every gain of 0 is (a shot
// file can switch the flare off and keep its settings), but the frames then pass through unchanged: a warning
// says so, as a user who did not mean it would otherwise not know.
void warn_about_zero_gain(const FilterArgs& args) {
    const FlareSettings& f = args.flare;
    if (f.lens.empty() || args.dof.dof_only || args.pipeline.quiet) return;
    const FlareParts parts = parse_parts(f.parts);
    const bool ghosts = parts.ghosts && f.controls.ghost_gain > 0.0, starburst = parts.starburst && f.starburst_gain > 0.0;
    if (f.gain > 0.0 && (ghosts || starburst)) return;
    const std::string why = f.gain > 0.0 ? "every part drawn has a gain of 0 (--parts, --ghost-gain, --starburst-gain)" : "--gain 0";
    fmt::print(stderr, "lensfx: warning: {}: no flare is added, the frames pass through unchanged\n", why);
}

// Whether the output (a file or frame pattern) names `path`: one of its frames, or the same pattern.
bool output_names(const std::string& out, const std::string& path) {
    std::error_code ec;
    if (std::filesystem::weakly_canonical(path, ec) == std::filesystem::weakly_canonical(out, ec)) return true;
    try {
        refuse_overwrite(path, "-o", out);  // throws when `path` is one of the output's files
    } catch (const std::runtime_error&) {
        return true;
    }
    return false;
}

// Refuses an output that would overwrite a file the effects read (--matte, --tracks, --aperture-image,
// --flare-look): the never-overwrite-an-input rule covers them too.
void refuse_output_over_side_inputs(const FilterArgs& args) {
    const std::string& out = args.pipeline.output;
    if (out.empty() || out == "-") return;
    const std::pair<const char*, const std::string*> side[] = {
        {"--matte", &args.flare.controls.matte}, {"--tracks", &args.flare.tracks},
        {"--aperture-image", &args.flare.pupil.aperture_image}, {"--flare-look", &args.flare.flare_look}};
    for (const auto& [option, path] : side)
        if (!path->empty() && *path != "-" && output_names(out, *path))
            throw std::runtime_error(fmt::format("-o {}: refusing to overwrite the {} file {}", out, option, *path));
}

void run_filter(FilterArgs& args, const CLI::App& app) {
    PipelineOptions& o = args.pipeline;
    o.pfm_order = parse_pfm_order(args.pfm_order);
    o.write.pfm_order = o.pfm_order;
    if (!args.pix_fmt.empty()) o.pix_fmt = parse_raw_pix_fmt(args.pix_fmt);
    if (!args.stream_format.empty()) o.stream_format = parse_stream_format(args.stream_format);
    if (!args.size.empty()) parse_size(args.size, o.raw_width, o.raw_height);
    o.memory = memory_budget_option(args.memory_limit);
    if (args.memory_limit.empty()) o.in_flight_limit = kDefaultInFlightBytes;
    args.flare.memory = o.memory;
    check_output_options(args, app);
    refuse_idle_options(args, app);
    check_exr_compression(o.write.compression);
    if (!args.flare.layer.empty()) o.adds_channels = "--layer " + args.flare.layer;
    warn_about_zero_gain(args);
    refuse_output_over_side_inputs(args);
    if (o.report_path == "-" && o.output == "-") throw std::runtime_error("--report - and -o - would both write to stdout");
    // the report is written after the frames: a place it cannot go fails the run before any frame replaces an output
    if (!o.report_path.empty() && o.report_path != "-") require_writable_file(o.report_path, "--report");
    o.options_toml = app.config_to_str(false, false);
    if (args.progress) o.progress = Progress::on;
    o.write.display_bits = args.colour.bits;
    o.write.dither = args.colour.dither_mode();

    const FlareStage* flare = nullptr;
    auto owned = make_stages(args, flare);
    std::vector<Stage*> stages;
    for (auto& s : owned) stages.push_back(s.get());
    const RunReport report = run_pipeline(o, stages);
    if (flare && !flare->summary().lights_per_frame.empty() && !o.quiet) fmt::print(stderr, "{}\n", describe(flare->summary()));
    // Neither flare nor lens blur: the frames went through the colour stages alone (an EXR to an EXR unchanged), which a
    // forgotten --lens would otherwise leave unsaid.
    if (args.flare.lens.empty() && !args.dof.enabled && report.written() > 0 && report.error.empty() && !o.quiet)
        fmt::print(stderr, "lensfx: {} frame{} written without a flare: no --lens was given (lensfx lens list names the presets)\n",
                   report.written(), report.written() == 1 ? "" : "s");
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
        "stream of EXR or PFM images on stdin (found by their magic number; raw planar float with --pix-fmt\n"
        "and --size) and stdout (the input stream's format, else EXR; --stream-format). Only R, G, B are\n"
        "changed: every other channel, the windows and the metadata pass through.");
    app.add_option("-i,--input", o.input, "Input file, pattern or - (stdin)");
    app.add_option("-o,--output", o.output, "Output file, pattern or - (stdout)");
    app.add_option("--frames", o.frames, "Frames of a pattern input: 1-100, 1-100x2 (every 2nd), 1-100y2 (the others), 100-1, 3,7,10-20; also in the pattern: pan.1-5#.exr (default: those on disk)")
        ->check(parsed_by([](const std::string& t) { parse_frame_list(t); }, "--frames", "LIST"));
    app.add_option("--threads", o.threads, "Worker threads for decoding and encoding (0: one per core)")->capture_default_str()->check(CLI::Range(0, 1024));
    app.add_option("--queue-depth", o.queue_depth, "Frames held between reader, effects and writer")->check(CLI::Range(1, 256));
    app.add_option("--compression", o.write.compression, "EXR compression: piz, zip, zips, dwaa[:level], none... (default: the input's, else piz)")
        ->check(parsed_by([](const std::string& t) { check_exr_compression(t); }, "--compression", "NAME[:LEVEL]"));
    app.add_option("--pfm-order", args->pfm_order, "PFM row order: top (ffmpeg 5.1), bottom (the PFM spec), auto (top on pipes, bottom in files)")
        ->check(CLI::IsMember({"auto", "top", "bottom"}));
    app.add_option("--stream-format", args->stream_format, "What - carries as output: exr, pfm or raw (default: the input stream's, else exr)")
        ->check(CLI::IsMember({"exr", "pfm", "raw"}));
    app.add_option("--pix-fmt", args->pix_fmt, "Raw planar float on -: gbrpf32le or gbrapf32le (planes G, B, R[, A]); the output's, and the input's with --size")
        ->check(CLI::IsMember({"gbrpf32le", "gbrapf32le"}));
    app.add_option("--size", args->size, "Frame size of raw input on stdin, WIDTHxHEIGHT")->check(parsed_by([](const std::string& text) {
        int w = 0, h = 0;
        parse_size(text, w, h);
    }, "--size", "WxH"));
    app.add_flag("--skip-bad-frames", o.skip_bad_frames, "Leave out unreadable or mismatched input frames and report them");
    app.add_flag("--allow-empty", o.allow_empty, "An input stream of no frames is a success (default: an error)");
    app.add_flag("-q,--quiet", o.quiet, "No progress line, no warnings");
    app.add_flag("--progress", args->progress, "Show progress even when stderr is not a terminal");
    app.add_option("--report", o.report_path, "Write per-frame stage times and the run's options as JSON (- : stdout)");
    app.add_option("--views", args->views, "Views of a stereo or multi-view EXR to flare, each from its own pixels (default: all)")
        ->delimiter(',');
    app.add_option("--memory-limit", args->memory_limit, kMemoryLimitHelp)->check(memory_limit_check());
    colour::add_colour_options(app, args->colour);
    add_flare_options(app, args->flare);
    add_dof_options(app, args->dof);

    app.callback([&app, args] {
        if (!app.get_subcommands().empty()) return;
        if (args->pipeline.input.empty() && args->pipeline.output.empty()) throw CLI::CallForHelp();
        if (args->pipeline.input.empty() || args->pipeline.output.empty()) {
            throw CLI::ValidationError("the filter needs both -i IN and -o OUT");
        }
        args->gpu_given = app.get_option("--gpu")->count() > 0;
        run_filter(*args, app);
    });
}

}  // namespace lensfx::filter
