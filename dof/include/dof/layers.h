// The layered scene the lens blur traces (Lee, Eisemann and Seidel 2010, section 3.1): per pixel up to
// `count` surfaces sorted front to back, each a depth interval [front, back] in metres from the entrance
// pupil along the view axis and a premultiplied colour with alpha. Deep EXR samples are the layers as
// given; a flat image with Z gets its visible layer plus what it hides, extended under it.
#pragma once
#include <cstddef>
#include <vector>

namespace lensfx::dof {

struct LayerStack {
    int width = 0, height = 0, count = 0;
    std::vector<float> front;  // count x width x height, metres; 0: no surface (later layers are empty too)
    std::vector<float> back;   // >= front: the surface's thickness, so rays between pixels cannot slip by
    std::vector<float> rgba;   // 4 per entry, premultiplied by alpha
    // true (deep input): a pixel without surfaces is empty space, a ray that meets nothing gathers
    // nothing, and alpha is each sample's opacity; false (flat input): every surface is opaque and extends
    // behind itself, such a ray takes the farthest surface under its end, and alpha is the image's own,
    // carried with the colour (so a premultiplied foreground's blurred edge is soft in alpha too)
    bool open = false;

    // How much of what lies behind entry i it hides.
    float opacity(std::size_t i) const { return open ? rgba[4 * i + 3] : 1.0f; }

    std::size_t at(int layer, int x, int y) const {
        return (static_cast<std::size_t>(layer) * static_cast<std::size_t>(height) + static_cast<std::size_t>(y)) *
                   static_cast<std::size_t>(width) + static_cast<std::size_t>(x);
    }
    void resize(int w, int h, int layers);
    float nearest() const;   // smallest front depth of any surface
    float farthest() const;  // largest back depth
};

struct FlatLayerOptions {
    double hidden_radius_px = 32.0;  // how far the hidden layer reaches under a nearer surface
    double step = 0.05;              // relative depth step that counts as an occlusion edge
    double thickness = 0.01;         // relative thickness of every surface
};

// Layers of a flat image: rgb interleaved (3 per pixel), depth in metres per pixel (<= 0 or not finite:
// at infinity, stored as 1e9 m), alpha per pixel (null: 1). Layer 0 is the visible surface; layer 1 holds, at pixels near a nearer
// surface's edge, the farther surface next to it (the nearest pixel behind, found by jump flooding),
// extended under the nearer one up to hidden_radius_px.
LayerStack layers_from_flat(const float* rgb, const float* depth, int width, int height,
                            const FlatLayerOptions& options = {}, const float* alpha = nullptr);

// Sets every surface's back depth: at least front x (1 + thickness), and continuous surfaces (neighbours
// whose front lies within `step` of this one) reach back to their farthest neighbour, so a ray crossing
// from one pixel to the next on a slanted surface always meets it.
void set_thickness(LayerStack& layers, double thickness, double step);

// Front-to-back "over" of a pixel's layers: what a pinhole at the pupil's centre sees (3 floats).
void composite_pixel(const LayerStack& layers, int x, int y, float* rgb);

}  // namespace lensfx::dof
