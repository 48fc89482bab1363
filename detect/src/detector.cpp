// Bright-source detection: sanitised luminance, a max-pooled search map, connected components refined at
// full resolution, radius merging, grid clustering of many tiny lights, visibility and budget, shapes.
#include <detect/detector.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <stdexcept>

#include <fmt/core.h>
#include <opencv2/imgproc.hpp>

namespace lensfx::detect {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Luminance histogram with 16 bins per stop: the float's exponent and top four mantissa bits.
constexpr int kFineShift = 19;
constexpr int kFineBins = 1 << (31 - kFineShift);
// The coarse histogram used for cut detection: one bin per stop from 2^-16 to 2^16, plus one for darker.
constexpr int kStopMin = -16;
constexpr int kStopMax = 16;

// A finite, non-negative value, or 0: NaN, Inf and negative pixels carry no light.
inline float sane(float v) { return (v > 0.0f && v <= std::numeric_limits<float>::max()) ? v : 0.0f; }
inline bool invalid_value(float v) { return !(v >= 0.0f && v <= std::numeric_limits<float>::max()); }

// Raw sums of one source's pixels; additive, so merging and clustering just add them.
struct Accum {
    double w = 0.0, wx = 0.0, wy = 0.0;                     // centroid weights: luminance above the low threshold
    double l = 0.0, lx = 0.0, ly = 0.0, lxx = 0.0, lxy = 0.0, lyy = 0.0;  // luminance moments (extent)
    std::array<double, 3> rgb{};
    double peak = 0.0;
    double peak_channel = 0.0;
    int near_peak = 0;  // pixels whose largest channel is within kFlatTolerance of peak_channel
    int count = 0;
    int members = 1;
    int x0 = std::numeric_limits<int>::max(), y0 = std::numeric_limits<int>::max(), x1 = 0, y1 = 0;
    int peak_x = 0, peak_y = 0;

    static constexpr double kFlatTolerance = 1e-3;  // about one half-float step

    void add_pixel(int x, int y, double lum, double low, const float* rgb_px) {
        const double px = x + 0.5, py = y + 0.5;
        const double wt = lum - low;
        w += wt; wx += wt * px; wy += wt * py;
        l += lum; lx += lum * px; ly += lum * py;
        lxx += lum * px * px; lxy += lum * px * py; lyy += lum * py * py;
        double mc = 0.0;
        for (int c = 0; c < 3; ++c) {
            const double v = static_cast<double>(sane(rgb_px[c]));
            rgb[c] += v;
            mc = std::max(mc, v);
        }
        if (mc > peak_channel * (1.0 + kFlatTolerance)) {
            peak_channel = mc;
            near_peak = 1;
        } else if (mc >= peak_channel * (1.0 - kFlatTolerance)) {
            peak_channel = std::max(peak_channel, mc);
            ++near_peak;
        }
        if (lum > peak) { peak = lum; peak_x = x; peak_y = y; }
        ++count;
        x0 = std::min(x0, x); y0 = std::min(y0, y); x1 = std::max(x1, x + 1); y1 = std::max(y1, y + 1);
    }

    void merge(const Accum& o) {
        w += o.w; wx += o.wx; wy += o.wy;
        l += o.l; lx += o.lx; ly += o.ly; lxx += o.lxx; lxy += o.lxy; lyy += o.lyy;
        for (int c = 0; c < 3; ++c) rgb[c] += o.rgb[c];
        if (o.peak_channel > peak_channel * (1.0 + kFlatTolerance)) {
            near_peak = o.near_peak;
        } else if (o.peak_channel >= peak_channel * (1.0 - kFlatTolerance)) {
            near_peak += o.near_peak;
        }
        peak_channel = std::max(peak_channel, o.peak_channel);
        if (o.peak > peak) { peak = o.peak; peak_x = o.peak_x; peak_y = o.peak_y; }
        count += o.count;
        members += o.members;
        x0 = std::min(x0, o.x0); y0 = std::min(y0, o.y0); x1 = std::max(x1, o.x1); y1 = std::max(y1, o.y1);
    }

    [[nodiscard]] double luminous() const {
        return kRec709Luma[0] * rgb[0] + kRec709Luma[1] * rgb[1] + kRec709Luma[2] * rgb[2];
    }
};

double bbox_gap(const Accum& a, const Accum& b) {
    const double gx = std::max({0, a.x0 - b.x1, b.x0 - a.x1});
    const double gy = std::max({0, a.y0 - b.y1, b.y0 - a.y1});
    return std::hypot(gx, gy);
}

int find_root(std::vector<int>& parent, int i) {
    while (parent[static_cast<std::size_t>(i)] != i) {
        parent[static_cast<std::size_t>(i)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(i)])];
        i = parent[static_cast<std::size_t>(i)];
    }
    return i;
}

// Union of every pair closer than `radius`; the merged list keeps the order of each group's first member.
std::vector<Accum> merge_by_radius(const std::vector<Accum>& in, double radius) {
    const int n = static_cast<int>(in.size());
    std::vector<int> parent(in.size());
    std::iota(parent.begin(), parent.end(), 0);
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j)
            if (bbox_gap(in[static_cast<std::size_t>(i)], in[static_cast<std::size_t>(j)]) < radius) {
                const int a = find_root(parent, i), b = find_root(parent, j);
                if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
            }
    std::vector<int> slot(in.size(), -1);
    std::vector<Accum> out;
    for (int i = 0; i < n; ++i) {
        const int r = find_root(parent, i);
        auto& s = slot[static_cast<std::size_t>(r)];
        if (s < 0) {
            s = static_cast<int>(out.size());
            out.push_back(in[static_cast<std::size_t>(i)]);
        } else {
            out[static_cast<std::size_t>(s)].merge(in[static_cast<std::size_t>(i)]);
        }
    }
    return out;
}

// Sources binned by their flux-weighted centroid into square cells; each cell becomes one source.
std::vector<Accum> cluster_on_grid(const std::vector<Accum>& in, double cell, int width, int height) {
    const int gw = static_cast<int>(std::ceil(width / cell)) + 1;
    const int gh = static_cast<int>(std::ceil(height / cell)) + 1;
    std::vector<int> slot(static_cast<std::size_t>(gw) * static_cast<std::size_t>(gh), -1);
    std::vector<Accum> out;
    for (const auto& a : in) {
        const double cx = a.l > 0.0 ? a.lx / a.l : 0.5 * (a.x0 + a.x1);
        const double cy = a.l > 0.0 ? a.ly / a.l : 0.5 * (a.y0 + a.y1);
        const int gx = std::clamp(static_cast<int>(cx / cell), 0, gw - 1);
        const int gy = std::clamp(static_cast<int>(cy / cell), 0, gh - 1);
        auto& s = slot[static_cast<std::size_t>(gy) * static_cast<std::size_t>(gw) + static_cast<std::size_t>(gx)];
        if (s < 0) {
            s = static_cast<int>(out.size());
            out.push_back(a);
        } else {
            out[static_cast<std::size_t>(s)].merge(a);
        }
    }
    return out;
}

Extent extent_of(const Accum& a) {
    if (!(a.l > 0.0)) return {};
    const double mx = a.lx / a.l, my = a.ly / a.l;
    const double sxx = std::max(0.0, a.lxx / a.l - mx * mx);
    const double syy = std::max(0.0, a.lyy / a.l - my * my);
    const double sxy = a.lxy / a.l - mx * my;
    const double mean = 0.5 * (sxx + syy);
    const double diff = std::hypot(0.5 * (sxx - syy), sxy);
    Extent e;
    e.major = 2.0 * std::sqrt(mean + diff);
    e.minor = 2.0 * std::sqrt(std::max(0.0, mean - diff));
    // Image rows grow downwards; the angle is measured with +y up, hence the sign of sxy.
    double angle = 0.5 * std::atan2(-2.0 * sxy, sxx - syy) * 180.0 / kPi;
    if (angle < 0.0) angle += 180.0;
    if (angle >= 180.0) angle -= 180.0;
    e.angle_deg = angle;
    return e;
}

}  // namespace

void DetectorOptions::validate() const {
    auto fail = [](const char* what) { throw std::invalid_argument(fmt::format("detector option {}", what)); };
    if (threshold.kind == Threshold::Kind::Absolute && !(threshold.value > 0.0)) fail("threshold: must be positive");
    if (!(hysteresis_ev >= 0.0) || !std::isfinite(hysteresis_ev)) fail("hysteresis_ev: must be >= 0");
    if (!(min_threshold > 0.0)) fail("min_threshold: must be positive");
    if (downsample < 1 || downsample > 64) fail("downsample: must be in 1..64");
    if (!(merge_radius >= 0.0)) fail("merge_radius: must be >= 0");
    if (max_lights < 0) fail("max_lights: must be >= 0");
    if (!(visibility >= 0.0 && visibility < 1.0)) fail("visibility: must be in [0, 1)");
    if (cluster_above < 1) fail("cluster_above: must be >= 1");
    if (!(cluster_cell >= 0.0)) fail("cluster_cell: must be >= 0");
    if (!(clip_level >= 0.0)) fail("clip_level: must be >= 0");
    if (shape_cells < 1 || shape_cells > 256) fail("shape_cells: must be in 1..256");
    if (!(shape_min_size >= 0.0)) fail("shape_min_size: must be >= 0");
}

Detector::Detector(DetectorOptions options) : options_(options), fine_histogram_(kFineBins, 0u) {
    options_.validate();
}

ImageView view_of(const cv::Mat& rgb) {
    if (rgb.depth() != CV_32F || (rgb.channels() != 3 && rgb.channels() != 4))
        throw std::invalid_argument(fmt::format("detector input: expected a 3- or 4-channel float image, got type {}", rgb.type()));
    if (rgb.step[0] % sizeof(float) != 0)
        throw std::invalid_argument("detector input: row step is not a whole number of floats");
    ImageView v;
    v.data = rgb.ptr<float>();
    v.width = rgb.cols;
    v.height = rgb.rows;
    v.channels = rgb.channels();
    v.row_stride = static_cast<std::ptrdiff_t>(rgb.step[0] / sizeof(float));
    return v;
}

Detection Detector::detect(const cv::Mat& rgb) { return detect(view_of(rgb)); }

namespace {

void check_input(const ImageView& image) {
    if (image.data == nullptr || image.width <= 0 || image.height <= 0)
        throw std::invalid_argument(fmt::format("detector input: empty image ({}x{})", image.width, image.height));
    if (image.channels < 3)
        throw std::invalid_argument(fmt::format("detector input: {} channels, need R, G, B", image.channels));
}

// Pass 1: the sanitised luminance of every pixel, the maximum of each block x block block (the pooled
// search map), the fine histogram, and the frame's flux, invalid pixels and maximum into `stats`.
void measure_luminance(const ImageView& image, int block, cv::Mat& luminance, cv::Mat& pooled,
                       std::vector<unsigned>& histogram, FrameStats& stats) {
    const int width = image.width, height = image.height;
    luminance.create(height, width, CV_32F);
    pooled.create((height + block - 1) / block, (width + block - 1) / block, CV_32F);
    pooled.setTo(0.0);
    std::fill(histogram.begin(), histogram.end(), 0u);
    double total = 0.0;
    int invalid = 0;
    const float wr = static_cast<float>(kRec709Luma[0]), wg = static_cast<float>(kRec709Luma[1]),
                wb = static_cast<float>(kRec709Luma[2]);
    for (int y = 0; y < height; ++y) {
        const float* src = image.row(y);
        float* lum = luminance.ptr<float>(y);
        float* pool = pooled.ptr<float>(y / block);
        double row_sum = 0.0;
        for (int x = 0, b = 0; x < width; ++b) {  // `block` pixels per block of the pooled map
            const int end = std::min(width, x + block);
            float m = pool[b];
            for (; x < end; ++x) {
                const float* p = src + static_cast<std::ptrdiff_t>(x) * image.channels;
                const float r = sane(p[0]), g = sane(p[1]), bl = sane(p[2]);
                invalid += (invalid_value(p[0]) || invalid_value(p[1]) || invalid_value(p[2])) ? 1 : 0;
                const float l = wr * r + wg * g + wb * bl;
                lum[x] = l;
                row_sum += static_cast<double>(l);
                m = std::max(m, l);
                ++histogram[std::bit_cast<std::uint32_t>(l) >> kFineShift];
            }
            pool[b] = m;
        }
        total += row_sum;
    }
    stats.total_luminous_flux = total;
    stats.invalid_pixels = invalid;
    cv::minMaxLoc(pooled, nullptr, &stats.max_luminance);  // the block maxima hold the frame's maximum
}

// The median from the fine histogram (1/16 stop resolution), and the per-stop histogram for cut detection.
void luminance_distribution(const std::vector<unsigned>& histogram, std::uint64_t pixels, FrameStats& stats) {
    std::uint64_t acc = 0;
    for (int i = 0; i < kFineBins; ++i) {
        acc += histogram[static_cast<std::size_t>(i)];
        if (2 * acc >= pixels) {
            const auto bits = (static_cast<std::uint32_t>(i) << kFineShift) | (1u << (kFineShift - 1));
            stats.median_luminance = i == 0 ? 0.0 : static_cast<double>(std::bit_cast<float>(bits));
            break;
        }
    }
    stats.histogram.assign(kStopMax - kStopMin + 1, 0.0f);
    for (int i = 0; i < kFineBins; ++i) {
        const auto c = histogram[static_cast<std::size_t>(i)];
        if (c == 0) continue;
        const int stop = (i >> 4) - 127;  // floor(log2 l)
        const int bin = stop < kStopMin ? 0 : std::min(stop, kStopMax - 1) - kStopMin + 1;
        stats.histogram[static_cast<std::size_t>(bin)] += static_cast<float>(static_cast<double>(c) / static_cast<double>(pixels));
    }
}

// The pixels of one full-resolution region at or above `low`, as components (index 0: the background).
std::vector<Accum> region_components(const ImageView& image, const cv::Mat& luminance, const cv::Rect& roi, double low,
                                     Components& scratch) {
    const cv::Mat lroi = luminance(roi);
    cv::compare(lroi, cv::Scalar(static_cast<double>(static_cast<float>(low))), scratch.mask, cv::CMP_GE);
    const int count = cv::connectedComponentsWithStats(scratch.mask, scratch.labels, scratch.stats, scratch.centroids, 8, CV_32S);
    std::vector<Accum> local(static_cast<std::size_t>(count));
    for (int yy = 0; yy < roi.height; ++yy) {
        const int* lab = scratch.labels.ptr<int>(yy);
        const float* lum = lroi.ptr<float>(yy);
        const int y = roi.y + yy;
        const float* src = image.row(y);
        for (int xx = 0; xx < roi.width; ++xx) {
            if (lab[xx] == 0) continue;
            const int x = roi.x + xx;
            local[static_cast<std::size_t>(lab[xx])].add_pixel(x, y, static_cast<double>(lum[xx]), low,
                                                               src + static_cast<std::ptrdiff_t>(x) * image.channels);
        }
    }
    return local;
}

// Pass 2: components of the pooled map; each one's blocks are searched at full resolution. A pixel above
// the threshold lies in a block whose maximum is above it, and 8-connected pixels lie in 8-connected
// blocks, so every full-resolution component lies inside one coarse component's bounding box; it is
// counted by the coarse component that owns the block of its peak, so overlapping boxes count it once.
std::vector<Accum> find_components(const ImageView& image, const cv::Mat& luminance, const cv::Mat& pooled, int block,
                                   double low, Components& coarse, Components& fine) {
    cv::compare(pooled, cv::Scalar(static_cast<double>(static_cast<float>(low))), coarse.mask, cv::CMP_GE);
    const int ncoarse = cv::connectedComponentsWithStats(coarse.mask, coarse.labels, coarse.stats, coarse.centroids, 8, CV_32S);
    std::vector<Accum> comps;
    for (int k = 1; k < ncoarse; ++k) {
        const int bx = coarse.stats.at<int>(k, cv::CC_STAT_LEFT), by = coarse.stats.at<int>(k, cv::CC_STAT_TOP);
        const int bw = coarse.stats.at<int>(k, cv::CC_STAT_WIDTH), bh = coarse.stats.at<int>(k, cv::CC_STAT_HEIGHT);
        const cv::Rect roi(bx * block, by * block, std::min(bw * block, image.width - bx * block),
                           std::min(bh * block, image.height - by * block));
        const std::vector<Accum> local = region_components(image, luminance, roi, low, fine);
        for (std::size_t j = 1; j < local.size(); ++j) {
            const Accum& a = local[j];
            if (coarse.labels.at<int>(a.peak_y / block, a.peak_x / block) == k) comps.push_back(a);
        }
    }
    return comps;
}

// Many components (city lights) are clustered on a grid first, so merging and the budget stay cheap; then
// components closer than the merge radius become one.
std::vector<Accum> group_components(std::vector<Accum> comps, const DetectorOptions& options, int width, int height,
                                    FrameStats& stats) {
    if (static_cast<int>(comps.size()) > options.cluster_above) {
        const double cell = options.cluster_cell > 0.0 ? options.cluster_cell : std::max(width, height) / 32.0;
        comps = cluster_on_grid(comps, cell, width, height);
        stats.clustered = true;
    }
    return merge_by_radius(comps, options.merge_radius);
}

double centroid_x(const Accum& a) { return a.wx / a.w; }
double centroid_y(const Accum& a) { return a.wy / a.w; }

// The visible components (at least options.visibility of the frame's flux), brightest first (ties: top to
// bottom, left to right), at most options.max_lights of them; what is dropped is counted in `stats`.
std::vector<Accum> visible_within_budget(const std::vector<Accum>& comps, const DetectorOptions& options, FrameStats& stats) {
    std::vector<Accum> kept;
    for (const auto& a : comps) {
        if (a.luminous() < options.visibility * stats.total_luminous_flux || !(a.w > 0.0)) {
            ++stats.dropped_invisible;
            continue;
        }
        kept.push_back(a);
    }
    std::sort(kept.begin(), kept.end(), [](const Accum& a, const Accum& b) {
        if (a.luminous() != b.luminous()) return a.luminous() > b.luminous();
        if (centroid_y(a) != centroid_y(b)) return centroid_y(a) < centroid_y(b);
        return centroid_x(a) < centroid_x(b);
    });
    if (static_cast<int>(kept.size()) > options.max_lights) {
        stats.dropped_budget = static_cast<int>(kept.size()) - options.max_lights;
        kept.resize(static_cast<std::size_t>(options.max_lights));
    }
    return kept;
}

// The shape of an extended source: its luminance at or above `low`, summed into cells of at most
// `max_cells` per side and normalised, placed relative to the source's centroid (x, y).
Shape shape_of(const Accum& a, const cv::Mat& luminance, float low, int max_cells, const ImageView& image, double x, double y) {
    const int bw = a.x1 - a.x0, bh = a.y1 - a.y0;
    const int cell = std::max(1, (std::max(bw, bh) + max_cells - 1) / max_cells);
    Shape sh;
    sh.cell = cell;
    sh.width = (bw + cell - 1) / cell;
    sh.height = (bh + cell - 1) / cell;
    sh.weights.assign(static_cast<std::size_t>(sh.width) * static_cast<std::size_t>(sh.height), 0.0f);
    std::vector<double> acc(sh.weights.size(), 0.0);
    double sum = 0.0;
    for (int py = a.y0; py < a.y1; ++py) {
        const float* lum = luminance.ptr<float>(py);
        const std::size_t row = static_cast<std::size_t>((py - a.y0) / cell) * static_cast<std::size_t>(sh.width);
        for (int px = a.x0; px < a.x1; ++px) {
            if (lum[px] < low) continue;
            acc[row + static_cast<std::size_t>((px - a.x0) / cell)] += static_cast<double>(lum[px]);
            sum += static_cast<double>(lum[px]);
        }
    }
    for (std::size_t i = 0; i < acc.size(); ++i) sh.weights[i] = static_cast<float>(acc[i] / sum);
    sh.origin_x = (a.x0 + image.x_offset) - x;
    sh.origin_y = (a.y0 + image.y_offset) - y;
    return sh;
}

// A kept component as a source in the image's coordinates, with its shape when it is wider or taller than
// options.shape_min_size.
Source source_of(const Accum& a, const ImageView& image, const cv::Mat& luminance, float low, const DetectorOptions& options) {
    Source s;
    s.x = centroid_x(a) + image.x_offset;
    s.y = centroid_y(a) + image.y_offset;
    s.flux = a.rgb;
    s.luminous_flux = a.luminous();
    s.peak = a.peak;
    s.peak_channel = a.peak_channel;
    s.pixel_count = a.count;
    s.members = a.members;
    s.bbox = {a.x0 + image.x_offset, a.y0 + image.y_offset, a.x1 + image.x_offset, a.y1 + image.y_offset};
    s.extent = extent_of(a);
    const bool at_clip = options.clip_level > 0.0 && a.peak_channel >= options.clip_level;
    const bool flat_top = a.near_peak >= 4 && a.near_peak * 20 >= a.count;
    s.clipped = at_clip || flat_top;
    if (std::max(a.x1 - a.x0, a.y1 - a.y0) > options.shape_min_size)
        s.shape = shape_of(a, luminance, low, options.shape_cells, image, s.x, s.y);
    return s;
}

}  // namespace

Detection Detector::detect(const ImageView& image) {
    check_input(image);
    Detection result;
    FrameStats& st = result.stats;
    st.width = image.width;
    st.height = image.height;
    measure_luminance(image, options_.downsample, luminance_, pooled_, fine_histogram_, st);
    luminance_distribution(fine_histogram_, static_cast<std::uint64_t>(image.width) * static_cast<std::uint64_t>(image.height), st);
    st.threshold = options_.threshold.resolve(st.median_luminance, options_.min_threshold);
    st.low_threshold = st.threshold * std::exp2(-options_.hysteresis_ev);

    std::vector<Accum> comps = find_components(image, luminance_, pooled_, options_.downsample, st.low_threshold, coarse_, fine_);
    st.components = static_cast<int>(comps.size());
    comps = group_components(std::move(comps), options_, image.width, image.height, st);
    for (const Accum& a : visible_within_budget(comps, options_, st))
        result.sources.push_back(source_of(a, image, luminance_, static_cast<float>(st.low_threshold), options_));
    release_large_buffers();
    return result;
}

void Detector::release_large_buffers() {
    // Kept between frames to save the allocation, except above 4K: at 8K the luminance alone is 0.27 GB,
    // held while the flare is drawn (issue 14's memory target).
    constexpr std::size_t kKeepPixels = std::size_t{4096} * 4096;
    if (luminance_.total() > kKeepPixels) luminance_.release();
    if (fine_.labels.total() > kKeepPixels) {
        fine_.mask.release();
        fine_.labels.release();
    }
}

}  // namespace lensfx::detect
