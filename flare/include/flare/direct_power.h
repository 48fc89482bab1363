// The light a lens lets straight through to the sensor (its direct path), per channel: what a light's
// recorded image is divided by to give its irradiance at the lens. Traced on demand over the field and
// kept on disk through the cache (cache.h).
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <flare/flare.h>
#include <optics/system.h>

namespace lensfx::flare {

// Power (mm^2 per unit irradiance) that a collimated light at angles (ax, ay) delivers through the lens's
// direct path to the sensor, per channel: pupil area seen along the beam x transmission, with vignetting
// by every clear aperture and the iris, summed over the passes with their weights (empty: RGB mode's
// three wavelengths). The light's irradiance is its image's recorded energy (flux x pixel area) over this.
std::array<double, 3> direct_power(const optics::System& system, double ax_deg, double ay_deg, int rays = 64,
                                   const std::vector<SpectralPass>& passes = {});

// direct_power over the field: sampled at `samples` field angles from 0 to max_field_deg along +x and
// interpolated (cubic) at a light's field angle atan(hypot(tan ax, tan ay)); beyond max_field_deg, from a second
// table over the whole field to 90 degrees (kBeyondSamples, 2 degrees apart, traced on demand, kept in memory only). The lens is rotationally
// symmetric, so only a bladed iris clipped by another aperture makes the power depend on the azimuth.
// Samples are traced when a lookup first needs them, so a run pays only for the field its lights cross;
// save/load keep them on disk between runs. The (up to four) samples one lookup needs are traced side by
// side on threads of their own.
class DirectPowerTable {
public:
    DirectPowerTable() = default;
    DirectPowerTable(const optics::System& system, double max_field_deg, int samples = 12, int rays = 96,
                     std::vector<SpectralPass> passes = {});
    [[nodiscard]] std::array<double, 3> at(double ax_deg, double ay_deg) const;
    [[nodiscard]] double max_field_deg() const { return max_field_deg_; }
    [[nodiscard]] bool empty() const { return power_.empty(); }
    [[nodiscard]] int traced() const;  // samples traced (or loaded) so far

    // A file holding `key` (what the table was made from) and the samples known; load() takes the known
    // samples of a file with the same key and sample count and returns whether it did.
    void save(const std::filesystem::path& path, const std::string& key) const;
    bool load(const std::filesystem::path& path, const std::string& key);

private:
    optics::System system_;
    std::vector<SpectralPass> passes_;
    int rays_ = 0;
    double max_field_deg_ = 0.0;
    mutable std::vector<std::array<double, 3>> power_;
    mutable std::vector<char> known_;
    static constexpr int kBeyondSamples = 46;
    mutable std::shared_ptr<const DirectPowerTable> beyond_;  // lights past max_field_deg (beyond())
    const std::array<double, 3>& sample(int i) const;
    const DirectPowerTable& beyond() const;
    void trace_missing(const std::array<int, 4>& indices) const;
};

// What the passes depend on, for cache keys: wavelengths and weights at full precision.
std::string passes_key(const std::vector<SpectralPass>& passes);

}  // namespace lensfx::flare
