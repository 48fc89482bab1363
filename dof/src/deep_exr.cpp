// Deep EXR reading and deep samples as layers (see deep_exr.h).
#include <dof/deep_exr.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include <fmt/core.h>
#include <Iex.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfDeepFrameBuffer.h>
#include <OpenEXR/ImfDeepScanLineInputFile.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfPartType.h>

#include <optics/image_window.h>

namespace lensfx::dof {

namespace {

// Reads one float channel of every sample into the member `field` of each DeepSample.
struct ChannelRead {
    const char* name;
    float DeepSample::*field;
};

// Bytes a pixel of the data window takes while it is read: its count, its offset and one sample pointer a
// channel.
double table_bytes_per_pixel(std::size_t channels) {
    return static_cast<double>(sizeof(unsigned int) + sizeof(std::uint32_t) + channels * sizeof(float*));
}

// Bytes a sample takes while it is read: the DeepSample and one float a channel as OpenEXR fills it.
double bytes_per_sample(std::size_t channels) { return static_cast<double>(sizeof(DeepSample) + channels * sizeof(float)); }

// The offsets of every pixel's samples (a prefix sum of the counts, one more than pixels). Throws when the
// counts add up beyond what the 32-bit offsets hold or what the budget allows.
std::vector<std::uint32_t> sample_offsets(const std::vector<unsigned int>& counts, std::size_t channels, const MemoryBudget& budget) {
    std::uint64_t total = 0;
    for (unsigned int c : counts) total += c;
    if (total > std::numeric_limits<std::uint32_t>::max())
        throw std::runtime_error(fmt::format("deep image declares {} samples, more than the {} lensfx reads", total,
                                             std::numeric_limits<std::uint32_t>::max()));
    budget.check(static_cast<double>(total) * bytes_per_sample(channels), fmt::format("its {} deep samples", total));
    std::vector<std::uint32_t> offsets(counts.size() + 1, 0);
    for (std::size_t i = 0; i < counts.size(); ++i) offsets[i + 1] = offsets[i] + counts[i];
    return offsets;
}

}  // namespace

bool is_deep_exr(const std::string& path) {
    try {
        Imf::MultiPartInputFile file(path.c_str());
        const Imf::Header& h = file.header(0);
        return h.hasType() && Imf::isDeepData(h.type());
    } catch (const std::exception&) {
        return false;
    }
}

DeepImage read_deep_exr(const std::string& path, const MemoryBudget& budget) {
    try {
        Imf::DeepScanLineInputFile file(path.c_str());
        const Imf::Header& header = file.header();
        const Imath::Box2i dw = header.dataWindow(), disp = header.displayWindow();
        DeepImage image;
        image.x = dw.min.x, image.y = dw.min.y;
        image.width = window_side(dw.min.x, dw.max.x, "data window"), image.height = window_side(dw.min.y, dw.max.y, "data window");
        image.full_x = disp.min.x, image.full_y = disp.min.y;
        image.full_width = window_side(disp.min.x, disp.max.x, "display window");
        image.full_height = window_side(disp.min.y, disp.max.y, "display window");
        for (const char* needed : {"R", "G", "B", "A", "Z"})
            if (!header.channels().findChannel(needed))
                throw std::runtime_error(fmt::format("deep image has no {} channel", needed));
        const bool has_zback = header.channels().findChannel("ZBack") != nullptr;

        const std::size_t channel_count = has_zback ? 6 : 5;
        budget.check(bytes_of(image.width, image.height, table_bytes_per_pixel(channel_count)),
                     fmt::format("its {}x{} deep data window's sample tables", image.width, image.height));
        const std::size_t n = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
        std::vector<unsigned int> counts(n);
        Imf::DeepFrameBuffer fb;
        const std::size_t row = static_cast<std::size_t>(image.width);
        const auto base = [&](auto* p, std::size_t elem) {
            return reinterpret_cast<char*>(p) - (static_cast<std::ptrdiff_t>(dw.min.x) + static_cast<std::ptrdiff_t>(dw.min.y) * static_cast<std::ptrdiff_t>(row)) * static_cast<std::ptrdiff_t>(elem);
        };
        fb.insertSampleCountSlice(Imf::Slice(Imf::UINT, base(counts.data(), sizeof(unsigned int)), sizeof(unsigned int),
                                             sizeof(unsigned int) * row));
        // The pointer arrays are registered first and filled once the counts are known (OpenEXR's order).
        std::vector<ChannelRead> reads{{"R", &DeepSample::r}, {"G", &DeepSample::g}, {"B", &DeepSample::b},
                                       {"A", &DeepSample::a}, {"Z", &DeepSample::z}};
        if (has_zback) reads.push_back({"ZBack", &DeepSample::zback});
        std::vector<std::vector<float*>> pointers(reads.size(), std::vector<float*>(n, nullptr));
        for (std::size_t c = 0; c < reads.size(); ++c)
            fb.insert(reads[c].name, Imf::DeepSlice(Imf::FLOAT, base(pointers[c].data(), sizeof(float*)), sizeof(float*),
                                                    sizeof(float*) * row, sizeof(float)));
        file.setFrameBuffer(fb);
        file.readPixelSampleCounts(dw.min.y, dw.max.y);

        image.offsets = sample_offsets(counts, reads.size(), budget);
        image.samples.resize(image.offsets[n]);
        std::vector<std::vector<float>> values(reads.size(), std::vector<float>(image.samples.size() + 1));
        for (std::size_t c = 0; c < reads.size(); ++c)
            for (std::size_t i = 0; i < n; ++i) pointers[c][i] = values[c].data() + image.offsets[i];
        file.readPixels(dw.min.y, dw.max.y);
        for (std::size_t c = 0; c < reads.size(); ++c)
            for (std::size_t s = 0; s < image.samples.size(); ++s) image.samples[s].*(reads[c].field) = values[c][s];
        if (!has_zback)
            for (DeepSample& s : image.samples) s.zback = s.z;
        return image;
    } catch (const Iex::BaseExc& e) {
        throw std::runtime_error(fmt::format("{}: {}", path, e.what()));
    } catch (const std::runtime_error& e) {
        throw std::runtime_error(fmt::format("{}: {}", path, e.what()));
    } catch (const std::exception& e) {  // what else OpenEXR lets out of a damaged file (std::length_error...)
        throw std::runtime_error(fmt::format("{}: damaged EXR: OpenEXR's reader failed ({})", path, e.what()));
    }
}

DeepImage reframe(const DeepImage& image, int x, int y, int width, int height) {
    DeepImage out;
    out.x = x, out.y = y, out.width = width, out.height = height;
    out.full_x = image.full_x, out.full_y = image.full_y, out.full_width = image.full_width, out.full_height = image.full_height;
    out.offsets.assign(1, 0);
    for (int py = y; py < y + height; ++py) {
        for (int px = x; px < x + width; ++px) {
            const int sx = px - image.x, sy = py - image.y;
            if (sx >= 0 && sy >= 0 && sx < image.width && sy < image.height) {
                const std::size_t i = static_cast<std::size_t>(sy) * static_cast<std::size_t>(image.width) + static_cast<std::size_t>(sx);
                out.samples.insert(out.samples.end(), image.samples.begin() + image.offsets[i], image.samples.begin() + image.offsets[i + 1]);
            }
            out.offsets.push_back(static_cast<std::uint32_t>(out.samples.size()));
        }
    }
    return out;
}

DeepImage merge_deep(const std::vector<DeepImage>& images, const MemoryBudget& budget) {
    if (images.empty()) throw std::invalid_argument("no deep images to merge");
    const DeepImage& first = images.front();
    double samples = 0;
    for (const DeepImage& im : images) samples += static_cast<double>(im.samples.size());
    // each image reframed over the display window, then the merged copy
    budget.check(bytes_of(first.full_width, first.full_height, static_cast<double>((images.size() + 1) * sizeof(std::uint32_t))) +
                     2 * samples * sizeof(DeepSample),
                 fmt::format("merging {} deep images over a {}x{} display window", images.size(), first.full_width, first.full_height));
    std::vector<DeepImage> framed;
    for (const DeepImage& im : images) framed.push_back(reframe(im, first.full_x, first.full_y, first.full_width, first.full_height));
    DeepImage out;  // over the display window, as every framed image
    out.x = out.full_x = first.full_x, out.y = out.full_y = first.full_y;
    out.width = out.full_width = first.full_width, out.height = out.full_height = first.full_height;
    const std::size_t n = static_cast<std::size_t>(out.width) * static_cast<std::size_t>(out.height);
    out.offsets.assign(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
        out.offsets[i] = static_cast<std::uint32_t>(out.samples.size());
        for (const DeepImage& im : framed)
            out.samples.insert(out.samples.end(), im.samples.begin() + im.offsets[i], im.samples.begin() + im.offsets[i + 1]);
    }
    out.offsets[n] = static_cast<std::uint32_t>(out.samples.size());
    return out;
}

namespace {

// The samples of pixel i sorted front to back.
std::vector<DeepSample> sorted_samples(const DeepImage& image, std::size_t i) {
    std::vector<DeepSample> s(image.samples.begin() + image.offsets[i], image.samples.begin() + image.offsets[i + 1]);
    std::stable_sort(s.begin(), s.end(), [](const DeepSample& a, const DeepSample& b) { return a.z < b.z; });
    return s;
}

}  // namespace

std::vector<float> flatten_deep(const DeepImage& image, std::vector<float>* z_out) {
    const std::size_t n = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
    std::vector<float> rgba(4 * n, 0.0f);
    if (z_out) z_out->assign(n, 0.0f);
    for (std::size_t i = 0; i < n; ++i) {
        float t = 1.0f;
        const std::vector<DeepSample> s = sorted_samples(image, i);
        for (const DeepSample& d : s) {
            rgba[4 * i + 0] += t * d.r, rgba[4 * i + 1] += t * d.g, rgba[4 * i + 2] += t * d.b, rgba[4 * i + 3] += t * d.a;
            t *= 1.0f - std::clamp(d.a, 0.0f, 1.0f);
        }
        if (z_out && !s.empty()) (*z_out)[i] = s.front().z;
    }
    return rgba;
}

LayerStack layers_from_deep(const DeepImage& image, double depth_scale, int max_layers, double thickness, double step) {
    const std::size_t n = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
    std::uint32_t most = 0;
    for (std::size_t i = 0; i < n; ++i) most = std::max(most, image.offsets[i + 1] - image.offsets[i]);
    LayerStack layers;
    layers.resize(image.width, image.height, std::clamp(static_cast<int>(most), 1, std::max(1, max_layers)));
    for (std::size_t i = 0; i < n; ++i) {
        const int x = static_cast<int>(i % static_cast<std::size_t>(image.width)), y = static_cast<int>(i / static_cast<std::size_t>(image.width));
        int k = 0;
        for (const DeepSample& d : sorted_samples(image, i)) {
            if (!(d.z > 0.0f) || !std::isfinite(d.z) || d.a <= 0.0f) continue;
            const std::size_t j = layers.at(std::min(k, layers.count - 1), x, y);
            if (k < layers.count) {
                layers.front[j] = static_cast<float>(static_cast<double>(d.z) * depth_scale);
                layers.back[j] = static_cast<float>(static_cast<double>(std::max(d.z, d.zback)) * depth_scale);
                layers.rgba[4 * j + 0] = d.r, layers.rgba[4 * j + 1] = d.g, layers.rgba[4 * j + 2] = d.b;
                layers.rgba[4 * j + 3] = std::min(d.a, 1.0f);
            } else {  // behind the last layer: composited under it
                const float t = 1.0f - layers.rgba[4 * j + 3];
                layers.rgba[4 * j + 0] += t * d.r, layers.rgba[4 * j + 1] += t * d.g, layers.rgba[4 * j + 2] += t * d.b;
                layers.rgba[4 * j + 3] += t * std::min(d.a, 1.0f);
            }
            ++k;
        }
    }
    set_thickness(layers, thickness, step);
    layers.open = true;
    return layers;
}

}  // namespace lensfx::dof
