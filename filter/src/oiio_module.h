// The formats other than EXR and PFM (TIFF, Radiance HDR, PNG, JPEG...) go through OpenImageIO in a
// separate module (liblensfx_oiio.so), loaded the first time such a file is read or written, so that the
// EXR path's process start does not pay for OpenImageIO's plug-in libraries. Both sides are built by the
// same build with the same compiler and standard library, so C++ types and exceptions cross.
#pragma once

#include <functional>
#include <string>

#include <filter/frame.h>
#include <optics/memory_budget.h>

namespace lensfx::filter {

struct OiioModule {
    // Reads the first subimage at full resolution, channels in their native types; throws std::runtime_error,
    // and MemoryLimitError before allocating when the image does not fit the budget.
    Frame (*read)(const std::string& path, const MemoryBudget& budget);
    // Fills rows [first, first + count) of the data window (0 = its top row), spec.nchannels() channels of
    // one type (spec.channeltypes[0]) interleaved, into `out`.
    using RowSource = std::function<void(int first, int count, void* out)>;
    // Writes the image `rows` gives, `strip_rows` rows at a time (only a strip is ever held), with the
    // spec's text attributes, in the format `name`'s extension gives (the file's name as the user gave it; `path`
    // may have none, as /proc/self/fd/N); straight to `path`, every write checked; throws std::runtime_error, also
    // when the writer wrote nothing.
    void (*write)(const std::string& path, const std::string& name, const ImageSpec& spec, int strip_rows, const RowSource& rows);
    // OpenImageIO's name of the format it would write for this path ("tiff", "png"), or "" if none.
    std::string (*output_format)(const std::string& path);
    void (*set_threads)(int threads);
};

// Loads the module once (beside the program, in ../lib/lensfx, or in the build tree); throws
// std::runtime_error naming the places it looked when it cannot.
const OiioModule& oiio_module();
// OpenImageIO's worker threads, now if the module is loaded, else when it is.
void set_oiio_threads(int threads);

}  // namespace lensfx::filter

// The module's one exported symbol.
extern "C" const lensfx::filter::OiioModule* lensfx_oiio_module();
