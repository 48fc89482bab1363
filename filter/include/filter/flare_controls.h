// A compositor's controls of the flare on footage, beside the physical model: gains for the ghosts, the
// starburst and extended sources; a matte that keeps parts of the plate from becoming lights; lights added
// by hand; and what the run found (lights per frame, the brightest luminance when none was found).
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>


#include <detect/image_view.h>
#include <filter/frame.h>
#include <optics/memory_budget.h>

namespace CLI {
class App;
}

namespace lensfx::filter {

// A disc of `value` (R = G = B) and `radius` px at display-window pixel position (x, y) (pixel centres at
// i + 0.5): what `--add-light X,Y,VALUE[,RADIUS]` puts into the image the detector sees; what the plate
// lacks of it is drawn as its starburst's core with the flare.
struct AddedLight {
    double x = 0.0;
    double y = 0.0;
    double value = 0.0;
    double radius = 2.0;
};

// "X,Y,VALUE" or "X,Y,VALUE,RADIUS"; throws std::invalid_argument naming the option and the text.
AddedLight parse_added_light(std::string_view text);

struct FlareControls {
    double ghost_gain = 1.0;     // scales the ghosts (1 = physical)
    double extended_gain = 1.0;  // scales the whole flare of extended sources (those with a shape)
    std::string matte;           // image or sequence pattern: white pixels never become lights
    std::string matte_channel;   // a channel of the input used as such a matte
    std::vector<std::string> add_lights;  // --add-light texts, parsed by DetectionInput
};

// Adds --ghost-gain and --starburst-gain, worded the same for `lensfx` and `lensfx flare`.
void add_part_gain_options(CLI::App& app, double& ghost_gain, double& starburst_gain, const std::string& group);

// Adds --extended-gain, --matte, --matte-channel and --add-light (--ghost-gain comes with
// add_part_gain_options).
void add_flare_control_options(CLI::App& app, FlareControls& controls, const std::string& group);

// The image the detector sees: the plate with the matte's white taken out (each pixel times 1 - matte,
// the matte clamped to [0, 1]) and the added lights painted in (antialiased discs over the result), over
// the data window grown to hold the discs. The frame itself is never changed. Without a matte or added
// lights it is the frame's own RGB buffer, at no cost.
// A matte image: its values over its data window, which lies at (x, y) from its display window's corner.
struct MatteImage {
    int full_width = 0, full_height = 0;      // the display window it covers (must be the frame's)
    int x = 0, y = 0, width = 0, height = 0;  // its data window, relative to the display window
    std::vector<float> value;                 // over the data window, row 0 at the top, in [0, 1]

    // The value at display-window pixel (dx, dy): 0 outside the data window.
    [[nodiscard]] float at(int dx, int dy) const;
};

// An added light and the light it adds to the plate under it, per channel (sum over its disc of the covered
// fraction times value - plate, where the plate is the darker): the image of it the plate does not hold.
struct UnheldLight {
    AddedLight light;
    std::array<double, 3> flux{};
};

class DetectionInput {
public:
    // Parses --add-light and reads a still matte, sized against `budget` (--memory-limit).
    explicit DetectionInput(const FlareControls& controls, const MemoryBudget& budget = {});
    [[nodiscard]] bool changes_the_plate() const { return !matte_.empty() || !matte_channel_.empty() || !lights_.empty(); }
    // The view for this frame (valid until the next call). Throws naming the matte file or channel.
    detect::ImageView view(const Frame& frame);
    // The added lights of the last view() with what each adds to that frame's plate.
    [[nodiscard]] const std::vector<UnheldLight>& unheld() const { return unheld_; }

private:
    using Matte = MatteImage;
    std::string matte_;           // file or pattern
    bool matte_is_sequence_ = false;
    MemoryBudget budget_;
    std::optional<Matte> still_;  // a matte without a frame token, read once
    std::string matte_channel_;
    std::vector<AddedLight> lights_;
    std::vector<UnheldLight> unheld_;
    std::vector<float> buffer_;

    Matte matte_for(const Frame& frame);
    void apply_matte(const Matte& matte, const Frame& frame, int x0, int y0, int width);
    void apply_matte_channel(const Frame& frame, int x0, int y0, int width);
};

// Reads a matte image: the mean of its colour channels (or its one channel, or A when it has nothing
// else), clamped to [0, 1], NaN as 0, over its data window (outside it the matte is 0, and takes no memory:
// a hostile display window costs nothing). Sized against `budget`; throws naming the file.
MatteImage read_matte(const std::string& path, const MemoryBudget& budget);

// Adds `light`, antialiased, over a float RGB buffer of width x height whose pixel (0, 0) lies at
// display-window position (x0, y0): each pixel becomes mix(pixel, value, covered fraction).
void paint_light(const AddedLight& light, float* rgb, int x0, int y0, int width, int height);

// What the flare stage found over a run: lights per frame, and the brightest luminance when none.
struct LightSummary {
    std::vector<int> lights_per_frame;   // lights rendered (after --min-light), per processed frame
    double brightest_luminance = 0.0;    // over every frame the detector saw
    double threshold_there = 0.0;        // the resolved threshold on the frame holding that luminance
    std::string threshold_text;          // as given: "20", "+6ev"
    std::string tracks;                  // the track file, when lights came from one
    long long ghosts_drawn = 0;          // ghost draws (per light and wavelength) over the run
    long long ghosts_culled = 0;         // left out by scene culling (--visibility) over the run
    long long lights_outside_field = 0;  // lights found whose light the lens does not image (no flare), over the run
    std::vector<std::string> added_below_threshold;  // --add-light texts whose value is below a frame's threshold
};

// The one stderr line for the end of a run: "lensfx: 24 frames, lights per frame min 1, median 2, max 2",
// or, when no frame had a light, why (the brightest luminance against the threshold, or the track file);
// lights that added no flare (outside the field the lens images) and --add-light discs too dim to become
// lights are said there too.
std::string describe(const LightSummary& summary);

}  // namespace lensfx::filter
