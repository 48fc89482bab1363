// The render targets and iris textures a FlareRenderer keeps between renders (gpu/render_resources.h).
#include <gpu/render_resources.h>

#include <algorithm>
#include <stdexcept>

#include <epoxy/gl.h>
#include <fmt/core.h>
#include <optics/aperture.h>
#include <optics/ringing.h>

namespace lensfx::gpu {

std::size_t RenderTargets::slot(int reduce) {
    switch (reduce) {
        case 1: return 0;
        case 2: return 1;
        case 4: return 2;
        case 8: return 3;
        case 16: return 4;
        case 32: return 5;
        default: throw std::logic_error(fmt::format("no render target at 1/{} of the image", reduce));
    }
}

FloatTarget& RenderTargets::sized(std::size_t slot, int width, int height) {
    std::optional<FloatTarget>& t = targets_[slot];
    if (!t || t->width() != width || t->height() != height) {
        t.emplace(width, height);
        lit_[slot].reset();  // its texels are undefined until cleared whole
        ++made_;
    }
    return *t;
}

FloatTarget& RenderTargets::full(int width, int rows) { return sized(0, width, rows); }

FloatTarget& RenderTargets::reduced(int reduce, int width, int height) {
    return sized(slot(reduce), (width + reduce - 1) / reduce, (height + reduce - 1) / reduce);
}

void RenderTargets::clear(std::size_t slot) {
    const FloatTarget& t = *targets_[slot];
    if (lit_[slot]) t.clear(*lit_[slot]);
    else t.clear();
    lit_[slot].reset();  // to be drawn into: lit anywhere until read back
}

void RenderTargets::release() {
    for (std::optional<FloatTarget>& t : targets_) t.reset();
    for (std::optional<TexelRect>& l : lit_) l.reset();
    // The driver (llvmpipe) keeps the last framebuffer's textures until another framebuffer is drawn to:
    // a clear of a 1 x 1 target lets them go now.
    const FloatTarget tiny(1, 1);
    tiny.bind();
    glClear(GL_COLOR_BUFFER_BIT);
    glFinish();
}

namespace {

bool same_iris(const optics::Aperture& a, const optics::Aperture& b) {
    return a.blades == b.blades && a.rotation_deg == b.rotation_deg && a.blade_curvature == b.blade_curvature;
}

// The iris's signed distance at the texel centres, bottom row (v = -extent) first as GL textures start.
std::vector<float> sdf_texels(const optics::Aperture& aperture) {
    constexpr int n = IrisTextures::kSize;
    std::vector<float> sdf(static_cast<std::size_t>(n) * n);
    const optics::IrisSdf iris_sdf(aperture);
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            const double u = IrisTextures::kExtent * (2.0 * (i + 0.5) / n - 1.0);
            const double v = IrisTextures::kExtent * (2.0 * (j + 0.5) / n - 1.0);
            sdf[static_cast<std::size_t>(j) * n + static_cast<std::size_t>(i)] = static_cast<float>(iris_sdf(u, v));
        }
    }
    return sdf;
}

// The ringing iris at FrFT order alpha, bottom row first (optics::ringing_aperture gives the top row first).
std::vector<float> ringing_texels(const optics::Aperture& aperture, double alpha) {
    constexpr int n = IrisTextures::kSize;
    const std::vector<float> top_down = optics::ringing_aperture(aperture, n, IrisTextures::kExtent, alpha);
    std::vector<float> bottom_up(top_down.size());
    for (int j = 0; j < n; ++j)
        std::copy_n(top_down.begin() + static_cast<std::ptrdiff_t>(n - 1 - j) * n, n, bottom_up.begin() + static_cast<std::ptrdiff_t>(j) * n);
    return bottom_up;
}

}  // namespace

// An R32F texture of kSize^2 texels, filtered linearly; beyond its edge the border (0) or the edge texels.
GlObject IrisTextures::upload(const std::vector<float>& bottom_up, bool border, const char* what) {
    GlObject texture = GlObject::texture();
    glTextureStorage2D(texture.get(), 1, GL_R32F, kSize, kSize);
    glTextureSubImage2D(texture.get(), 0, 0, 0, kSize, kSize, GL_RED, GL_FLOAT, bottom_up.data());
    glTextureParameteri(texture.get(), GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(texture.get(), GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    const GLint wrap = border ? GL_CLAMP_TO_BORDER : GL_CLAMP_TO_EDGE;
    glTextureParameteri(texture.get(), GL_TEXTURE_WRAP_S, wrap);
    glTextureParameteri(texture.get(), GL_TEXTURE_WRAP_T, wrap);
    check_gl(what);
    ++uploads_;
    return texture;
}

unsigned IrisTextures::sdf(const optics::Aperture& aperture) {
    if (!sdf_of_ || !same_iris(*sdf_of_, aperture)) {
        sdf_texture_ = upload(sdf_texels(aperture), false, "uploading the iris SDF texture");
        sdf_of_ = aperture;
    }
    return sdf_texture_.get();
}

unsigned IrisTextures::ringing(const optics::Aperture& aperture, double alpha) {
    for (const Ringing& r : ringing_)
        if (r.alpha == alpha && same_iris(r.aperture, aperture)) return r.texture.get();
    if (ringing_.size() >= kRingingKept) ringing_.erase(ringing_.begin());
    ringing_.push_back({aperture, alpha, upload(ringing_texels(aperture, alpha), true, "uploading the iris ringing texture")});
    return ringing_.back().texture.get();
}

}  // namespace lensfx::gpu
