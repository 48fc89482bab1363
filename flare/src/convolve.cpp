// FFT convolution of RGB float images (flare/convolve.h).
#include <flare/convolve.h>

#include <algorithm>
#include <complex>
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <utility>

#include <fftw3.h>

namespace lensfx::flare {

int fft_size(int n) {
    for (int m = std::max(n, 1);; ++m) {
        int r = m;
        for (int p : {2, 3, 5, 7})
            while (r % p == 0) r /= p;
        if (r == 1) return m;
    }
}

namespace {

struct FftwFree {
    void operator()(void* p) const { fftw_free(p); }
};
using Reals = std::unique_ptr<double[], FftwFree>;
using Spectrum = std::unique_ptr<fftw_complex[], FftwFree>;

Reals reals(std::size_t n) {
    Reals out(fftw_alloc_real(n));
    if (!out) throw std::bad_alloc();
    return out;
}
Spectrum spectrum(std::size_t n) {
    Spectrum out(fftw_alloc_complex(n));
    if (!out) throw std::bad_alloc();
    return out;
}

// The forward (real to half spectrum) and inverse transforms of ny rows of nx values, planned once per size
// for the process (FFTW_ESTIMATE: no trial runs) and run on any arrays of fftw_malloc's alignment. FFTW's
// planner is not thread-safe: plans are made under a lock; running them is.
struct Plans {
    fftw_plan forward = nullptr;
    fftw_plan inverse = nullptr;
};

const Plans& plans_for(int nx, int ny) {
    static std::mutex mutex;
    static std::map<std::pair<int, int>, Plans> made;
    const std::lock_guard<std::mutex> lock(mutex);
    Plans& p = made[{nx, ny}];
    if (!p.forward) {
        const std::size_t n = static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny);
        Reals in = reals(n);
        Spectrum out = spectrum(static_cast<std::size_t>(nx / 2 + 1) * static_cast<std::size_t>(ny));
        p.inverse = fftw_plan_dft_c2r_2d(ny, nx, out.get(), in.get(), FFTW_ESTIMATE);
        p.forward = fftw_plan_dft_r2c_2d(ny, nx, in.get(), out.get(), FFTW_ESTIMATE);
        if (!p.forward || !p.inverse) throw std::runtime_error("FFTW could not plan a transform");
    }
    return p;
}

// One transform's arrays and the kernel's spectrum (scaled by 1 / (nx ny), the inverse's normalisation).
struct Transform {
    int nx, ny;
    const Plans& plans;
    Reals values;
    Spectrum spec;
    Spectrum kernel_spec;

    Transform(int x, int y)
        : nx(x), ny(y), plans(plans_for(x, y)), values(reals(count())), spec(spectrum(half())), kernel_spec(spectrum(half())) {}
    std::size_t count() const { return static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny); }
    std::size_t half() const { return static_cast<std::size_t>(nx / 2 + 1) * static_cast<std::size_t>(ny); }
    double* row(int y) { return values.get() + static_cast<std::size_t>(y) * static_cast<std::size_t>(nx); }

    void set_kernel(const float* kernel, int kw, int kh) {
        std::fill(values.get(), values.get() + count(), 0.0);
        for (int y = 0; y < kh; ++y) std::copy_n(kernel + static_cast<std::size_t>(y) * static_cast<std::size_t>(kw), kw, row(y));
        fftw_execute_dft_r2c(plans.forward, values.get(), kernel_spec.get());
        const double scale = 1.0 / static_cast<double>(count());
        for (std::size_t i = 0; i < half(); ++i) kernel_spec[i][0] *= scale, kernel_spec[i][1] *= scale;
    }
    // values (the channel's tile, placed) replaced by their circular convolution with the kernel.
    void convolve() {
        fftw_execute_dft_r2c(plans.forward, values.get(), spec.get());
        for (std::size_t i = 0; i < half(); ++i) {
            const std::complex<double> v = std::complex<double>(spec[i][0], spec[i][1]) * std::complex<double>(kernel_spec[i][0], kernel_spec[i][1]);
            spec[i][0] = v.real(), spec[i][1] = v.imag();
        }
        fftw_execute_dft_c2r(plans.inverse, spec.get(), values.get());
    }
};

// The tile's side along one axis: the whole image when its transform fits kMaxFftSide, else what does.
int tile_side(int n, int r) { return n + 2 * r <= kMaxFftSide ? n : std::max(kMaxFftSide - 2 * r, 64); }

}  // namespace

void convolve_rgb(std::vector<float>& rgb, int width, int height, const float* kernel, int rx, int ry) {
    if (width <= 0 || height <= 0) return;
    const int tw = tile_side(width, rx), th = tile_side(height, ry);
    Transform t(fft_size(tw + 2 * rx), fft_size(th + 2 * ry));
    t.set_kernel(kernel, 2 * rx + 1, 2 * ry + 1);
    std::vector<float> out(rgb.size());
    const auto at = [width](int x, int y) { return (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 3; };
    // Overlap-save: a tile's outputs [x0, x0 + w) need the inputs [x0 - rx, x0 + w + rx), placed from index 0;
    // output x is then at index x - x0 + 2 rx, clear of the transform's wrap-around.
    for (int y0 = 0; y0 < height; y0 += th) {
        for (int x0 = 0; x0 < width; x0 += tw) {
            const int w = std::min(tw, width - x0), h = std::min(th, height - y0);
            const int ix0 = std::max(0, x0 - rx), ix1 = std::min(width, x0 + w + rx);
            const int iy0 = std::max(0, y0 - ry), iy1 = std::min(height, y0 + h + ry);
            for (std::size_t c = 0; c < 3; ++c) {
                std::fill(t.values.get(), t.values.get() + t.count(), 0.0);
                for (int y = iy0; y < iy1; ++y) {
                    double* to = t.row(y - (y0 - ry)) + (ix0 - (x0 - rx));
                    const float* from = rgb.data() + at(ix0, y) + c;
                    for (int x = ix0; x < ix1; ++x, from += 3) *to++ = *from;
                }
                t.convolve();
                for (int y = y0; y < y0 + h; ++y) {
                    const double* from = t.row(y - y0 + 2 * ry) + 2 * rx;
                    float* to = out.data() + at(x0, y) + c;
                    for (int x = 0; x < w; ++x, to += 3) *to = static_cast<float>(from[x]);
                }
            }
        }
    }
    rgb = std::move(out);
}

}  // namespace lensfx::flare
