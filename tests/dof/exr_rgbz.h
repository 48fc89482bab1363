// Writing and reading the small float R, G, B(, Z) EXRs and deep EXRs of the lens-blur tests.
#pragma once
#include <string>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfDeepFrameBuffer.h>
#include <OpenEXR/ImfDeepScanLineOutputFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfPartType.h>

namespace lensfx::dof::test {

// Planes of one channel each, rows top first; `chromaticities`: the file's primaries (null: none, Rec. 709).
inline void write_exr(const std::string& path, int w, int h, const std::vector<std::string>& names, const std::vector<std::vector<float>>& planes,
                      const Imf::Chromaticities* chromaticities = nullptr) {
    Imf::Header header(w, h);
    if (chromaticities) Imf::addChromaticities(header, *chromaticities);
    Imf::FrameBuffer fb;
    for (std::size_t c = 0; c < names.size(); ++c) {
        header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
        fb.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(const_cast<float*>(planes[c].data())), sizeof(float), sizeof(float) * static_cast<std::size_t>(w)));
    }
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(h);
}

// One channel over the display window (0 outside the data window).
inline std::vector<float> read_channel(const std::string& path, const std::string& name, int& w, int& h) {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i disp = file.header().displayWindow();
    w = disp.max.x - disp.min.x + 1, h = disp.max.y - disp.min.y + 1;
    std::vector<float> plane(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0.0f);
    Imf::FrameBuffer fb;
    fb.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(plane.data()), sizeof(float), sizeof(float) * static_cast<std::size_t>(w)));
    file.setFrameBuffer(fb);
    const Imath::Box2i dw = file.header().dataWindow();
    file.readPixels(dw.min.y, dw.max.y);
    return plane;
}

// A 3 x 2 deep file whose pixel i holds i % 3 samples, sample s of it R = 10 i + s, Z = 1 + s.
inline void write_small_deep(const std::string& path) {
    constexpr int kW = 3, kH = 2;
    Imf::Header header(kW, kH);
    for (const char* c : {"R", "G", "B", "A", "Z"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    header.setType(Imf::DEEPSCANLINE);
    header.compression() = Imf::ZIPS_COMPRESSION;
    std::vector<unsigned int> counts(kW * kH);
    std::vector<std::vector<float>> values(5);
    std::vector<std::vector<float*>> pointers(5, std::vector<float*>(kW * kH));
    for (int i = 0; i < kW * kH; ++i) counts[static_cast<std::size_t>(i)] = static_cast<unsigned int>(i % 3);
    for (auto& v : values) v.resize(16);
    Imf::DeepFrameBuffer fb;
    fb.insertSampleCountSlice(Imf::Slice(Imf::UINT, reinterpret_cast<char*>(counts.data()), sizeof(unsigned int), sizeof(unsigned int) * kW));
    const char* names[] = {"R", "G", "B", "A", "Z"};
    for (std::size_t c = 0; c < 5; ++c) {
        std::size_t next = 0;
        for (std::size_t i = 0; i < counts.size(); ++i) {
            pointers[c][i] = values[c].data() + next;
            for (unsigned s = 0; s < counts[i]; ++s)
                values[c][next + s] = c == 0 ? static_cast<float>(10 * i + s) : c == 3 ? 1.0f : c == 4 ? 1.0f + static_cast<float>(s) : 0.0f;
            next += counts[i];
        }
        fb.insert(names[c], Imf::DeepSlice(Imf::FLOAT, reinterpret_cast<char*>(pointers[c].data()), sizeof(float*), sizeof(float*) * kW, sizeof(float)));
    }
    Imf::DeepScanLineOutputFile out(path.c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(kH);
}

}  // namespace lensfx::dof::test
