// Follows detected sources from frame to frame: gated greedy association, alpha-beta smoothing of position
// and flux, births and deaths with weight ramps, threshold hysteresis, coasting through short occlusions,
// and a reset at cuts. Deterministic: the same detections in the same order give the same lights.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include <detect/image_view.h>
#include <detect/source.h>

namespace lensfx::detect {

struct TrackerOptions {
    double gate_px = 24.0;           // largest distance from a track's prediction to its detection
    double gate_flux_ratio = 4.0;    // largest luminous-flux ratio (either way) between track and detection
    double position_alpha = 0.5;     // alpha-beta gains of the position filter; beta <= 0 means the
    double position_beta = 0.0;      //   critically damped value alpha^2 / (2 - alpha)
    double flux_alpha = 0.3;         // same for the RGB flux
    double flux_beta = 0.0;
    double extent_alpha = 0.3;       // exponential smoothing of the extent
    int coast_frames = 3;            // frames a track keeps its weight without a detection (occlusion)
    int fade_in_frames = 4;          // weight ramp of a light born mid-shot (0 -> 1)
    int fade_out_frames = 4;         // weight ramp of a light that died (1 -> 0)
    double cut_threshold = 0.5;      // L1 distance of consecutive per-stop luminance histograms (0..2)

    // Throws std::invalid_argument naming the option when a value is out of range.
    void validate() const;
};

class Tracker {
public:
    explicit Tracker(TrackerOptions options = {});

    // Feeds the next frame's detection; returns the lights of that frame, by increasing id. Sources born
    // need their peak at the detection's birth threshold; tracks go on down to its low threshold.
    [[nodiscard]] std::vector<Light> update(const Detection& detection);

    // Forgets every track (ids keep increasing); the next frame starts like the first.
    void reset();

    [[nodiscard]] bool last_was_cut() const { return last_was_cut_; }
    [[nodiscard]] int frames_seen() const { return frames_; }
    [[nodiscard]] const TrackerOptions& options() const { return options_; }

private:
    struct Track {
        int id = 0;
        double x = 0.0, y = 0.0, vx = 0.0, vy = 0.0;
        std::array<double, 3> flux{}, dflux{};
        Extent extent;
        bool clipped = false;
        std::optional<Shape> shape;
        double weight = 0.0;
        int updates = 0;  // detections matched so far
        int missed = 0;   // consecutive frames without one
    };

    struct Prediction {  // where a track is expected in this frame, before its detection
        double x = 0.0, y = 0.0;
        std::array<double, 3> flux{};
    };
    struct Association {
        std::vector<int> match_of_track;  // source index per track, -1 when none
        std::vector<bool> source_taken;   // per source
    };

    // The steps of update, in order.
    void forget_tracks_at_cut(const std::vector<float>& histogram);
    [[nodiscard]] std::vector<Prediction> predict() const;
    [[nodiscard]] Association associate(const std::vector<Prediction>& pred, const std::vector<Source>& sources) const;
    void coast(Track& tr, const Prediction& p) const;
    void correct(Track& tr, const Prediction& p, const Source& s) const;
    void start_tracks(const Detection& detection, const std::vector<bool>& source_taken);
    [[nodiscard]] std::vector<Light> visible_lights() const;

    static void start_velocity(Track& tr, const Source& s);
    void filter_motion(Track& tr, const Prediction& p, const Source& s) const;
    static void smooth_extent(Extent& e, const Extent& seen, double alpha);
    [[nodiscard]] double fade_in_step() const;
    [[nodiscard]] double fade_out_step() const;

    TrackerOptions options_;
    std::vector<Track> tracks_;
    std::vector<float> previous_histogram_;
    int next_id_ = 1;
    int frames_ = 0;
    bool fresh_ = true;  // the next frame is the first of a shot (start or after a cut)
    bool last_was_cut_ = false;
};

// L1 distance between two per-stop histograms (FrameStats::histogram), in [0, 2].
double histogram_distance(const std::vector<float>& a, const std::vector<float>& b);

}  // namespace lensfx::detect
