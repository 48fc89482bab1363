// An OCIO config and the names asked of it (filter/colour/config.h).
#include <filter/colour/config.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

#include <fmt/core.h>

#include "ocio_parts.h"

namespace lensfx::colour {

ColourConfig ColourConfig::builtin_config() {
    ColourConfig c;
    c.config_ = make_builtin_config();
    c.source_ = "built-in";
    c.builtin_ = true;
    return c;
}

ColourConfig ColourConfig::load(const std::string& path) {
    std::string file = path;
    if (file.empty()) {
        const char* env = std::getenv("OCIO");
        if (env == nullptr || *env == '\0') return builtin_config();
        file = env;
    }
    ColourConfig c;
    try {
        c.config_ = OCIO::Config::CreateFromFile(file.c_str());
        c.config_->validate();
    } catch (const OCIO::Exception& e) {
        throw std::runtime_error(fmt::format("OCIO config '{}'{}: {}", file,
                                             path.empty() ? " (from $OCIO)" : "", e.what()));
    }
    c.source_ = file;
    return c;
}

std::string ColourConfig::serialize() const {
    std::ostringstream os;
    config_->serialize(os);
    return os.str();
}

std::vector<std::string> ColourConfig::colour_spaces() const {
    std::vector<std::string> v;
    const int n = config_->getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL);
    for (int i = 0; i < n; ++i)
        v.emplace_back(config_->getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL, i));
    return v;
}

std::vector<std::string> ColourConfig::displays() const {
    std::vector<std::string> v;
    for (int i = 0; i < config_->getNumDisplays(); ++i) v.emplace_back(config_->getDisplay(i));
    return v;
}

std::vector<std::string> ColourConfig::views(const std::string& display) const {
    std::vector<std::string> v;
    for (int i = 0; i < config_->getNumViews(display.c_str()); ++i) v.emplace_back(config_->getView(display.c_str(), i));
    return v;
}

std::vector<std::string> ColourConfig::looks() const {
    std::vector<std::string> v;
    for (int i = 0; i < config_->getNumLooks(); ++i) v.emplace_back(config_->getLookNameByIndex(i));
    return v;
}

std::string ColourConfig::default_display() const { return config_->getDefaultDisplay(); }

std::string ColourConfig::default_view(const std::string& display) const {
    return config_->getDefaultView(display.c_str());
}

void ColourConfig::check_colour_space(const std::string& name) const {
    if (!config_->getColorSpace(name.c_str()))
        throw std::runtime_error(fmt::format("unknown colour space '{}' in OCIO config {}; valid: {}", name,
                                             source_, join(colour_spaces())));
}

void ColourConfig::check_display_view(const std::string& display, const std::string& view) const {
    const auto ds = displays();
    if (std::find(ds.begin(), ds.end(), display) == ds.end())
        throw std::runtime_error(
            fmt::format("unknown display '{}' in OCIO config {}; valid: {}", display, source_, join(ds)));
    const auto vs = views(display);
    if (std::find(vs.begin(), vs.end(), view) == vs.end())
        throw std::runtime_error(fmt::format("unknown view '{}' for display '{}' in OCIO config {}; valid: {}",
                                             view, display, source_, join(vs)));
}

void ColourConfig::check_looks(const std::string& looks) const {
    // OCIO look strings: names separated by ',' or ':', each optionally prefixed by '+' or '-'; '|' separates
    // fallbacks.
    std::string token;
    auto check = [&] {
        auto b = token.find_first_not_of(" \t+-");
        auto e = token.find_last_not_of(" \t");
        const std::string look = b == std::string::npos ? std::string() : token.substr(b, e - b + 1);
        token.clear();
        if (look.empty()) return;
        if (!config_->getLook(look.c_str()))
            throw std::runtime_error(fmt::format("unknown look '{}' in OCIO config {}; valid: {}", look, source_,
                                                 join(this->looks())));
    };
    for (char ch : looks) {
        if (ch == ',' || ch == ':' || ch == '|')
            check();
        else
            token += ch;
    }
    check();
}

ColourOptions ColourConfig::checked_output_names(ColourOptions options) const {
    if (options.display.empty()) options.display = default_display();
    const auto ds = displays();
    if (std::find(ds.begin(), ds.end(), options.display) == ds.end()) check_display_view(options.display, options.view);
    if (options.view.empty()) options.view = default_view(options.display);
    check_display_view(options.display, options.view);
    if (!options.look.empty()) check_looks(options.look);
    return options;
}

namespace {

struct NamedSpaces {
    KnownPrimaries primaries;
    std::vector<const char*> names;
};

// The names the common configs (ACES studio/cg 1.x and 2.x, spi, Blender) give linear spaces of known primaries.
const std::vector<NamedSpaces>& usual_names() {
    static const std::vector<NamedSpaces> names{
        {KnownPrimaries::Rec709,
         {"Linear Rec.709 (sRGB)", "lin_rec709_srgb", "lin_rec709", "Utility - Linear - sRGB",
          "Utility - Linear - Rec.709", "lin_srgb", "Linear sRGB", "Linear Rec.709"}},
        {KnownPrimaries::AcesAP0, {"ACES2065-1", "ACES - ACES2065-1", "aces_interchange", "lin_ap0"}},
        {KnownPrimaries::AcesAP1, {"ACEScg", "ACES - ACEScg", "lin_ap1"}},
        {KnownPrimaries::Rec2020,
         {"Linear Rec.2020", "lin_rec2020", "Utility - Linear - Rec.2020", "Linear Rec.2020 (Rec.2100)"}},
        {KnownPrimaries::P3D65, {"Linear P3-D65", "lin_p3d65", "Utility - Linear - P3-D65"}},
    };
    return names;
}

}  // namespace

std::optional<Mat3> measure_to_ap0(const OCIO::ConstConfigRcPtr& config, const std::string& space) {
    if (!config->getColorSpace(OCIO::ROLE_INTERCHANGE_SCENE)) return std::nullopt;
    OCIO::ConstCPUProcessorRcPtr cpu;
    try {
        cpu = config->getProcessor(space.c_str(), OCIO::ROLE_INTERCHANGE_SCENE)->getDefaultCPUProcessor();
    } catch (const OCIO::Exception&) {
        return std::nullopt;
    }
    auto f = [&](double r, double g, double b) {
        float p[3] = {static_cast<float>(r), static_cast<float>(g), static_cast<float>(b)};
        cpu->applyRGB(p);
        return std::array<double, 3>{static_cast<double>(p[0]), static_cast<double>(p[1]), static_cast<double>(p[2])};
    };
    const auto cr = f(1, 0, 0), cg = f(0, 1, 0), cb = f(0, 0, 1);
    const Mat3 m{cr[0], cg[0], cb[0], cr[1], cg[1], cb[1], cr[2], cg[2], cb[2]};
    const std::array<std::array<double, 3>, 4> probes{{{0.18, 0.18, 0.18}, {0.3, 0.05, 0.7}, {8.0, 2.0, 0.5}, {0, 0, 0}}};
    for (const auto& v : probes) {
        const auto want = apply_matrix(m, v);
        const auto got = f(v[0], v[1], v[2]);
        for (int i = 0; i < 3; ++i)
            if (std::abs(got[i] - want[i]) > 1e-4 * (1.0 + std::abs(want[i]))) return std::nullopt;
    }
    return m;
}

Mat3 ap0_to_xyz_d65_matrix() {
    const auto ap0 = chromaticities(KnownPrimaries::AcesAP0);
    return multiply(bradford(ap0.wx, ap0.wy, d65_x, d65_y), rgb_to_xyz(ap0));
}

std::string ColourConfig::input_space(const std::string& requested,
                                      const std::optional<std::array<float, 8>>& exr_chromaticities) {
    if (!requested.empty()) {
        check_colour_space(requested);
        return requested;
    }
    if (!exr_chromaticities) {
        if (builtin_) return std::string(builtin::lin_rec709);
        // An EXR without chromaticities is linear Rec.709 (the format's default primaries); else, as
        // oiiotool takes an untagged image, the config's scene_linear role, then its default role.
        for (const char* n : usual_names().front().names)
            if (config_->getColorSpace(n)) return n;
        for (const char* role : {OCIO::ROLE_SCENE_LINEAR, OCIO::ROLE_DEFAULT})
            if (const auto cs = config_->getColorSpace(role)) return cs->getName();
        throw std::runtime_error(fmt::format(
            "the input has no chromaticities and OCIO config {} has no linear Rec.709 colour space under a usual "
            "name and no scene_linear or default role; give --colorspace, one of: {}",
            source_, join(colour_spaces())));
    }
    const auto& c = *exr_chromaticities;
    const auto known = identify_primaries(c);
    if (known) {
        // When the config can convert to ACES (aces_interchange role), a candidate must measure as linear with
        // these primaries; without that role the usual names are trusted.
        const auto k = chromaticities(*known);
        const Mat3 want = multiply(bradford(k.wx, k.wy, d65_x, d65_y), rgb_to_xyz(k));
        const bool can_measure = config_->getColorSpace(OCIO::ROLE_INTERCHANGE_SCENE) != nullptr;
        auto matches = [&](const std::string& n) {
            const auto m = measure_to_ap0(config_, n);
            if (!m) return false;
            const Mat3 got = multiply(ap0_to_xyz_d65_matrix(), *m);
            for (std::size_t i = 0; i < 9; ++i)
                if (std::abs(got[i] - want[i]) > 2e-3) return false;
            return true;
        };
        for (const auto& entry : usual_names())
            if (entry.primaries == *known)
                for (const char* n : entry.names)
                    if (config_->getColorSpace(n) && (!can_measure || matches(n))) return n;
        if (can_measure)
            for (const auto& n : colour_spaces()) {
                const auto cs = config_->getColorSpace(n.c_str());
                if (cs && !cs->isData() && cs->getReferenceSpaceType() == OCIO::REFERENCE_SPACE_SCENE && matches(n))
                    return n;
            }
    }
    if (!builtin_)
        throw std::runtime_error(fmt::format(
            "OCIO config {} has no linear colour space with the input's chromaticities {}{}; give --colorspace, "
            "one of: {}",
            source_, describe(c), known ? fmt::format(" ({})", name(*known)) : std::string(), join(colour_spaces())));
    if (known) {
        switch (*known) {
            case KnownPrimaries::Rec709: return std::string(builtin::lin_rec709);
            case KnownPrimaries::AcesAP0: return std::string(builtin::aces2065_1);
            case KnownPrimaries::AcesAP1: return std::string(builtin::acescg);
            case KnownPrimaries::Rec2020: return std::string(builtin::lin_rec2020);
            case KnownPrimaries::P3D65: return std::string(builtin::lin_p3d65);
        }
    }
    // Other chromaticities: add a linear colour space for them to (a copy of) the built-in config.
    const Chromaticities ch = widened(c);
    OCIO::TransformRcPtr to_ref;
    try {
        to_ref = rgb_to_aces_reference(ch);
    } catch (const std::invalid_argument& e) {
        throw std::runtime_error(fmt::format("input chromaticities {}: {}", describe(c), e.what()));
    }
    const std::string space = fmt::format("Linear input primaries {}", describe(c));
    if (!config_->getColorSpace(space.c_str())) {
        auto copy = config_->createEditableCopy();
        copy->addColorSpace(scene_space(space, "Input", "Linear RGB of the input file's EXR chromaticities", to_ref));
        config_ = copy;
    }
    return space;
}

}  // namespace lensfx::colour
