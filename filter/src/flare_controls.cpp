// The compositor's controls of the flare stage (filter/flare_controls.h): options, the image the detector
// sees (matte, added lights), and the run's summary of lights found.
#include <filter/flare_controls.h>

#include <CLI/CLI.hpp>
#include <filter/option_checks.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <stdexcept>

#include <fmt/core.h>

#include <detect/track_file.h>
#include <filter/frame_view.h>
#include <filter/image_io.h>
#include <filter/sequence.h>

namespace lensfx::filter {

namespace {

// The brightest VALUE an added light may have: its largest disc (radius 4096 px) then sums to under a
// track file's largest flux (detect::kMaxTrackFlux), far inside float range after every gain.
constexpr double kMaxAddedLightValue = 1e7;

// The numbers of a comma-separated list, each one whole and finite.
std::vector<double> parse_numbers(std::string_view text) {
    std::vector<double> out;
    std::size_t begin = 0;
    while (begin <= text.size()) {
        const std::size_t end = std::min(text.find(',', begin), text.size());
        const std::string part(text.substr(begin, end - begin));
        // strtod, not stod: a value too small for a normal double (1e-310) is a number, read as the
        // subnormal (or 0) it rounds to, not an error that would call it not finite.
        char* used = nullptr;
        const double v = std::strtod(part.c_str(), &used);
        if (part.empty() || used != part.c_str() + part.size() || !std::isfinite(v)) throw std::invalid_argument(part);
        out.push_back(v);
        begin = end + 1;
    }
    return out;
}

// The fraction of display-window pixel [px, px+1) x [py, py+1) inside the disc: exact for pixels wholly in
// or out, 8 x 8 samples on the rim.
double covered_fraction(const AddedLight& l, double px, double py) {
    const double nx = std::clamp(l.x, px, px + 1.0) - l.x, ny = std::clamp(l.y, py, py + 1.0) - l.y;
    if (nx * nx + ny * ny >= l.radius * l.radius) return 0.0;
    const double fx = std::max(std::abs(px - l.x), std::abs(px + 1.0 - l.x));
    const double fy = std::max(std::abs(py - l.y), std::abs(py + 1.0 - l.y));
    if (fx * fx + fy * fy <= l.radius * l.radius) return 1.0;
    int inside = 0;
    for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 8; ++i) inside += std::hypot(px + (i + 0.5) / 8.0 - l.x, py + (j + 0.5) / 8.0 - l.y) < l.radius;
    return inside / 64.0;
}

// Display-window pixels [x0, x1) x [y0, y1) a disc can touch.
struct Rect {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};
Rect disc_bounds(const AddedLight& l) {
    return {static_cast<int>(std::floor(l.x - l.radius)), static_cast<int>(std::floor(l.y - l.radius)),
            static_cast<int>(std::ceil(l.x + l.radius)), static_cast<int>(std::ceil(l.y + l.radius))};
}

// An added light is painted into the detector's copy of the plate, which grows to reach it: a light more
// than half the display window's width or height outside it is refused (the copy stays within 4 frames).
void check_within_reach(const AddedLight& l, const ImageSpec& spec) {
    const double w = spec.full_width, h = spec.full_height;
    if (l.x < -0.5 * w || l.x > 1.5 * w || l.y < -0.5 * h || l.y > 1.5 * h)
        throw std::runtime_error(fmt::format("--add-light {:g},{:g}: more than half the {}x{} display window outside it",
                                             l.x, l.y, spec.full_width, spec.full_height));
}

// What `l` adds to the frame's plate (UnheldLight): pixels outside the data window are black.
std::array<double, 3> unheld_flux(const AddedLight& l, const Frame& frame) {
    const int dx0 = frame.spec.x - frame.spec.full_x, dy0 = frame.spec.y - frame.spec.full_y;
    const Rect r = disc_bounds(l);
    std::array<double, 3> flux{};
    for (int y = r.y0; y < r.y1; ++y)
        for (int x = r.x0; x < r.x1; ++x) {
            const double a = covered_fraction(l, x, y);
            const int fx = x - dx0, fy = y - dy0;
            const bool inside = fx >= 0 && fy >= 0 && fx < frame.spec.width && fy < frame.spec.height;
            const float* p = inside ? frame.rgb.data() + (static_cast<std::size_t>(fy) * static_cast<std::size_t>(frame.spec.width) +
                                                          static_cast<std::size_t>(fx)) * 3
                                    : nullptr;
            for (std::size_t c = 0; c < 3; ++c) {
                const double plate = p && std::isfinite(p[c]) ? static_cast<double>(p[c]) : 0.0;
                flux[c] += a * std::max(0.0, l.value - plate);
            }
        }
    return flux;
}

double clamp01(float v) { return std::isfinite(v) ? std::clamp(static_cast<double>(v), 0.0, 1.0) : 0.0; }

}  // namespace

AddedLight parse_added_light(std::string_view text) {
    std::vector<double> v;
    try {
        v = parse_numbers(text);
    } catch (const std::exception&) {
        v.clear();
    }
    if (v.size() < 3 || v.size() > 4)
        throw std::invalid_argument(fmt::format("--add-light {}: expected X,Y,VALUE or X,Y,VALUE,RADIUS (finite numbers)", text));
    AddedLight light{v[0], v[1], v[2], v.size() == 4 ? v[3] : AddedLight{}.radius};
    if (light.value < 0.0 || !(light.radius > 0.0) || light.radius > 4096.0)
        throw std::invalid_argument(fmt::format("--add-light {}: VALUE must be >= 0 and RADIUS in (0, 4096] px", text));
    if (!(std::abs(light.x) <= detect::kMaxTrackCoordinate) || !(std::abs(light.y) <= detect::kMaxTrackCoordinate) ||
        !(light.value <= kMaxAddedLightValue))
        throw std::invalid_argument(fmt::format("--add-light {}: X and Y must be within {:g} px and VALUE at most {:g}", text,
                                                detect::kMaxTrackCoordinate, kMaxAddedLightValue));
    return light;
}

void add_part_gain_options(CLI::App& app, double& ghost_gain, double& starburst_gain, const std::string& group) {
    app.add_option("--ghost-gain", ghost_gain, "Scale of the ghosts (1 = physical; 0 leaves them out)")
        ->capture_default_str()->group(group)->check(finite_non_negative());
    app.add_option("--starburst-gain", starburst_gain,
                   "Starburst energy relative to the light's own energy through the lens (1 = physical; 0 leaves it out)")
        ->capture_default_str()->group(group)->check(finite_non_negative());
}

void add_flare_control_options(CLI::App& app, FlareControls& c, const std::string& group) {
    app.add_option("--extended-gain", c.extended_gain,
                   "Scale of the whole flare of extended sources (windows, backdrops, sky: sources wider than 16 px)")
        ->capture_default_str()->group(group)->check(finite_non_negative());
    app.add_option("--matte", c.matte, "Matte image or sequence pattern: its white pixels never become lights")->group(group);
    app.add_option("--matte-channel", c.matte_channel, "A channel of the input used as a matte (white: never a light)")->group(group);
    app.add_option("--add-light", c.add_lights,
                   "X,Y,VALUE[,RADIUS]: a disc of VALUE (radius 2 px) at display-window pixel X,Y lights the lens as if "
                   "the plate held it; the plate is unchanged, the flare holds the disc where the plate lacks it (repeatable)")
        ->group(group)->check(parsed_by([](const std::string& t) { parse_added_light(t); }, "--add-light", "X,Y,VALUE[,RADIUS]"));
}

MatteImage read_matte(const std::string& path, const MemoryBudget& budget) {
    Frame frame;
    try {
        frame = read_image(path, PfmOrder::automatic, budget);
    } catch (const std::exception& e) {
        throw std::runtime_error(fmt::format("--matte {}: {}", path, e.what()));
    }
    const ImageSpec& spec = frame.spec;
    std::vector<int> channels;
    if (spec.channel_index("R") >= 0 && spec.channel_index("G") >= 0 && spec.channel_index("B") >= 0) {
        channels = {spec.channel_index("R"), spec.channel_index("G"), spec.channel_index("B")};
    } else {
        for (int c = 0; c < spec.nchannels() && channels.empty(); ++c)
            if (spec.channel_name(c) != "A") channels.push_back(c);
        if (channels.empty()) channels.push_back(0);
    }
    const std::vector<float> data = channels_as_float(frame, channels);
    MatteImage m;
    m.full_width = spec.full_width, m.full_height = spec.full_height;
    m.x = spec.x - spec.full_x, m.y = spec.y - spec.full_y, m.width = spec.width, m.height = spec.height;
    m.value.resize(static_cast<std::size_t>(spec.width) * static_cast<std::size_t>(spec.height));
    const std::size_t n = channels.size();
    for (std::size_t i = 0; i < m.value.size(); ++i) {
        double sum = 0.0;
        for (std::size_t c = 0; c < n; ++c) sum += clamp01(data[i * n + c]);
        m.value[i] = static_cast<float>(sum / static_cast<double>(n));
    }
    return m;
}

float MatteImage::at(int dx, int dy) const {
    const std::int64_t mx = std::int64_t{dx} - x, my = std::int64_t{dy} - y;
    if (mx < 0 || my < 0 || mx >= width || my >= height) return 0.0f;
    return value[static_cast<std::size_t>(my) * static_cast<std::size_t>(width) + static_cast<std::size_t>(mx)];
}

void paint_light(const AddedLight& light, float* rgb, int x0, int y0, int width, int height) {
    const Rect r = disc_bounds(light);
    for (int y = std::max(r.y0, y0); y < std::min(r.y1, y0 + height); ++y)
        for (int x = std::max(r.x0, x0); x < std::min(r.x1, x0 + width); ++x) {
            const double a = covered_fraction(light, x, y);
            if (a <= 0.0) continue;
            float* p = rgb + (static_cast<std::size_t>(y - y0) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x - x0)) * 3;
            for (int c = 0; c < 3; ++c) p[c] = static_cast<float>(static_cast<double>(p[c]) + (light.value - static_cast<double>(p[c])) * a);
        }
}

DetectionInput::DetectionInput(const FlareControls& controls, const MemoryBudget& budget)
    : matte_(controls.matte), budget_(budget), matte_channel_(controls.matte_channel) {
    for (const std::string& text : controls.add_lights) lights_.push_back(parse_added_light(text));
    if (matte_.empty()) return;
    matte_is_sequence_ = parse_pattern(matte_).is_sequence;
    if (!matte_is_sequence_) {
        still_ = read_matte(matte_, budget_);
    }
}

DetectionInput::Matte DetectionInput::matte_for(const Frame& frame) {
    if (still_) return *still_;
    return read_matte(parse_pattern(matte_).path(frame.number), budget_);
}

// Multiplies the plate's pixels in the buffer by 1 - matte (the buffer's pixel (0, 0) at display (x0, y0)).
void DetectionInput::apply_matte(const Matte& m, const Frame& frame, int x0, int y0, int width) {
    if (m.full_width != frame.spec.full_width || m.full_height != frame.spec.full_height)
        throw std::runtime_error(fmt::format("--matte {}: {}x{}, the frame {}x{}", matte_, m.full_width, m.full_height,
                                             frame.spec.full_width, frame.spec.full_height));
    const int dx0 = frame.spec.x - frame.spec.full_x, dy0 = frame.spec.y - frame.spec.full_y;
    for (int y = dy0; y < dy0 + frame.spec.height; ++y)
        for (int x = dx0; x < dx0 + frame.spec.width; ++x) {
            const bool inside = x >= 0 && y >= 0 && x < m.full_width && y < m.full_height;
            const float keep = inside ? 1.0f - m.at(x, y) : 1.0f;
            float* p = &buffer_[(static_cast<std::size_t>(y - y0) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x - x0)) * 3];
            for (int c = 0; c < 3; ++c) p[c] *= keep;
        }
}

void DetectionInput::apply_matte_channel(const Frame& frame, int x0, int y0, int width) {
    const int index = frame.spec.channel_index(matte_channel_);
    if (index < 0) {
        std::string names;
        for (const std::string& n : frame.spec.channelnames) names += (names.empty() ? "" : ", ") + n;
        throw std::runtime_error(fmt::format("--matte-channel {}: the frame has no such channel (it has {})", matte_channel_, names));
    }
    const std::vector<float> matte = channels_as_float(frame, {index});
    const int dx0 = frame.spec.x - frame.spec.full_x, dy0 = frame.spec.y - frame.spec.full_y;
    for (int y = 0; y < frame.spec.height; ++y)
        for (int x = 0; x < frame.spec.width; ++x) {
            const auto keep = static_cast<float>(1.0 - clamp01(matte[static_cast<std::size_t>(y) * static_cast<std::size_t>(frame.spec.width) + static_cast<std::size_t>(x)]));
            float* p = &buffer_[(static_cast<std::size_t>(y + dy0 - y0) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x + dx0 - x0)) * 3];
            for (int c = 0; c < 3; ++c) p[c] *= keep;
        }
}

detect::ImageView DetectionInput::view(const Frame& frame) {
    if (!changes_the_plate()) return rgb_view(frame);
    const int dx0 = frame.spec.x - frame.spec.full_x, dy0 = frame.spec.y - frame.spec.full_y;
    Rect region{dx0, dy0, dx0 + frame.spec.width, dy0 + frame.spec.height};
    for (const AddedLight& l : lights_) {
        check_within_reach(l, frame.spec);
        const Rect d = disc_bounds(l);
        region = {std::min(region.x0, d.x0), std::min(region.y0, d.y0), std::max(region.x1, d.x1), std::max(region.y1, d.y1)};
    }
    const int width = region.x1 - region.x0, height = region.y1 - region.y0;
    buffer_.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3, 0.0f);
    for (int y = 0; y < frame.spec.height; ++y)
        std::copy_n(frame.rgb.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(frame.spec.width) * 3,
                    static_cast<std::size_t>(frame.spec.width) * 3,
                    buffer_.data() + (static_cast<std::size_t>(y + dy0 - region.y0) * static_cast<std::size_t>(width) +
                                      static_cast<std::size_t>(dx0 - region.x0)) * 3);
    if (!matte_.empty()) apply_matte(matte_for(frame), frame, region.x0, region.y0, width);
    if (!matte_channel_.empty()) apply_matte_channel(frame, region.x0, region.y0, width);
    unheld_.clear();
    for (const AddedLight& l : lights_) {
        paint_light(l, buffer_.data(), region.x0, region.y0, width, height);
        unheld_.push_back({l, unheld_flux(l, frame)});
    }
    detect::ImageView v;
    v.data = buffer_.data();
    v.width = width;
    v.height = height;
    v.channels = 3;
    v.x_offset = region.x0;
    v.y_offset = region.y0;
    return v;
}

namespace {

// What describe adds for lights that added nothing: none, some or all of them outside the lens's field.
std::string outside_field(const LightSummary& s) {
    if (s.lights_outside_field == 0) return {};
    long long lights = 0;
    for (int n : s.lights_per_frame) lights += n;
    if (s.lights_outside_field >= lights)
        return "; no flare was added: every light lies outside the field the lens images (check --fov and --sensor)";
    return fmt::format("; {} of the lights lie outside the field the lens images and add no flare", s.lights_outside_field);
}

// What describe adds for --add-light discs below the threshold (the detector cannot find them).
std::string dropped_added(const LightSummary& s) {
    std::string out;
    for (const std::string& text : s.added_below_threshold)
        out += fmt::format("; --add-light {} is below the threshold {} and adds no light", text, s.threshold_text);
    return out;
}

}  // namespace

std::string describe(const LightSummary& s) {
    const std::size_t frames = s.lights_per_frame.size();
    const std::string of_frames = fmt::format("{} frame{}", frames, frames == 1 ? "" : "s");
    std::vector<int> sorted = s.lights_per_frame;
    std::sort(sorted.begin(), sorted.end());
    if (!sorted.empty() && sorted.back() > 0) {
        std::string culled = s.ghosts_drawn > 0 || s.ghosts_culled > 0 ? fmt::format(", ghosts drawn {}", s.ghosts_drawn) : std::string();
        if (s.ghosts_culled > 0) culled += fmt::format(", culled against the plate {}", s.ghosts_culled);
        return fmt::format("lensfx: {}, lights per frame min {}, median {}, max {}{}{}{}", of_frames, sorted.front(),
                           sorted[(sorted.size() - 1) / 2], sorted.back(), culled, outside_field(s), dropped_added(s));
    }
    if (!s.tracks.empty()) return fmt::format("lensfx: no light in any of {} from track file {}", of_frames, s.tracks);
    const std::string threshold = s.threshold_text.find("ev") != std::string::npos
                                      ? fmt::format("{} ({:.4g} on that frame)", s.threshold_text, s.threshold_there)
                                      : s.threshold_text;
    if (s.brightest_luminance < s.threshold_there)
        return fmt::format("lensfx: no light in any of {}: the brightest luminance is {:.4g}, below the threshold {} "
                           "(lower --threshold, or give one with --add-light){}",
                           of_frames, s.brightest_luminance, threshold, dropped_added(s));
    return fmt::format("lensfx: no light in any of {}: the brightest luminance {:.4g} reaches the threshold {}, but its "
                       "sources hold too little of the frame's light to show (or --min-light left them out)",
                       of_frames, s.brightest_luminance, threshold);
}

}  // namespace lensfx::filter
