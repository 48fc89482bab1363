// The GL resources a FlareRenderer keeps between renders, each remade only when what it depends on changes:
// the render targets (by image size) and the iris textures (by iris shape and ringing order). Needs a current
// gpu::Context.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include <gpu/gl.h>
#include <optics/lens.h>

namespace lensfx::gpu {

// The RGBA32F targets ghosts are drawn into: the full-size one (or a band of its rows) and those at 1/2, 1/4,
// 1/8, 1/16 and (faint ghosts only) 1/32 of the image. Each is kept while it is asked for at the same size and remade at another.
class RenderTargets {
public:
    static constexpr std::size_t kSlots = 6;
    // Which of the kSlots targets holds 1/reduce of the image (0 the full size ... 5 the 1/32); throws
    // std::logic_error for a reduce other than 1, 2, 4, 8, 16 or 32.
    static std::size_t slot(int reduce);
    // The full-size target for a band of `rows` rows of a width-wide image.
    FloatTarget& full(int width, int rows);
    // The target at 1/reduce of width x height (each side rounded up).
    FloatTarget& reduced(int reduce, int width, int height);
    // Frees every target (made again when next asked for), and lets the driver free their memory now.
    void release();
    // Clears the target in `slot` (which must exist) before it is drawn into: only where a read-back last saw
    // it lit (lit_within), else whole. Clearing the 33 MB full-size target of a 1080p frame whole took ~8 ms on
    // llvmpipe, and an extended light's groups clear it once each.
    void clear(std::size_t slot);
    // After a read-back of the target in `slot`: every texel outside `lit` holds the cleared value.
    void lit_within(std::size_t slot, const TexelRect& lit) { lit_[slot] = lit; }
    int made() const { return made_; }  // targets made so far (each a GL allocation)

private:
    FloatTarget& sized(std::size_t slot, int width, int height);
    std::optional<FloatTarget> targets_[kSlots];
    std::optional<TexelRect> lit_[kSlots];  // where each may hold anything but zeros; none: anywhere
    int made_ = 0;
};

// The iris the ghosts are shaded by, as R32F textures of kSize x kSize texels over [-kExtent, kExtent]^2 stop
// radii: the sharp iris's signed distance (one texture, remade when the iris's shape changes) and its ringing at
// a fractional Fourier order (eq. 5; the last 16 orders and shapes kept).
class IrisTextures {
public:
    static constexpr int kSize = 512;
    static constexpr double kExtent = 1.25;
    static constexpr std::size_t kRingingKept = 16;
    // The signed-distance texture of `aperture`'s iris (its blades, rotation and curvature).
    unsigned sdf(const optics::Aperture& aperture);
    // The ringing texture of `aperture`'s iris at FrFT order `alpha`.
    unsigned ringing(const optics::Aperture& aperture, double alpha);
    int uploads() const { return uploads_; }  // textures computed and uploaded so far

private:
    struct Ringing {
        optics::Aperture aperture;
        double alpha = 0.0;
        GlObject texture;
    };
    GlObject upload(const std::vector<float>& bottom_up, bool border, const char* what);
    GlObject sdf_texture_;
    std::optional<optics::Aperture> sdf_of_;
    std::vector<Ringing> ringing_;
    int uploads_ = 0;
};

}  // namespace lensfx::gpu
