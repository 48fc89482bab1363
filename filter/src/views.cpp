// Multi-view EXR frames (see filter/views.h).
#include <filter/views.h>

#include <algorithm>
#include <stdexcept>

#include <fmt/core.h>

#include "exr_io.h"

namespace lensfx::filter {

std::vector<std::string> frame_views(const Frame& frame) { return exr_views(frame.spec); }

std::array<int, 3> view_rgb_channels(const ImageSpec& spec, const std::string& view, bool is_default) {
    const std::string prefix = is_default ? std::string() : view + ".";
    return {spec.channel_index(prefix + "R"), spec.channel_index(prefix + "G"), spec.channel_index(prefix + "B")};
}

void ViewSelection::check(const Frame& frame) const {
    if (wanted_.empty()) return;
    const std::vector<std::string> views = frame_views(frame);
    if (views.empty()) throw std::runtime_error("--views: the input is not a multi-view EXR (no multiView attribute)");
    for (const std::string& v : wanted_) {
        if (std::find(views.begin(), views.end(), v) == views.end()) {
            std::string names;
            for (const auto& n : views) names += (names.empty() ? "" : ", ") + n;
            throw std::runtime_error(fmt::format("--views: the input has no view \"{}\" (its views: {})", v, names));
        }
    }
}

bool ViewSelection::selected(const std::string& view) const {
    return wanted_.empty() || std::find(wanted_.begin(), wanted_.end(), view) != wanted_.end();
}

bool ViewSelection::default_selected(const Frame& frame) const {
    const std::vector<std::string> views = frame_views(frame);
    return views.empty() ? wanted_.empty() : selected(views.front());
}

void DefaultViewStage::process(Frame& frame) {
    if (frame.index == 0) views_->check(frame);
    if (views_->default_selected(frame)) inner_->process(frame);
}

void OtherViewsStage::process(Frame& frame) {
    const std::vector<std::string> views = frame_views(frame);
    if (views.size() < 2) return;
    const std::array<int, 3> default_rgb = frame.rgb_channels;
    const ImageSpec before = frame.spec;
    std::vector<float> default_working = std::move(frame.rgb);
    for (std::size_t v = 1; v < views.size(); ++v) {
        const std::string& view = views[v];
        if (!views_->selected(view)) continue;
        frame.rgb_channels = view_rgb_channels(frame.spec, view, false);
        if (!frame.has_rgb()) continue;  // a view without R, G, B (depth only) passes through
        auto& stages = stages_[view];
        if (stages.empty()) stages = make_(view);
        bool loaded = false;
        for (auto& stage : stages) {
            if (stage->wants_rgb() && !loaded) {
                load_rgb(frame);
                loaded = true;
            }
            stage->process(frame);
        }
        if (loaded) store_rgb(frame);
        frame.rgb.clear();
    }
    frame.rgb_channels = default_rgb;
    // a view's flare may have grown the data window (grow_data_window): the default view's buffer grows with it
    const bool grown = before.x != frame.spec.x || before.y != frame.spec.y || before.width != frame.spec.width || before.height != frame.spec.height;
    if (grown && !default_working.empty()) default_working = rgb_in_window(default_working, before, frame.spec);
    frame.rgb = std::move(default_working);
}

}  // namespace lensfx::filter
