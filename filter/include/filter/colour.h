// Colour management with OpenColorIO: which colour space the input frames are in, the scene-linear working
// space the flare is rendered and composited in (and its primaries, for the renderer's spectral-to-RGB
// conversion), the display transform (view/look/exposure) for viewable outputs, and quantisation with dither.
// Without an OCIO config (no --ocio, no $OCIO) a config is built in code from OCIO's built-in ACES transforms.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#include <OpenColorIO/OpenColorIO.h>

#include <filter/frame.h>
#include <filter/gpu_session.h>
#include <optics/starburst.h>

namespace lensfx::colour {

namespace OCIO = OCIO_NAMESPACE;

// Row-major 3x3 matrix acting on column vectors: out = m * in.
using Mat3 = std::array<double, 9>;

Mat3 multiply(const Mat3& a, const Mat3& b);
Mat3 inverse(const Mat3& m);  // throws std::invalid_argument when singular

// CIE 1931 xy chromaticities of an RGB space's primaries and white point, in the order of the OpenEXR
// `chromaticities` attribute: red x, y, green x, y, blue x, y, white x, y.
struct Chromaticities {
    double rx, ry, gx, gy, bx, by, wx, wy;
};

enum class KnownPrimaries { Rec709, AcesAP0, AcesAP1, Rec2020, P3D65 };

Chromaticities chromaticities(KnownPrimaries p);
std::string_view name(KnownPrimaries p);

// Which of the known primary sets the 8 floats of an EXR chromaticities attribute are, allowing for the
// rounding of writers (each coordinate within `tolerance`); nullopt when none matches.
std::optional<KnownPrimaries> identify_primaries(const std::array<float, 8>& exr_chromaticities,
                                                 double tolerance = 2e-3);

// The RGB -> CIE XYZ matrix of an RGB space (no chromatic adaptation; white RGB (1,1,1) maps to the white
// point with Y = 1).
Mat3 rgb_to_xyz(const Chromaticities& c);
// Bradford chromatic adaptation of XYZ from one white point (xy) to another.
Mat3 bradford(double src_wx, double src_wy, double dst_wx, double dst_wy);

// CIE 1931 2-degree colour matching functions (the optics core's Wyman-Sloan-Shirley fit).
using optics::cie1931_xyz;
// Working-space RGB of monochromatic light of unit spectral power at a wavelength: inverse(rgb_to_xyz) times
// the colour matching functions. A renderer that samples wavelengths sums these (times the sample spacing)
// to put a spectrum into the same RGB as the frame. Spectral colours lie outside most gamuts: expect
// negative components.
std::array<double, 3> wavelength_to_rgb(double wavelength_nm, const Mat3& rgb_to_xyz);

// What the user asked for on the command line.
struct ColourOptions {
    std::string ocio_config;   // --ocio FILE; empty: $OCIO, else the built-in config
    std::string colorspace;    // --colorspace NAME: the input's OCIO colour space; empty: from the file
    std::string display;       // --display; empty: the config's default display
    std::string view;          // --view; empty: the display's default view
    std::string look;          // --look: OCIO look(s) applied in scene-linear before the view, replacing the view's own
    double exposure_ev = 0.0;  // --exposure: scale by 2^EV in scene-linear before the display transform
};

// Names of the colour spaces, displays and views of the built-in config (used when there is no OCIO config).
namespace builtin {
inline constexpr std::string_view aces2065_1 = "ACES2065-1";
inline constexpr std::string_view acescg = "ACEScg";
inline constexpr std::string_view lin_rec709 = "Linear Rec.709 (sRGB)";
inline constexpr std::string_view lin_rec2020 = "Linear Rec.2020";
inline constexpr std::string_view lin_p3d65 = "Linear P3-D65";
inline constexpr std::string_view xyz_d65 = "CIE-XYZ-D65";
inline constexpr std::string_view display_srgb = "srgb";
inline constexpr std::string_view display_rec709 = "rec709";
inline constexpr std::string_view display_rec2100_pq = "rec2100-pq";
inline constexpr std::string_view view_sdr = "ACES 1.0 - SDR Video";
inline constexpr std::string_view view_hdr = "ACES 1.1 - HDR Video (1000 nits & Rec.2020 lim)";
inline constexpr std::string_view view_untonemapped = "Un-tone-mapped";
}  // namespace builtin

// An OpenColorIO config (a file or the built-in one) and what can be asked of it. Copyable, shares the config.
class ColourConfig {
public:
    // `path` empty: $OCIO when set, else the built-in config. Throws naming the file when it cannot be used.
    static ColourConfig load(const std::string& path);
    static ColourConfig builtin_config();

    const std::string& source() const { return source_; }  // the file, or "built-in"
    bool is_builtin() const { return builtin_; }

    std::vector<std::string> colour_spaces() const;
    std::vector<std::string> displays() const;
    std::vector<std::string> views(const std::string& display) const;
    std::vector<std::string> looks() const;
    std::string default_display() const;
    std::string default_view(const std::string& display) const;

    // The colour space of the input: `requested` (checked, also accepts roles) when not empty, else the one
    // matching the file's chromaticities, else linear Rec.709. With the built-in config any chromaticities
    // work (a colour space is added for them); with a file config known primaries are looked up by the
    // usual names. Throws naming the colour space or chromaticities and listing the valid ones.
    std::string input_space(const std::string& requested,
                            const std::optional<std::array<float, 8>>& exr_chromaticities);

    // Throwing checks with messages that list the valid names.
    void check_colour_space(const std::string& name) const;
    void check_display_view(const std::string& display, const std::string& view) const;
    void check_looks(const std::string& looks) const;

    const OCIO::ConstConfigRcPtr& ocio() const { return config_; }
    std::string serialize() const;  // the config as an .ocio file

private:
    OCIO::ConstConfigRcPtr config_;
    std::string source_;
    bool builtin_ = false;
};

// A view of float pixels with at least 3 channels (RGB first; further channels such as alpha are left
// untouched). `row_stride` in floats, 0 = width * channels.
struct PixelSpan {
    float* data = nullptr;
    std::size_t width = 0;
    std::size_t height = 0;
    int channels = 3;
    std::size_t row_stride = 0;
};

// One colour transform on the CPU (OCIO's optimised float processor), applied over rows on several threads.
// Non-finite input values are replaced before the transform (NaN and -Inf by 0, +Inf by the largest half
// float), so NaN/Inf never reach the output; display transforms also clamp the result to [0, 1].
class ColourTransform {
public:
    ColourTransform() = default;  // identity
    bool is_identity() const { return !processor_; }
    bool clamps() const { return clamp_; }
    void apply(PixelSpan pixels) const;
    void apply_rgb(float* rgb, std::size_t count) const;  // packed RGB triples, single thread
    const OCIO::ConstProcessorRcPtr& processor() const { return processor_; }  // null for identity
    std::string description() const;  // the OCIO transforms, for logs

    // `clamp`: clamp the result to [0, 1] (display transforms).
    ColourTransform(OCIO::ConstProcessorRcPtr processor, bool clamp);

private:
    OCIO::ConstProcessorRcPtr processor_;
    OCIO::ConstCPUProcessorRcPtr cpu_;
    bool clamp_ = false;
};

// The same transform as GLSL (4.x) for the GPU path, from OCIO's shader generator. `source` declares the
// LUT samplers and defines `vec4 <function>(vec4 rgba)`, which sanitises, applies the transform and clamps
// (display transforms) exactly as ColourTransform::apply does; alpha passes through. Each texture is to be
// uploaded as given (GL order, x fastest; R32F or RGB32F) and bound to the sampler uniform of its name.
struct GpuShader {
    struct Texture {
        std::string sampler;        // the sampler uniform in `source`
        int dimensions = 1;         // 1, 2 (a long 1D LUT folded into rows) or 3
        unsigned width = 0, height = 1, depth = 1;
        int channels = 3;           // 1 (red only) or 3
        bool linear = true;         // linear filtering, else nearest
        std::vector<float> values;  // width * height * depth * channels
    };
    std::string function;
    std::string source;
    std::vector<Texture> textures;
};
// Throws when the transform needs uniforms (dynamic properties), which this path does not feed.
GpuShader gpu_shader(const ColourTransform& transform, const std::string& function = "lensfx_colour");

// A transform compiled for the GPU: gpu_shader() in a compute shader on the current GL context (a
// gpu::Context made current on this thread, which must outlive this). apply() gives what
// ColourTransform::apply gives within 1e-4, NaN/Inf sanitised the same way; the identity does nothing.
class GpuColourTransform {
public:
    explicit GpuColourTransform(const ColourTransform& transform);
    ~GpuColourTransform();
    GpuColourTransform(GpuColourTransform&&) noexcept;
    GpuColourTransform& operator=(GpuColourTransform&&) noexcept;
    void apply(PixelSpan pixels);
    void apply_rgb(float* rgb, std::size_t count);  // packed RGB triples

private:
    struct State;
    std::unique_ptr<State> state_;
};

// Colour space to colour space (names or roles of the config).
ColourTransform make_transform(const ColourConfig& config, const std::string& src, const std::string& dst);

// The scene-linear space the flare is rendered and composited in.
struct WorkingSpace {
    std::string name;             // the OCIO colour space
    Chromaticities primaries;     // measured through the config when not known by name
    Mat3 rgb_to_xyz;              // of `primaries`: for the renderer's spectral -> RGB (use inverse())
    bool is_input_space = false;  // the input is already scene-linear in this space (no conversion)
    bool primaries_assumed = false;  // the config cannot convert to ACES and no chromaticities: Rec.709 assumed
};

// Everything a run of the filter needs: input -> working, working -> scene-linear output (back to the
// input's space), working -> display (exposure, look, view, clamp).
class ColourPipeline {
public:
    // Checks every name against the config; throws with the valid choices.
    ColourPipeline(ColourConfig config, const ColourOptions& options,
                   const std::optional<std::array<float, 8>>& exr_chromaticities);

    const ColourConfig& config() const { return config_; }
    const std::string& input_space() const { return input_space_; }
    const WorkingSpace& working() const { return working_; }
    const std::string& display() const { return display_; }
    const std::string& view() const { return view_; }

    const ColourTransform& to_working() const { return to_working_; }
    const ColourTransform& to_scene_output() const { return from_working_; }
    const ColourTransform& to_display() const { return to_display_; }

private:
    ColourConfig config_;
    std::string input_space_;
    WorkingSpace working_;
    std::string display_;
    std::string view_;
    ColourTransform to_working_;
    ColourTransform from_working_;
    ColourTransform to_display_;
};

// Output files: those that hold display-referred integer pixels always get the display transform
// (PNG, JPEG, 8/16-bit TIFF, ...); scene-linear ones (EXR, HDR, PFM, raw float) only when asked.
bool is_display_referred_format(std::string_view path_or_extension);

enum class Dither { None, Ordered, BlueNoise };

// Quantises display-referred values in [0, 1] to `bits` (8 or 16) with deterministic dither: Ordered is a
// 16x16 Bayer matrix, BlueNoise a fixed, spatially decorrelated pattern; `frame` shifts the pattern over
// time so that a static picture does not show a fixed pattern in video. Values outside [0, 1] clamp.
std::vector<std::uint8_t> quantise8(const PixelSpan& pixels, Dither dither, std::uint64_t frame = 0);
std::vector<std::uint16_t> quantise16(const PixelSpan& pixels, Dither dither, std::uint64_t frame = 0);
// The dither threshold offset in (-0.5, 0.5) LSB at a pixel and channel, for tests and the GPU path.
float dither_offset(Dither dither, std::size_t x, std::size_t y, int channel, std::uint64_t frame);

// ---------------------------------------------------------------------------------------------------------
// The colour stages of `lensfx -i IN -o OUT`.

struct ColourArgs {
    ColourOptions options;
    int bits = 8;                       // --bits: 8 or 16 for display-referred files (PNG, TIFF; JPEG is 8)
    std::string dither = "blue-noise";  // --dither: none, ordered, blue-noise
    std::string device = "auto";        // --colour-on: auto (GPU when the run has a GL context), cpu, gpu
    Dither dither_mode() const;
    // A display transform was asked for (--display, --view or --look): scene-linear outputs get it too.
    bool display_asked() const;
};

// Adds --colorspace, --ocio, --display, --view, --look, --exposure, --bits, --dither, --colour-on to the filter.
void add_colour_options(CLI::App& app, ColourArgs& args);

// What the colour stages of one run share: the config (loaded and checked when the run starts) and the
// ColourPipeline, made from the first frame's chromaticities. Stages run on one thread, in frame order.
class ColourSession {
public:
    // `output`: the -o argument; display-referred formats always get the display transform.
    ColourSession(const ColourArgs& args, const std::string& output);

    bool display_output() const { return display_output_; }
    const ColourConfig& config() const { return config_; }
    const ColourOptions& options() const { return options_; }  // display and view filled in
    // The pipeline for a frame: made from the first frame; a later frame whose chromaticities differ
    // from the first's is rejected (throws).
    const ColourPipeline& pipeline_for(const filter::Frame& frame);
    // Null before the first frame. The renderer reads working().rgb_to_xyz from here.
    const ColourPipeline* pipeline() const { return pipeline_ ? &*pipeline_ : nullptr; }

private:
    ColourConfig config_;
    ColourOptions options_;
    bool display_output_ = false;
    std::optional<ColourPipeline> pipeline_;
    std::optional<std::array<float, 8>> first_chromaticities_;
};

// Input -> working space: first in the chain. Does nothing (and asks for no float buffer) unless the
// input is in a non-linear colour space (--colorspace).
class ColourInputStage final : public filter::Stage {
public:
    explicit ColourInputStage(std::shared_ptr<ColourSession> session) : session_(std::move(session)) {}
    std::string_view name() const override { return "colour-in"; }
    bool wants_rgb() const override { return !session_->options().colorspace.empty(); }
    void process(filter::Frame& frame) override;

private:
    std::shared_ptr<ColourSession> session_;
};

// Working space -> output: last in the chain. Display outputs: exposure, look, view, clamp (and the
// frame's colour metadata says display); scene-linear outputs: exposure, back to the input's space.
// The transform runs on the GPU (OCIO's shader) when `device` is "gpu" (the context is made if needed), or
// "auto" and the run's GPU session is active (the flare stage made a context, or --gpu was given); else on
// the CPU. Both agree within 1e-4.
class ColourOutputStage final : public filter::Stage {
public:
    explicit ColourOutputStage(std::shared_ptr<ColourSession> session,
                               std::shared_ptr<filter::GpuSession> gpu = nullptr, std::string device = "auto");
    ~ColourOutputStage() override;
    std::string_view name() const override { return "colour-out"; }
    bool wants_rgb() const override;
    void process(filter::Frame& frame) override;
    bool ran_on_gpu() const { return ran_on_gpu_; }  // the last frame's transform did

private:
    void apply(const ColourTransform& transform, std::unique_ptr<GpuColourTransform>& compiled, PixelSpan pixels);
    std::shared_ptr<ColourSession> session_;
    std::shared_ptr<filter::GpuSession> gpu_;
    std::string device_;
    std::unique_ptr<GpuColourTransform> gpu_display_, gpu_scene_;
    bool ran_on_gpu_ = false;
};

}  // namespace lensfx::colour
