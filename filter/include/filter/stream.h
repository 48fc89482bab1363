// Frames as byte streams: EXR images one after another (as ffmpeg's `-f image2pipe -c:v exr` writes them), PFM (one image or many concatenated, as ffmpeg's image2pipe writes them) and
// raw planar float video (ffmpeg's gbrpf32le / gbrapf32le: planes G, B, R[, A], rows top first).
// OpenImageIO cannot read a stream of concatenated images from a pipe, so these are our own.
#pragma once

#include <cstdio>
#include <optional>
#include <string>
#include <string_view>

#include <filter/frame.h>
#include <optics/memory_budget.h>

namespace lensfx::filter {

// PFM row order. The format puts the bottom row first; ffmpeg 5.1 writes and reads the top row first.
// `automatic` means top-first on stdin/stdout (the other end is ffmpeg in practice) and bottom-first in files.
enum class PfmOrder { automatic, top_first, bottom_first };
enum class RawPixFmt { gbrpf32le, gbrapf32le };
// What a stream on stdin or stdout carries.
enum class StreamFormat { exr, pfm, raw };

PfmOrder parse_pfm_order(std::string_view text);             // "auto", "top", "bottom"
RawPixFmt parse_raw_pix_fmt(std::string_view text);          // "gbrpf32le", "gbrapf32le"
std::string_view to_string(RawPixFmt fmt);
int channel_count(RawPixFmt fmt);
StreamFormat parse_stream_format(std::string_view text);     // "exr", "pfm", "raw"
std::string_view to_string(StreamFormat format);

// The format of a stream by its first byte (EXR's magic number 0x76, PFM's 'P'), which is left unread;
// PFM for an empty stream. Throws std::runtime_error for anything else.
StreamFormat detect_stream_format(std::FILE* in);

// The bytes of the next EXR image of a stream: magic number and version, the headers, the offset
// tables and the chunks up to the end of the last one. Nothing at a clean end of stream; throws
// std::runtime_error on a malformed or truncated image, and for deep images.
std::optional<std::string> read_exr_bytes(std::FILE* in);

// Reads the next PFM image ("PF": R, G, B; "Pf": one channel "Y"). Returns nothing at a clean end of
// stream (no byte before the header); throws std::runtime_error on a malformed header or a short read.
// The frame's spec is float, its format "pfm"; `top_first` says how the rows are stored. A header whose
// size does not fit `budget` is refused (MemoryLimitError) before the pixels are allocated.
std::optional<Frame> read_pfm(std::FILE* in, bool top_first, const MemoryBudget& budget = {});
// Writes a PFM (little endian) of R, G, B (or "PF" of Y repeated when the frame has one channel only
// and no RGB: "Pf"). Throws std::runtime_error if the frame has neither or the write fails, and
// MemoryLimitError when the display window's float copy does not fit `budget`.
void write_pfm(std::FILE* out, const Frame& frame, bool top_first, const MemoryBudget& budget = {});

// Reads one raw planar frame of width x height; nothing at a clean end of stream; throws on a short frame,
// and MemoryLimitError (before reading) when a frame of that size does not fit `budget`.
std::optional<Frame> read_raw(std::FILE* in, RawPixFmt fmt, int width, int height, const MemoryBudget& budget = {});
// Writes the frame's R, G, B (and A, or 1 where it has none) as planes G, B, R[, A].
void write_raw(std::FILE* out, const Frame& frame, RawPixFmt fmt, const MemoryBudget& budget = {});

}  // namespace lensfx::filter
