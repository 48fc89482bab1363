// The lens blur's ray table kept on disk, so a sequence (and every farm chunk or later run with the same
// lens, zoom, f-number, focus, sensor, raster and table size) traces it once: <dir>/dof-rays-<key>.bin.
// The key is a hash of everything the table depends on; the file repeats the whole key text and ends in a
// checksum, so a foreign, truncated or corrupted file is rejected and rebuilt. Named, hashed and written
// atomically by the disk cache (flare/cache.h).
#pragma once
#include <optional>
#include <string>

#include <dof/lens_rays.h>

namespace lensfx::dof {

// Everything make_ray_table(camera, samples, grid) depends on, as text (the lens by its system hash).
std::string ray_table_key(const Camera& camera, int samples, int grid);
// The file of that key in dir.
std::string ray_table_path(const std::string& dir, const std::string& key);

// The table stored at path for exactly this key, or nothing when the file is missing, of another key, of
// another shape, truncated, altered (checksum) or holds non-finite values.
std::optional<RayTable> read_ray_table(const std::string& path, const std::string& key);
// Writes the table (temporary file in the same folder, then rename); false when it cannot (the caller
// goes on without the cache).
bool write_ray_table(const std::string& path, const std::string& key, const RayTable& table);

// Where the table came from and what it cost.
struct RayTableSource {
    bool loaded = false;   // read from the cache
    bool rejected = false; // a file was there but was not usable (rebuilt and rewritten)
    bool saved = false;    // written to the cache
    double ms = 0.0;
};

// make_ray_table through the cache in dir (empty: no cache, always computed).
RayTable cached_ray_table(const Camera& camera, int samples, int grid, const std::string& dir, RayTableSource* source = nullptr);

}  // namespace lensfx::dof
