// Reading and writing single image files: OpenEXR for EXR, our own PFM code (filter/stream.h) for PFM,
// OpenImageIO (a module loaded on first use) for TIFF, Radiance HDR and the display formats. Writes go to a temporary file in the target's
// directory (filter/output_files.h) and are renamed into place only when complete, so a failure never leaves a partial file.
#pragma once

#include <cstdio>
#include <optional>
#include <string>

#include <filter/dither.h>
#include <filter/frame.h>
#include <filter/stream.h>
#include <optics/memory_budget.h>

namespace lensfx::filter {

class TempFile;  // filter/output_files.h

// Reads the first part (subimage) of a file at its full resolution (mip level 0); tiles are read into
// scanline order. Every channel keeps its native type. Throws std::runtime_error on a missing, damaged
// or unrecognised file, and for deep images; MemoryLimitError, before the pixels are allocated, when the
// data window does not fit `budget`.
Frame read_image(const std::string& path, PfmOrder pfm_order = PfmOrder::automatic, const MemoryBudget& budget = {});

struct WriteOptions {
    // EXR compression ("piz", "zip", "dwaa:45", ...). Empty: the input's own when it was a losslessly
    // compressed EXR, else piz (re-encoding a DWA or B44 input would change its pixels).
    std::string compression;
    PfmOrder pfm_order = PfmOrder::automatic;
    // Display-referred formats (PNG, JPEG...): 8 or 16 bits (where the format has 16: PNG, PNM, DPX),
    // quantised with this dither (the frame's index moves the pattern over time).
    int display_bits = 8;
    colour::Dither dither = colour::Dither::BlueNoise;
    // What the conversion buffers of an output may take (display formats are converted in strips).
    MemoryBudget memory;
};

// Writes a frame; the format follows the extension. EXR: every channel, type, window and attribute as
// in the frame, scanline. TIFF: every channel (float when the types differ). HDR, PFM: R, G, B as float.
// Other formats (PNG, JPEG...): R, G, B and A if present, quantised to 8 or 16 bits.
// Throws std::runtime_error (unknown format, unwritable directory, failed write); leaves no file then.
void write_image(const Frame& frame, const std::string& path, const WriteOptions& options = {});
// The same into `file` (its name() sets the format), which the caller commits.
void write_image(const Frame& frame, TempFile& file, const WriteOptions& options = {});

// Writes a frame as one EXR image of a stream (the compression as write_image() chooses it).
void write_exr_stream(std::FILE* out, const Frame& frame, const WriteOptions& options = {});
// Reads the next EXR image of a stream (filter/stream.h's read_exr_bytes); nothing at its end.
std::optional<Frame> read_exr_stream(std::FILE* in);

// A frame holding `channels` interleaved values of one type over width x height at the origin (channels
// R, G, B, A...), for writing images lensfx makes: flare renders, previews, plots.
Frame image_frame(int width, int height, int channels, PixelType type, const void* data);

// Throws, naming the path, unless write_image() can write an image file of this path's extension: an unknown
// extension, or one of OpenImageIO's writers that make no picture file of R, G, B (null: nothing; term: escape
// codes on the terminal; zfile: one depth channel).
void require_output_format(const std::string& path);

}  // namespace lensfx::filter
