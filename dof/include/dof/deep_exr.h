// Deep OpenEXR images (samples per pixel, RGBA + Z) read with OpenEXR's deep API, merged, flattened and
// turned into the lens blur's layers: the deep samples are the layered scene itself.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <dof/layers.h>
#include <optics/memory_budget.h>

namespace lensfx::dof {

struct DeepSample {
    float r = 0, g = 0, b = 0, a = 0;  // premultiplied, as OpenEXR stores deep colour
    float z = 0, zback = 0;            // metres times the file's unit (zback = z when the file has none)
};

// A deep image over its data window; samples of pixel i are samples[offsets[i] .. offsets[i+1]).
struct DeepImage {
    int x = 0, y = 0, width = 0, height = 0;                  // data window
    int full_x = 0, full_y = 0, full_width = 0, full_height = 0;  // display window
    std::vector<std::uint32_t> offsets;
    std::vector<DeepSample> samples;
};

// Whether the file is an EXR whose first part holds deep data.
bool is_deep_exr(const std::string& path);
// Reads a deep scanline EXR (R, G, B, A, Z; ZBack optional). The sample tables are sized against `budget`
// from the header and the counts before they are made (a hostile header of a few hundred bytes can declare
// 10^12 samples). Throws std::runtime_error naming the file and what is missing or too big.
DeepImage read_deep_exr(const std::string& path, const MemoryBudget& budget);
// The image over another window (x, y, width, height): pixels outside its data window have no samples.
DeepImage reframe(const DeepImage& image, int x, int y, int width, int height);
// The samples of several deep images in one (the composite of Balls, Leaves and Trunks), over the first
// one's display window, whose tables are sized against `budget` first.
DeepImage merge_deep(const std::vector<DeepImage>& images, const MemoryBudget& budget);
// Front-to-back "over" of every pixel: RGBA interleaved, the data window, and the nearest depth (Z, 0 where
// empty) when z_out is given.
std::vector<float> flatten_deep(const DeepImage& image, std::vector<float>* z_out = nullptr);
// The layers (samples sorted by depth, each scaled by depth_scale metres per unit); pixels with more than
// max_layers samples have their farthest ones composited into the last layer. Thickness as set_thickness.
LayerStack layers_from_deep(const DeepImage& image, double depth_scale = 1.0, int max_layers = 8,
                            double thickness = 0.01, double step = 0.05);

}  // namespace lensfx::dof
