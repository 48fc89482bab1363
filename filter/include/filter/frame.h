// The frame that travels through the lensfx pipeline, and the hook effects plug into.
// A Frame carries the image exactly as read (every channel in its native type, both windows, all
// metadata) plus a float RGB working buffer; effects change only that buffer, everything else passes
// through bit-exact.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <filter/image_spec.h>

namespace lensfx::filter {

// An uninitialised byte buffer (no zero fill: frames are large and are always overwritten by a read).
// Copyable, so Frame stays a value type.
class PixelBuffer {
public:
    PixelBuffer() = default;
    explicit PixelBuffer(std::size_t size) : data_(new std::byte[size]), size_(size) {}
    PixelBuffer(const PixelBuffer& other);
    PixelBuffer& operator=(const PixelBuffer& other);
    PixelBuffer(PixelBuffer&&) noexcept = default;
    PixelBuffer& operator=(PixelBuffer&&) noexcept = default;
    ~PixelBuffer() = default;

    // A buffer of `size` bytes in the storage of `floats` (at least size / 4 of them): store_rgb() writes a
    // released frame's pixels into its float working buffer's own memory instead of allocating beside it.
    static PixelBuffer adopt(std::vector<float>&& floats, std::size_t size);

    std::byte* data() { return adopted_.empty() ? data_.get() : reinterpret_cast<std::byte*>(adopted_.data()); }
    const std::byte* data() const { return adopted_.empty() ? data_.get() : reinterpret_cast<const std::byte*>(adopted_.data()); }
    std::size_t size() const { return size_; }

private:
    std::unique_ptr<std::byte[]> data_;
    std::vector<float> adopted_;
    std::size_t size_ = 0;
};

struct Frame {
    std::int64_t number = 0;  // frame number from the input pattern; 1, 2, ... for a stream or a single file
    std::size_t index = 0;    // 0-based position in this run
    std::string source;       // the input file, or "-" for stdin
    std::string format;       // the input's format: "openexr", "pfm", "raw", or OpenImageIO's name ("tiff", "hdr"...)

    // Channel names, per-channel types and order, data window (x, y, width, height), display window
    // (full_*), and the input's metadata (compression, chromaticities, an EXR's whole header).
    ImageSpec spec;
    // Every channel over the data window, interleaved, each channel in its native type
    // (spec.channeltypes); rows top first. Size spec.image_bytes().
    PixelBuffer pixels;

    // Indices in spec of the channels an effect works on (R, G, B); -1 where the image has none. A
    // luminance-only image (Y, no R, G, B) has Y in all three: see luminance_only().
    std::array<int, 3> rgb_channels{-1, -1, -1};
    // A luminance-only image's Y in terms of R, G, B: the Y row of its RGB -> XYZ (its chromaticities,
    // else Rec. 709's, OpenEXR's default). load_rgb() spreads Y to R = G = B; store_rgb() writes back
    // this weighted sum of `rgb`, so a coloured flare adds its luminance.
    std::array<double, 3> luminance_weights{0.2126, 0.7152, 0.0722};
    // The working buffer: R, G, B as float, interleaved, over the data window, rows top first.
    // Empty until load_rgb(); the pipeline fills it before the stages that ask for it and writes it back
    // with store_rgb() after them, so a frame no stage touches is written from `pixels` unconverted.
    std::vector<float> rgb;

    bool has_rgb() const { return rgb_channels[0] >= 0 && rgb_channels[1] >= 0 && rgb_channels[2] >= 0; }
    // Y stands in for R, G, B (find_rgb_channels found no R, G, B but a Y).
    bool luminance_only() const { return has_rgb() && rgb_channels[0] == rgb_channels[1] && rgb_channels[1] == rgb_channels[2]; }
    std::size_t pixel_count() const { return spec.pixel_count(); }
};

// Finds R, G and B among the spec's channel names (exact names first, then a "layer.R" suffix on the
// first layer that has all three) and stores their indices in frame.rgb_channels. An image with none but
// a luminance channel Y (and no chroma RY, BY) gets Y for all three and its luminance_weights.
void find_rgb_channels(Frame& frame);
// Byte offset of each channel inside one pixel of `pixels`.
std::vector<std::size_t> channel_offsets(const ImageSpec& spec);
// Copies the R, G, B channels of `pixels` into `rgb` as float. Throws if the frame has no R, G, B.
void load_rgb(Frame& frame);
// Writes `rgb` back into the R, G, B channels of `pixels`, converted to their native types (making
// `pixels` again when release_rgb_pixels() released them).
void store_rgb(Frame& frame);
// store_rgb(), then `rgb` emptied; a frame whose pixels were released is stored into the memory of `rgb`
// itself (PixelBuffer::adopt), so the frame is not held twice while it is stored.
void store_rgb_and_drop(Frame& frame);
// When R, G, B are all of the frame's channels and `rgb` is loaded, releases `pixels` (they hold nothing
// `rgb` does not) until store_rgb(): a half RGB frame is then held once while the stages run, not twice.
// Returns whether it did. grow_data_window() and add_rgb_layer() work on a frame in this state.
bool release_rgb_pixels(Frame& frame);
// The given channels of `pixels` as float, interleaved in the order given.
std::vector<float> channels_as_float(const Frame& frame, const std::vector<int>& channels);
// Writes floats (interleaved in the order given) into those channels of `pixels`, in their native types.
void store_channels(Frame& frame, const std::vector<int>& channels, const std::vector<float>& values);
// The same for `rows` rows of the data window from `first_row` (0: its top), into `out`
// (rows x width x channels.size() floats): for converting an output a strip at a time.
void rows_as_float(const Frame& frame, const std::vector<int>& channels, int first_row, int rows, float* out);
// Grows the data window to also cover the rectangle [x0, x1) x [y0, y1) (absolute pixel coordinates, as
// spec.x / spec.y); new pixels are 0 in every channel, and `rgb`, when loaded, grows with `pixels`.
void grow_data_window(Frame& frame, int x0, int y0, int x1, int y1);
// `rgb` (R, G, B interleaved over the data window of `was`) over the data window of `now`, which holds it: 0 where
// it grew (grow_data_window's working buffer; a multi-view frame's other view's).
std::vector<float> rgb_in_window(const std::vector<float>& rgb, const ImageSpec& was, const ImageSpec& now);
// Appends channels LAYER.R, LAYER.G, LAYER.B, of the R channel's type, holding `rgb` (float RGB
// interleaved over the data window). Throws std::invalid_argument when a channel of that name exists.
void add_rgb_layer(Frame& frame, const std::string& layer, const std::vector<float>& rgb);

// An effect: detection, flare, colour. The pipeline calls process() on one thread, once per frame, in
// frame order, so a stage may keep state from frame to frame (tracking). A stage changes frame.rgb
// (filled by the pipeline when wants_rgb() is true) and may read anything else; it must not change the
// spec's channels or windows. It throws std::exception to reject the frame: the message should say why;
// the pipeline adds the file and frame.
class Stage {
public:
    Stage() = default;
    Stage(const Stage&) = delete;
    Stage& operator=(const Stage&) = delete;
    virtual ~Stage() = default;

    virtual std::string_view name() const = 0;
    virtual bool wants_rgb() const { return true; }
    virtual void process(Frame& frame) = 0;
    // Milliseconds spent in named parts of the last process() call; the report lists them as NAME.PART.
    virtual std::vector<std::pair<std::string, double>> part_times() const { return {}; }
    // Figures of the last process() call (what it found: lights, the brightest luminance...); the report
    // lists them as NAME.FIGURE.
    virtual std::vector<std::pair<std::string, double>> frame_figures() const { return {}; }
    // Bytes the stage holds, beyond the frame itself, while it processes a frame of `spec` and after it
    // (buffers it keeps for the next frame: the flare's GL targets); the pipeline counts them against the
    // memory limit with the frames in flight.
    virtual std::size_t held_bytes(const ImageSpec& /*spec*/) const { return 0; }
};

}  // namespace lensfx::filter
