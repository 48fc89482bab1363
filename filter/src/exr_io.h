// EXR files through OpenEXR itself: the pipeline's own format, read and written without OpenImageIO,
// whose Debian build loads some 260 plug-in libraries and costs a quarter second at every process start.
#pragma once

#include <string>
#include <vector>

#include <OpenEXR/ImfHeader.h>

#include <filter/frame.h>
#include <optics/memory_budget.h>

namespace lensfx::filter {

// An EXR input's header as read: what an EXR output starts from, so every attribute passes through.
class ExrHeader {
public:
    explicit ExrHeader(Imf::Header h) : header(std::move(h)) {}
    Imf::Header header;
};

// Whether the file starts with the EXR magic number.
bool is_exr_file(const std::string& path);

// Checks an EXR's headers before OpenEXR reads them (OpenEXR 3.1 allocates what a header declares): every
// attribute's size fits the file and its type, the data window and tiles are of a size lensfx reads, the
// chunk count fits the file. Throws std::runtime_error naming the attribute; read_exr runs it.
void check_exr_header(const std::string& path);

// Reads the first part of an EXR at its full resolution (tiles and mip levels: level 0 as scanlines).
// Channels keep their types (half, float, uint) and come R, G, B, A first within each layer, as
// OpenImageIO orders them. Throws std::runtime_error for damaged, deep or subsampled files, and
// MemoryLimitError (before allocating) when the data window does not fit `budget`.
Frame read_exr(const std::string& path, const MemoryBudget& budget = {});

// The same from a whole EXR held in memory (one image of a stream); `source` names it in messages.
Frame read_exr_memory(const std::string& bytes, const std::string& source, const MemoryBudget& budget = {});

// Writes every channel (8- and 16-bit ones as half) as a scanline EXR with the frame's windows and the
// given compression ("piz", "zip", "dwaa:45"...); the widened copies are sized against `budget`. Attributes: the input's header when it was an EXR,
// then the spec's chromaticities, pixel aspect and text attributes.
void write_exr(const Frame& frame, const std::string& path, const std::string& compression, const MemoryBudget& budget = {});
// Throws what write_exr would for this compression ("piz", "dwaa:45"...; empty: the input's) when it is not one, so
// a bad --compression is refused before the first frame is rendered rather than when it is written.
void check_exr_compression(const std::string& compression);

// The same EXR as write_exr() would write, into memory (one image of a stream on stdout).
std::string write_exr_memory(const Frame& frame, const std::string& compression, const MemoryBudget& budget = {});

// The views of a multi-view EXR (its multiView attribute), default first; empty for other frames.
std::vector<std::string> exr_views(const ImageSpec& spec);

// OpenEXR's worker threads for decoding and encoding (0: none).
void set_exr_threads(int threads);

}  // namespace lensfx::filter
