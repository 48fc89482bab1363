// Direct power: the lens's direct path traced over the entrance square, and its table over the field.
#include <flare/direct_power.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <future>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <fmt/core.h>
#include <flare/cache.h>
#include <optics/ghosts.h>
#include <optics/tracer.h>

namespace lensfx::flare {

namespace {

constexpr double kDegrees = 180.0 / std::numbers::pi;

// A power (mm^2 of entrance pupil, weighted by transmission) a trace could give: none, or between one
// faint ray's share (far above 1e-12) and far more than any lens's pupil. A file's sample outside it is
// traced again: 1e-300 made every pixel saturate, a negative or huge one left the flare out.
bool plausible_power(const std::array<double, 3>& p) {
    return std::all_of(p.begin(), p.end(), [](double v) { return v == 0.0 || (v >= 1e-12 && v <= 1e8); });
}

// Fewer passing samples than this over the entrance square: the iris's image is a few samples across (a lens
// stopped far down: f/500 passed none of 96^2), so it is sampled again over a square round it, until this many pass.
constexpr int kMinPassing = 64;
constexpr int kMaxCloser = 4;  // squares round the beam, each about a tenth of the last across

// The direct path sampled `rays` a side over `square`: its power (mm^2), how many samples pass, and where the
// sample whose stop crossing lies nearest the iris's centre enters (the beam's middle, to a sample).
struct DirectSamples {
    double power = 0.0;
    int passing = 0;
    double centre_x = 0.0, centre_y = 0.0;
    double centre_r = std::numeric_limits<double>::infinity();
};

DirectSamples sample_direct(const optics::TraceSystem& traced, const std::vector<optics::Step>& path, const optics::Aperture& aperture,
                            double ax_deg, double ay_deg, const PupilRect& square, int rays) {
    DirectSamples out;
    const double dx = (square.x1 - square.x0) / rays;
    const double dy = (square.y1 - square.y0) / rays;
    double sum = 0.0;
    for (int iy = 0; iy < rays; ++iy) {
        for (int ix = 0; ix < rays; ++ix) {
            const double x = square.x0 + dx * (ix + 0.5), y = square.y0 + dy * (iy + 0.5);
            const optics::Ray ray = optics::collimated_ray(ax_deg, ay_deg, x, y, 0.0);
            const optics::TraceResult r = optics::trace(traced, ray, path);
            if (r.ok() && r.stop_count > 0) {
                const double at_stop = std::hypot(r.stop_crossings[0].x, r.stop_crossings[0].y);
                if (at_stop < out.centre_r) out.centre_r = at_stop, out.centre_x = x, out.centre_y = y;
            }
            if (!ray_passes(r, aperture)) continue;
            sum += r.transmission * std::abs(ray.direction.z);
            ++out.passing;
        }
    }
    out.power = sum * dx * dy;
    return out;
}

// A square round the beam that the coarse samples found only a few of (`coarse` over `square`, `rays` a side):
// its middle, grown by the radius their count gives and two samples.
PupilRect around_beam(const DirectSamples& coarse, const PupilRect& square, int rays) {
    const double spacing = std::max(square.x1 - square.x0, square.y1 - square.y0) / rays;
    const double radius = std::sqrt(coarse.passing / std::numbers::pi) * spacing + 2.0 * spacing;
    const double half = 1.5 * radius;
    return {coarse.centre_x - half, coarse.centre_y - half, coarse.centre_x + half, coarse.centre_y + half};
}

}  // namespace

std::array<double, 3> direct_power(const optics::System& system, double ax_deg, double ay_deg, int rays,
                                   const std::vector<SpectralPass>& passes) {
    std::array<double, 3> power{};
    FlareView view;
    view.angle_x_deg = ax_deg;
    view.angle_y_deg = ay_deg;
    const std::vector<optics::Step> path = optics::direct_path(system);
    for (const SpectralPass& pass : passes.empty() ? view.passes() : passes) {
        const optics::TraceSystem traced(system, pass.wavelength_nm);
        PupilRect square = entrance_square(traced, view);
        DirectSamples s = sample_direct(traced, path, system.aperture, ax_deg, ay_deg, square, rays);
        for (int closer = 0; closer < kMaxCloser && s.passing < kMinPassing && std::isfinite(s.centre_r); ++closer) {
            square = around_beam(s, square, rays);
            s = sample_direct(traced, path, system.aperture, ax_deg, ay_deg, square, rays);
        }
        for (std::size_t c = 0; c < 3; ++c) power[c] += pass.weight[c] * s.power;
    }
    return power;
}

DirectPowerTable::DirectPowerTable(const optics::System& system, double max_field_deg, int samples, int rays,
                                   std::vector<SpectralPass> passes)
    : system_(system), passes_(std::move(passes)), rays_(rays), max_field_deg_(max_field_deg),
      power_(static_cast<std::size_t>(std::max(samples, 0))), known_(static_cast<std::size_t>(std::max(samples, 0)), 0) {
    if (samples < 2 || rays < 1 || !(max_field_deg > 0.0))
        throw std::invalid_argument(fmt::format("direct power table: {} samples of {} rays up to {} degrees", samples,
                                                rays, max_field_deg));
}

const std::array<double, 3>& DirectPowerTable::sample(int i) const {
    const auto k = static_cast<std::size_t>(std::clamp(i, 0, static_cast<int>(power_.size()) - 1));
    if (!known_[k]) {
        power_[k] = direct_power(system_, max_field_deg_ * static_cast<double>(k) / static_cast<double>(power_.size() - 1), 0.0, rays_,
                                 passes_);
        known_[k] = 1;
    }
    return power_[k];
}

// The samples of `indices` not known yet, each traced on a thread of its own (the first on this one): a
// cold run's first light needs four, about 50 ms each. Each sample is traced exactly as alone.
void DirectPowerTable::trace_missing(const std::array<int, 4>& indices) const {
    std::vector<std::size_t> missing;
    for (int i : indices) {
        const auto k = static_cast<std::size_t>(std::clamp(i, 0, static_cast<int>(power_.size()) - 1));
        if (!known_[k] && std::find(missing.begin(), missing.end(), k) == missing.end()) missing.push_back(k);
    }
    if (missing.size() < 2) return;  // sample() traces a lone one where it is
    const auto field = [&](std::size_t k) { return max_field_deg_ * static_cast<double>(k) / static_cast<double>(power_.size() - 1); };
    std::vector<std::future<std::array<double, 3>>> others;
    for (std::size_t j = 1; j < missing.size(); ++j)
        others.push_back(std::async(std::launch::async, [&, k = missing[j]] { return direct_power(system_, field(k), 0.0, rays_, passes_); }));
    power_[missing[0]] = direct_power(system_, field(missing[0]), 0.0, rays_, passes_);
    known_[missing[0]] = 1;
    for (std::size_t j = 1; j < missing.size(); ++j) {
        power_[missing[j]] = others[j - 1].get();
        known_[missing[j]] = 1;
    }
}

const DirectPowerTable& DirectPowerTable::beyond() const {
    if (!beyond_) beyond_ = std::make_shared<const DirectPowerTable>(system_, 90.0, kBeyondSamples, rays_, passes_);
    return *beyond_;
}

int DirectPowerTable::traced() const { return static_cast<int>(std::count(known_.begin(), known_.end(), 1)); }

std::array<double, 3> DirectPowerTable::at(double ax_deg, double ay_deg) const {
    const double field = std::atan(std::hypot(std::tan(ax_deg / kDegrees), std::tan(ay_deg / kDegrees))) * kDegrees;
    if (!std::isfinite(field)) return {};
    // Beyond the table (a light outside the frame, in its overscan): looked up where it is, not at the edge, whose
    // power had a light the lens cannot image add a flare that lands nowhere, and said nothing.
    if (field > max_field_deg_) return beyond().at(ax_deg, ay_deg);
    const int n = static_cast<int>(power_.size());
    const double u = std::clamp(field / max_field_deg_, 0.0, 1.0) * (n - 1);
    const int i = std::min(static_cast<int>(u), n - 2);
    const double t = u - i;
    trace_missing({i - 1, i, i + 1, i + 2});
    // Catmull-Rom through the samples around u (ends repeated); a power is never negative.
    const auto p0 = sample(i - 1), p1 = sample(i), p2 = sample(i + 1), p3 = sample(i + 2);
    std::array<double, 3> out{};
    for (std::size_t c = 0; c < 3; ++c) {
        const double v = 0.5 * (2.0 * p1[c] + (-p0[c] + p2[c]) * t + (2.0 * p0[c] - 5.0 * p1[c] + 4.0 * p2[c] - p3[c]) * t * t +
                                (-p0[c] + 3.0 * p1[c] - 3.0 * p2[c] + p3[c]) * t * t * t);
        out[c] = std::max(0.0, v);
    }
    return out;
}

void DirectPowerTable::save(const std::filesystem::path& path, const std::string& key) const {
    try_write_cache_file(path.string(), [&](std::ostream& out) {
        const auto n = static_cast<std::uint64_t>(power_.size());
        write_key(out, key);
        out.write(reinterpret_cast<const char*>(&n), sizeof(n));
        out.write(known_.data(), static_cast<std::streamsize>(known_.size()));
        out.write(reinterpret_cast<const char*>(power_.data()), static_cast<std::streamsize>(power_.size() * sizeof(power_[0])));
    });
}

bool DirectPowerTable::load(const std::filesystem::path& path, const std::string& key) {
    CacheFile in = open_cache_file(path);
    std::uint64_t n = 0;
    if (!read_key(in, key)) return false;
    if (!in.read(reinterpret_cast<char*>(&n), sizeof(n)) || n != power_.size()) return false;
    std::vector<char> known(power_.size());
    std::vector<std::array<double, 3>> power(power_.size());
    if (!in.read(known.data(), static_cast<std::streamsize>(known.size())) ||
        !in.read(reinterpret_cast<char*>(power.data()), static_cast<std::streamsize>(power.size() * sizeof(power[0]))) ||
        in.peek() != std::char_traits<char>::eof())
        return false;
    for (std::size_t k = 0; k < known.size(); ++k)
        if (known[k] && !known_[k] && plausible_power(power[k])) {
            power_[k] = power[k];
            known_[k] = 1;
        }
    return true;
}

std::string passes_key(const std::vector<SpectralPass>& passes) {
    std::string key = "passes";
    for (const SpectralPass& p : passes)
        key += fmt::format(" {:.17g}:{:.17g},{:.17g},{:.17g}", p.wavelength_nm, p.weight[0], p.weight[1], p.weight[2]);
    return key;
}

}  // namespace lensfx::flare
