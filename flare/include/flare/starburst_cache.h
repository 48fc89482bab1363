// The starburst texture of an iris, kept on disk through the cache (cache.h): computing one takes a
// second or more, reading it a few milliseconds.
#pragma once

#include <string>

#include <optics/aperture.h>
#include <optics/starburst.h>

namespace lensfx::flare {

// The starburst of an iris with these options, read from `cache_dir` when a file for exactly these is
// there, else computed and stored there (best effort: a cache that cannot be written is skipped; a damaged
// file is recomputed). Empty cache_dir: always computed.
optics::Starburst cached_starburst(const optics::Aperture& aperture, const optics::StarburstOptions& options,
                                   const std::string& cache_dir);

}  // namespace lensfx::flare
