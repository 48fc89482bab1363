// Track files as JSON (nlohmann_json), and the lights of a frame from them.
#include <detect/track_file.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <stdexcept>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

namespace lensfx::detect {

namespace {

using nlohmann::json;
using ojson = nlohmann::ordered_json;

constexpr const char* kFormat = "lensfx-tracks";
constexpr int kVersion = 1;

// A stored shape is repeated on a later key only when its cells change by more than this (sum of |dw|).
constexpr double kShapeChange = 0.02;

bool shape_differs(const std::optional<Shape>& a, const std::optional<Shape>& b) {
    if (a.has_value() != b.has_value()) return true;
    if (!a) return false;
    if (a->width != b->width || a->height != b->height || a->cell != b->cell) return true;
    if (std::abs(a->origin_x - b->origin_x) > 0.5 * a->cell || std::abs(a->origin_y - b->origin_y) > 0.5 * a->cell) return true;
    double d = 0.0;
    for (std::size_t i = 0; i < a->weights.size(); ++i) d += std::abs(static_cast<double>(a->weights[i]) - static_cast<double>(b->weights[i]));
    return d > kShapeChange;
}

ojson shape_json(const Shape& s) {
    return ojson{{"size", {s.width, s.height}}, {"cell", s.cell}, {"origin", {s.origin_x, s.origin_y}}, {"weights", s.weights}};
}

Light light_of(int id, const TrackKey& k) {
    Light l;
    l.id = id;
    l.x = k.x;
    l.y = k.y;
    l.flux = k.flux;
    l.extent = k.extent;
    l.weight = k.weight;
    l.clipped = k.clipped;
    l.shape = k.shape;
    return l;
}

double lerp(double a, double b, double t) { return a + (b - a) * t; }

// Reads one field with a message naming where it is.
template <typename T>
T field(const json& j, const char* key, const std::string& where) {
    const auto it = j.find(key);
    if (it == j.end()) throw std::runtime_error(fmt::format("{}: missing \"{}\"", where, key));
    try {
        return it->get<T>();
    } catch (const json::exception& e) {
        throw std::runtime_error(fmt::format("{}: \"{}\": {}", where, key, e.what()));
    }
}

template <typename T>
T field_or(const json& j, const char* key, T fallback, const std::string& where) {
    return j.contains(key) ? field<T>(j, key, where) : fallback;
}

// A number within [lo, hi], or an error naming the field.
void check_range(double v, double lo, double hi, const std::string& where, const char* what) {
    if (!std::isfinite(v)) throw std::runtime_error(fmt::format("{}: \"{}\" is not a finite number", where, what));
    if (v < lo || v > hi) throw std::runtime_error(fmt::format("{}: \"{}\" {:g} is outside [{:g}, {:g}]", where, what, v, lo, hi));
}

// A frame number: a whole JSON number in 64 bits (2^32 + 1 is not frame 1, 1.5 is not frame 1).
std::int64_t frame_field(const json& j, const std::string& where) {
    const auto it = j.find("frame");
    if (it == j.end()) throw std::runtime_error(fmt::format("{}: missing \"frame\"", where));
    if (it->is_number_unsigned() && it->get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX))
        throw std::runtime_error(fmt::format("{}: \"frame\" {} is beyond 64-bit frame numbers", where, it->dump()));
    if (!it->is_number_integer()) throw std::runtime_error(fmt::format("{}: \"frame\" {} is not a whole number", where, it->dump()));
    return it->get<std::int64_t>();
}

// A whole number in [lo, hi], or an error naming the field (no silent truncation of 2^32 + 1 or 1.5).
int whole_number(const json& v, const std::string& key, int lo, int hi, const std::string& where) {
    if (!v.is_number_integer()) throw std::runtime_error(fmt::format("{}: \"{}\" {} is not a whole number", where, key, v.dump()));
    const bool above = v.is_number_unsigned() ? v.get<std::uint64_t>() > static_cast<std::uint64_t>(hi) : v.get<std::int64_t>() > hi;
    if (above || (!v.is_number_unsigned() && v.get<std::int64_t>() < lo))
        throw std::runtime_error(fmt::format("{}: \"{}\" {} is outside [{}, {}]", where, key, v.dump(), lo, hi));
    return static_cast<int>(v.get<std::int64_t>());
}

int int_field(const json& j, const char* key, int lo, int hi, const std::string& where) {
    const auto it = j.find(key);
    if (it == j.end()) throw std::runtime_error(fmt::format("{}: missing \"{}\"", where, key));
    return whole_number(*it, key, lo, hi, where);
}

// The key's values, each checked against the bounds of track_file.h.
void check_key(const TrackKey& k, const std::string& where) {
    check_range(k.x, -kMaxTrackCoordinate, kMaxTrackCoordinate, where, "position[0]");
    check_range(k.y, -kMaxTrackCoordinate, kMaxTrackCoordinate, where, "position[1]");
    for (const char* name : {"flux[0]", "flux[1]", "flux[2]"})
        check_range(k.flux[static_cast<std::size_t>(name[5] - '0')], 0.0, kMaxTrackFlux, where, name);
    check_range(k.extent.major, 0.0, kMaxTrackExtent, where, "extent[0]");
    check_range(k.extent.minor, 0.0, kMaxTrackExtent, where, "extent[1]");
    check_range(k.extent.angle_deg, -360.0, 360.0, where, "extent[2]");
    check_range(k.weight, 0.0, 1.0, where, "weight");
}

// A footprint shape as stored, checked.
Shape shape_field(const json& js, const std::string& where) {
    Shape s;
    const json size = field<json>(js, "size", where);
    if (!size.is_array() || size.size() != 2) throw std::runtime_error(fmt::format("{}: \"size\" must be [width, height]", where));
    s.width = whole_number(size[0], "size[0]", 1, kMaxShapeSide, where);
    s.height = whole_number(size[1], "size[1]", 1, kMaxShapeSide, where);
    s.cell = field<double>(js, "cell", where);
    check_range(s.cell, 1e-6, kMaxShapeCell, where, "cell");
    const auto origin = field<std::array<double, 2>>(js, "origin", where);
    check_range(origin[0], -kMaxTrackCoordinate, kMaxTrackCoordinate, where, "origin[0]");
    check_range(origin[1], -kMaxTrackCoordinate, kMaxTrackCoordinate, where, "origin[1]");
    s.origin_x = origin[0];
    s.origin_y = origin[1];
    s.weights = field<std::vector<float>>(js, "weights", where);
    if (s.weights.size() != static_cast<std::size_t>(s.width) * static_cast<std::size_t>(s.height))
        throw std::runtime_error(fmt::format("{}: {} weights for {}x{} cells", where, s.weights.size(), s.width, s.height));
    for (float w : s.weights) check_range(static_cast<double>(w), 0.0, 1e30, where, "weights");
    return s;
}

// A track's "gain" and "exclude", written only when they differ from the defaults ("" then).
std::string track_controls_json(const Track& t) {
    std::string out;
    if (t.gain != 1.0) out += fmt::format("\"gain\": {}, ", ojson(t.gain).dump());
    if (t.exclude) out += "\"exclude\": true, ";
    return out;
}

// Reads a track's optional "gain" (a finite number >= 0) and "exclude" (a boolean).
void read_track_controls(const json& jt, const std::string& where, Track& t) {
    t.gain = field_or<double>(jt, "gain", 1.0, where);
    if (!std::isfinite(t.gain) || t.gain < 0.0 || t.gain > kMaxTrackGain)
        throw std::runtime_error(fmt::format("{}: \"gain\" must be a number from 0 to {:g}, not {}", where, kMaxTrackGain, t.gain));
    t.exclude = field_or<bool>(jt, "exclude", false, where);
}

}  // namespace

void TrackFile::append(std::int64_t frame, const std::vector<Light>& lights) {
    for (const Light& l : lights) {
        auto it = std::lower_bound(tracks.begin(), tracks.end(), l.id, [](const Track& t, int id) { return t.id < id; });
        if (it == tracks.end() || it->id != l.id) {
            Track t;
            t.id = l.id;
            it = tracks.insert(it, std::move(t));
        }
        if (!it->keys.empty() && it->keys.back().frame >= frame)
            throw std::invalid_argument(fmt::format("track {}: frame {} appended after frame {}", l.id, frame, it->keys.back().frame));
        TrackKey k;
        k.frame = frame;
        k.x = l.x;
        k.y = l.y;
        k.flux = l.flux;
        k.extent = l.extent;
        k.weight = l.weight;
        k.clipped = l.clipped;
        k.shape = l.shape;
        it->keys.push_back(std::move(k));
    }
}

std::vector<Light> TrackFile::lights_at(std::int64_t frame) const {
    std::vector<Light> out;
    for (const Track& t : tracks) {
        if (t.exclude || t.keys.empty() || frame < t.keys.front().frame || frame > t.keys.back().frame) continue;
        const auto hi = std::lower_bound(t.keys.begin(), t.keys.end(), frame, [](const TrackKey& k, std::int64_t f) { return k.frame < f; });
        Light l;
        if (hi->frame == frame) {
            l = light_of(t.id, *hi);
        } else {
            const TrackKey& a = *(hi - 1);
            const TrackKey& b = *hi;
            // Frame differences in unsigned 64 bits: exact for keys anywhere in the 64-bit range.
            const double u = static_cast<double>(static_cast<std::uint64_t>(frame) - static_cast<std::uint64_t>(a.frame)) /
                             static_cast<double>(static_cast<std::uint64_t>(b.frame) - static_cast<std::uint64_t>(a.frame));
            l = light_of(t.id, a);
            l.x = lerp(a.x, b.x, u);
            l.y = lerp(a.y, b.y, u);
            for (std::size_t c = 0; c < 3; ++c) l.flux[c] = lerp(a.flux[c], b.flux[c], u);
            l.extent.major = lerp(a.extent.major, b.extent.major, u);
            l.extent.minor = lerp(a.extent.minor, b.extent.minor, u);
            double da = b.extent.angle_deg - a.extent.angle_deg;
            da -= 180.0 * std::round(da / 180.0);
            l.extent.angle_deg = std::fmod(a.extent.angle_deg + u * da + 180.0, 180.0);
            l.weight = lerp(a.weight, b.weight, u);
        }
        l.gain = t.gain;
        if (l.weight > 0.0) out.push_back(std::move(l));
    }
    return out;
}

std::pair<std::int64_t, std::int64_t> TrackFile::frame_range() const {
    std::int64_t first = 0, last = -1;
    bool any = false;
    for (const Track& t : tracks) {
        if (t.keys.empty()) continue;
        first = any ? std::min(first, t.keys.front().frame) : t.keys.front().frame;
        last = any ? std::max(last, t.keys.back().frame) : t.keys.back().frame;
        any = true;
    }
    return {first, last};
}

std::string to_json_text(const TrackFile& file) {
    // One line per key, so a shot reads (and diffs) as one line per light and frame.
    std::string out = fmt::format("{{\n \"format\": \"{}\",\n \"version\": {},\n \"width\": {},\n \"height\": {},\n \"tracks\": [",
                                  kFormat, kVersion, file.width, file.height);
    for (std::size_t ti = 0; ti < file.tracks.size(); ++ti) {
        const Track& t = file.tracks[ti];
        out += fmt::format("{}\n  {{\"id\": {}, \"origin\": {}, {}\"keys\": [", ti ? "," : "", t.id, ojson(t.origin).dump(),
                           track_controls_json(t));
        std::optional<Shape> stored;
        for (std::size_t ki = 0; ki < t.keys.size(); ++ki) {
            const TrackKey& k = t.keys[ki];
            ojson jk{{"frame", k.frame},
                     {"position", {k.x, k.y}},
                     {"flux", {k.flux[0], k.flux[1], k.flux[2]}},
                     {"extent", {k.extent.major, k.extent.minor, k.extent.angle_deg}},
                     {"weight", k.weight}};
            if (k.clipped) jk["clipped"] = true;
            if (shape_differs(k.shape, stored)) {
                jk["shape"] = k.shape ? shape_json(*k.shape) : ojson(nullptr);
                stored = k.shape;
            }
            out += fmt::format("{}\n   {}", ki ? "," : "", jk.dump());
        }
        out += "\n  ]}";
    }
    out += "\n ]\n}\n";
    return out;
}

TrackFile parse_track_json(std::string_view text, const std::string& name) {
    json doc;
    try {
        doc = json::parse(text.begin(), text.end());
    } catch (const json::exception& e) {  // parse_error, and out_of_range for a number beyond double (1e310)
        throw std::runtime_error(fmt::format("{}: not valid JSON: {}", name, e.what()));
    }
    if (!doc.is_object()) throw std::runtime_error(fmt::format("{}: expected a JSON object", name));
    if (field_or<std::string>(doc, "format", kFormat, name) != kFormat)
        throw std::runtime_error(fmt::format("{}: \"format\" is not \"{}\"", name, kFormat));
    // Compared as JSON: converting a hostile number (1e30) to int first would be undefined.
    const json version = doc.contains("version") ? doc["version"] : json(kVersion);
    if (version != json(kVersion))
        throw std::runtime_error(fmt::format("{}: track file version {} (this program reads {})", name, version.dump(), kVersion));

    TrackFile file;
    file.width = doc.contains("width") ? int_field(doc, "width", 0, kMaxFrameSide, name) : 0;
    file.height = doc.contains("height") ? int_field(doc, "height", 0, kMaxFrameSide, name) : 0;
    const json tracks = field<json>(doc, "tracks", name);
    if (!tracks.is_array()) throw std::runtime_error(fmt::format("{}: \"tracks\" must be an array", name));
    for (std::size_t ti = 0; ti < tracks.size(); ++ti) {
        const json& jt = tracks[ti];
        const std::string twhere = fmt::format("{}: track #{}", name, ti);
        Track t;
        t.id = int_field(jt, "id", INT_MIN, INT_MAX, twhere);
        const std::string where = fmt::format("{}: track id {}", name, t.id);
        t.origin = field_or<std::string>(jt, "origin", "manual", where);
        read_track_controls(jt, where, t);
        const json keys = field<json>(jt, "keys", where);
        if (!keys.is_array() || keys.empty()) throw std::runtime_error(fmt::format("{}: \"keys\" must be a non-empty array", where));
        std::optional<Shape> carried;
        for (std::size_t ki = 0; ki < keys.size(); ++ki) {
            const json& jk = keys[ki];
            const std::string kwhere = fmt::format("{} key {}", where, ki);
            TrackKey k;
            k.frame = frame_field(jk, kwhere);
            if (!t.keys.empty() && k.frame <= t.keys.back().frame)
                throw std::runtime_error(fmt::format("{}: frame {} does not follow frame {}", kwhere, k.frame, t.keys.back().frame));
            const auto pos = field<std::array<double, 2>>(jk, "position", kwhere);
            k.x = pos[0];
            k.y = pos[1];
            k.flux = field<std::array<double, 3>>(jk, "flux", kwhere);
            const auto ext = field_or<std::array<double, 3>>(jk, "extent", {0.0, 0.0, 0.0}, kwhere);
            k.extent = {ext[0], ext[1], ext[2]};
            k.weight = field_or<double>(jk, "weight", 1.0, kwhere);
            k.clipped = field_or<bool>(jk, "clipped", false, kwhere);
            check_key(k, kwhere);
            if (jk.contains("shape")) {
                const json& js = jk["shape"];
                if (js.is_null()) {
                    carried.reset();
                } else {
                    const std::string swhere = kwhere + " shape";
                    Shape s = shape_field(js, swhere);
                    carried = std::move(s);
                }
            }
            k.shape = carried;
            t.keys.push_back(std::move(k));
        }
        file.tracks.push_back(std::move(t));
    }
    std::sort(file.tracks.begin(), file.tracks.end(), [](const Track& a, const Track& b) { return a.id < b.id; });
    for (std::size_t i = 1; i < file.tracks.size(); ++i)
        if (file.tracks[i].id == file.tracks[i - 1].id)
            throw std::runtime_error(fmt::format("{}: track id {} appears twice", name, file.tracks[i].id));
    return file;
}

void write_track_file(const std::filesystem::path& path, const TrackFile& file) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error(fmt::format("{}: cannot open for writing", path.string()));
    out << to_json_text(file);
    out.close();
    if (!out) throw std::runtime_error(fmt::format("{}: write failed", path.string()));
}

TrackFile read_track_file(const std::filesystem::path& path) {
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (!ec && std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))  // a FIFO would block
        throw std::runtime_error(fmt::format("{}: not a regular file (a directory, device or named pipe)", path.string()));
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(fmt::format("{}: cannot open track file", path.string()));
    std::ostringstream ss;
    ss << in.rdbuf();
    return parse_track_json(ss.str(), path.string());
}

}  // namespace lensfx::detect
