// Writing and reading the small float R, G, B(, Z) EXRs of the lens-blur program tests.
#pragma once
#include <string>
#include <vector>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

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

}  // namespace lensfx::dof::test
