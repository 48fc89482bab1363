// Finds the bright light sources of one frame: threshold on a max-pooled luminance map, connected
// components refined at full resolution, merging, clustering of many tiny lights, and a budget.
#pragma once

#include <array>
#include <vector>

#include <opencv2/core/mat.hpp>

#include <detect/image_view.h>
#include <detect/source.h>
#include <detect/threshold.h>

namespace lensfx::detect {

struct DetectorOptions {
    Threshold threshold{};         // a source is born when its peak reaches this
    double hysteresis_ev = 1.0;    // sources are found down to threshold / 2^hysteresis_ev (tracks go on there)
    double min_threshold = 1.0;    // floor of a relative threshold (diffuse white)
    int downsample = 4;            // block size of the max-pooled search map (1: search at full resolution)
    double merge_radius = 6.0;     // px: components whose bounding boxes are closer become one source
    int max_lights = 16;           // the brightest sources kept
    double visibility = 1e-4;      // sources with less than this fraction of the frame's luminous flux are skipped
    int cluster_above = 64;        // more components than this: grid clustering
    double cluster_cell = 0.0;     // px, grid cell of the clustering; 0: max(width, height) / 32
    double clip_level = 0.0;       // channel value at which the camera clipped; 0: flat-top test only
    int shape_cells = 32;          // largest side of a source's shape image, in cells
    double shape_min_size = 16.0;  // px: sources with a wider or taller bounding box keep a shape

    // Throws std::invalid_argument naming the option when a value is out of range.
    void validate() const;
};

// The scratch of one connected-components labelling (cv::connectedComponentsWithStats), reused per frame.
struct Components {
    cv::Mat mask, labels, stats, centroids;
};

// Holds the options and the scratch buffers reused from frame to frame (one detector per thread).
class Detector {
public:
    explicit Detector(DetectorOptions options = {});

    [[nodiscard]] Detection detect(const ImageView& image);
    // A CV_32FC3 or CV_32FC4 matrix, RGB(A) order.
    [[nodiscard]] Detection detect(const cv::Mat& rgb);

    [[nodiscard]] const DetectorOptions& options() const { return options_; }

private:
    void release_large_buffers();  // after a frame above 4K, what scales with its pixels

    DetectorOptions options_;
    cv::Mat luminance_;  // CV_32F, sanitised full-resolution luminance
    cv::Mat pooled_;     // CV_32F, block maxima
    Components coarse_;  // of the pooled map
    Components fine_;    // of one coarse component's region at full resolution
    std::vector<unsigned> fine_histogram_;
};

// An ImageView of a CV_32FC3 / CV_32FC4 matrix (RGB order). Throws std::invalid_argument for other types.
ImageView view_of(const cv::Mat& rgb);

}  // namespace lensfx::detect
