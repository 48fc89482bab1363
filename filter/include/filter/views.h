// Stereo and multi-view EXR (the `multiView` attribute): every view's R, G, B is flared from its own
// pixels by its own stages (so a light is detected and tracked where it sits in that view). The default
// view (the first named, whose channels are plain R, G, B) goes through the pipeline's stages as any
// frame does; the others through a "views" stage that selects each view's channels in turn.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <filter/frame.h>

namespace lensfx::filter {

// The views of a frame as its EXR header names them (multiView), default view first; empty when it has none.
std::vector<std::string> frame_views(const Frame& frame);

// The indices of view `view`'s R, G, B in the spec (plain R, G, B for the default view, VIEW.R... for the
// others); -1 where one is missing.
std::array<int, 3> view_rgb_channels(const ImageSpec& spec, const std::string& view, bool is_default);

// Which views to flare: --views a,b (empty: all). Checked against the frame's views on the first frame.
class ViewSelection {
public:
    explicit ViewSelection(std::vector<std::string> wanted) : wanted_(std::move(wanted)) {}
    // Throws when --views names a view the frame does not have (or the frame has none).
    void check(const Frame& frame) const;
    bool selected(const std::string& view) const;
    bool default_selected(const Frame& frame) const;

private:
    std::vector<std::string> wanted_;
};

// A default-view stage that runs only when the default view is selected (every stage of a single-view frame).
class DefaultViewStage final : public Stage {
public:
    DefaultViewStage(std::unique_ptr<Stage> inner, std::shared_ptr<const ViewSelection> views)
        : inner_(std::move(inner)), views_(std::move(views)) {}
    std::string_view name() const override { return inner_->name(); }
    bool wants_rgb() const override { return inner_->wants_rgb(); }
    void process(Frame& frame) override;
    std::vector<std::pair<std::string, double>> part_times() const override { return inner_->part_times(); }
    std::vector<std::pair<std::string, double>> frame_figures() const override { return inner_->frame_figures(); }
    std::size_t held_bytes(const ImageSpec& spec) const override { return inner_->held_bytes(spec); }

private:
    std::unique_ptr<Stage> inner_;
    std::shared_ptr<const ViewSelection> views_;
};

// The views other than the default one: for each selected view, its R, G, B become the frame's working
// channels, its own stages (made by `make` at its first frame, so each keeps its own tracks) run, and the
// result is stored back. Nothing happens to a frame without views.
class OtherViewsStage final : public Stage {
public:
    using StageFactory = std::function<std::vector<std::unique_ptr<Stage>>(const std::string& view)>;
    OtherViewsStage(StageFactory make, std::shared_ptr<const ViewSelection> views) : make_(std::move(make)), views_(std::move(views)) {}
    std::string_view name() const override { return "views"; }
    bool wants_rgb() const override { return false; }
    void process(Frame& frame) override;

private:
    StageFactory make_;
    std::shared_ptr<const ViewSelection> views_;
    std::map<std::string, std::vector<std::unique_ptr<Stage>>> stages_;
};

}  // namespace lensfx::filter
