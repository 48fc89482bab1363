// FFT convolution of RGB float images (flare/convolve.h).
#include <flare/convolve.h>

#include <algorithm>
#include <atomic>
#include <complex>
#include <string>
#include <string_view>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <utility>

#include <fftw3.h>

#include <flare/cache.h>

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

// Whether two texts hold the same lines in any order: FFTW exports its wisdom in hash-table order, which
// differs from run to run for the same wisdom.
bool same_lines(const std::string& a, const std::string& b) {
    if (a.size() != b.size()) return false;
    const auto lines = [](const std::string& text) {
        std::vector<std::string_view> out;
        for (std::size_t start = 0; start < text.size();) {
            const std::size_t end = std::min(text.find('\n', start), text.size());
            out.emplace_back(text.data() + start, end - start);
            start = end + 1;
        }
        std::sort(out.begin(), out.end());
        return out;
    };
    return lines(a) == lines(b);
}

// The largest wisdom file read: two runs (pan1080, CandleGlass) left 56 kB, and a cache used for a day of varied
// runs held 160 kB. A larger file is a miss; the next save replaces it with that run's wisdom alone, so the
// file cannot grow without bound either.
constexpr std::uintmax_t kMaxWisdomBytes = std::uintmax_t{1} << 20;

// What the planner knows, kept in the cache folder (keep_fft_wisdom_in): planning a size takes some 3 ms of
// CPU even with FFTW_ESTIMATE (a frame's extended groups convolve at a dozen sizes), and with the wisdom of
// an earlier run a fraction of that. Read at the first plan; written back once, when the folder changes or
// the process ends, if planning added to it (exporting costs about a millisecond). Guarded by plan_mutex.
struct Wisdom {
    std::string dir;        // empty: not kept
    bool imported = false;  // the file read (or found missing) since dir was set
    bool planned = false;   // a size planned since
    std::string known;      // the wisdom as the file last held it

    std::string key() const { return std::string("fftw wisdom for ") + fftw_version; }
    std::string file() const { return cache_file(dir, "fftw-wisdom", key_hash(key())); }

    void import() {
        imported = true;
        if (dir.empty()) return;
        CacheFile in = open_cache_file(file(), kMaxWisdomBytes);  // larger: a miss, replaced at the next save
        if (!in || !read_key(in, key())) return;
        std::string text;
        std::getline(in, text, '\0');  // the rest of the file (wisdom is text), at most its size when opened
        if (!text.empty() && fftw_import_wisdom_from_string(text.c_str())) known = std::move(text);
    }
    // Written back when planning has added to it (best effort: a cache that cannot be written only costs time).
    void save() {
        if (dir.empty() || !planned) return;
        planned = false;
        const std::unique_ptr<char, FftwFree> text(fftw_export_wisdom_to_string());
        if (!text || same_lines(known, text.get())) return;
        if (try_write_cache_file(file(), [&](std::ostream& out) {
                write_key(out, key());
                out << text.get();
            }))
            known = text.get();
    }
    ~Wisdom() { save(); }
};

// The process's, as FFTW's planner and wisdom are (convolve.h): the lock every plan is made under, and the
// wisdom kept.
std::mutex plan_mutex;
Wisdom wisdom;

const Plans& plans_for(int nx, int ny) {
    static std::map<std::pair<int, int>, Plans> made;
    const std::lock_guard<std::mutex> lock(plan_mutex);
    if (!wisdom.imported) wisdom.import();
    Plans& p = made[{nx, ny}];
    if (!p.forward) {
        const std::size_t n = static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny);
        Reals in = reals(n);
        Spectrum out = spectrum(static_cast<std::size_t>(nx / 2 + 1) * static_cast<std::size_t>(ny));
        p.inverse = fftw_plan_dft_c2r_2d(ny, nx, out.get(), in.get(), FFTW_ESTIMATE);
        p.forward = fftw_plan_dft_r2c_2d(ny, nx, in.get(), out.get(), FFTW_ESTIMATE);
        if (!p.forward || !p.inverse) throw std::runtime_error("FFTW could not plan a transform");
        wisdom.planned = true;
    }
    return p;
}

// One thread's arrays for a transform of ny rows of nx values (values: nx ny reals, spec: its half spectrum),
// at least that large.
struct Scratch {
    Reals values;
    Spectrum spec;
    std::size_t count = 0, half = 0;
};

}  // namespace

// The arrays a ConvolveScratch keeps, the largest first, under a lock (the calls sharing it may run at once).
struct ConvolveScratch::Pool {
    std::mutex mutex;
    std::vector<Scratch> kept;
};

namespace {

// At most kKeptScratch arrays are kept, the largest, so what stays is bounded by three transforms of
// kMaxFftSide^2 values (some 50 MB).
constexpr std::size_t kKeptScratch = 3;

Scratch take_scratch(ConvolveScratch::Pool& pool, std::size_t count, std::size_t half) {
    {
        const std::lock_guard<std::mutex> lock(pool.mutex);
        for (auto it = pool.kept.begin(); it != pool.kept.end(); ++it)
            if (it->count >= count && it->half >= half) {
                Scratch s = std::move(*it);
                pool.kept.erase(it);
                return s;
            }
    }
    return {reals(count), spectrum(half), count, half};
}

void keep_scratch(ConvolveScratch::Pool& pool, Scratch s) {
    const std::lock_guard<std::mutex> lock(pool.mutex);
    pool.kept.push_back(std::move(s));
    std::sort(pool.kept.begin(), pool.kept.end(), [](const Scratch& a, const Scratch& b) { return a.count > b.count; });
    if (pool.kept.size() > kKeptScratch) pool.kept.resize(kKeptScratch);
}

// Scratch taken from a pool for a convolution and given back when it ends (or throws).
struct HeldScratch {
    ConvolveScratch::Pool& pool;
    Scratch s;
    HeldScratch(ConvolveScratch::Pool& p, std::size_t count, std::size_t half) : pool(p), s(take_scratch(p, count, half)) {}
    ~HeldScratch() { keep_scratch(pool, std::move(s)); }
    HeldScratch(const HeldScratch&) = delete;
    HeldScratch& operator=(const HeldScratch&) = delete;
};

// A convolution's transforms: their size and plans, and the kernel's spectrum (scaled by 1 / (nx ny), the
// inverse's normalisation).
struct Transform {
    int nx, ny;
    const Plans& plans;

    HeldScratch kernel_held;
    fftw_complex* kernel_spec;

    Transform(int x, int y, ConvolveScratch::Pool& pool)
        : nx(x), ny(y), plans(plans_for(x, y)), kernel_held(pool, count(), half()), kernel_spec(kernel_held.s.spec.get()) {}
    std::size_t count() const { return static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny); }
    std::size_t half() const { return static_cast<std::size_t>(nx / 2 + 1) * static_cast<std::size_t>(ny); }
    double* row(Scratch& s, int y) const { return s.values.get() + static_cast<std::size_t>(y) * static_cast<std::size_t>(nx); }

    void set_kernel(const float* kernel, int kw, int kh, Scratch& s) {
        std::fill(s.values.get(), s.values.get() + count(), 0.0);
        for (int y = 0; y < kh; ++y) std::copy_n(kernel + static_cast<std::size_t>(y) * static_cast<std::size_t>(kw), kw, row(s, y));
        fftw_execute_dft_r2c(plans.forward, s.values.get(), kernel_spec);
        const double scale = 1.0 / static_cast<double>(count());
        for (std::size_t i = 0; i < half(); ++i) kernel_spec[i][0] *= scale, kernel_spec[i][1] *= scale;
    }
    // s.values (a channel's tile, placed) replaced by their circular convolution with the kernel.
    void convolve(Scratch& s) const {
        fftw_execute_dft_r2c(plans.forward, s.values.get(), s.spec.get());
        for (std::size_t i = 0; i < half(); ++i) {
            const std::complex<double> v =
                std::complex<double>(s.spec[i][0], s.spec[i][1]) * std::complex<double>(kernel_spec[i][0], kernel_spec[i][1]);
            s.spec[i][0] = v.real(), s.spec[i][1] = v.imag();
        }
        fftw_execute_dft_c2r(plans.inverse, s.spec.get(), s.values.get());
    }
};

// The tile's side along one axis: the whole image when its transform fits kMaxFftSide, else what does.
int tile_side(int n, int r) { return n + 2 * r <= kMaxFftSide ? n : std::max(kMaxFftSide - 2 * r, 64); }

// One channel of one tile: outputs [x0, x0 + tile w) x [y0, y0 + tile h).
struct Job {
    int x0, y0;
    std::size_t channel;
};

// Transforms of fewer values than this are run on the calling thread alone: a thread costs more.
constexpr std::size_t kThreadedValues = std::size_t{128} * 128;

}  // namespace

void keep_fft_wisdom_in(const std::string& dir) {
    const std::lock_guard<std::mutex> lock(plan_mutex);
    if (dir == wisdom.dir) return;
    wisdom.save();
    wisdom.dir = dir;
    wisdom.imported = false;
    wisdom.known.clear();
}

ConvolveScratch::ConvolveScratch() : pool_(std::make_unique<Pool>()) {}
ConvolveScratch::~ConvolveScratch() = default;

std::size_t ConvolveScratch::held_bytes() const {
    const std::lock_guard<std::mutex> lock(pool_->mutex);
    std::size_t bytes = 0;
    for (const Scratch& s : pool_->kept) bytes += s.count * sizeof(double) + s.half * sizeof(fftw_complex);
    return bytes;
}

void convolve_rgb(std::vector<float>& rgb, int width, int height, const float* kernel, int rx, int ry, ConvolveScratch& scratch) {
    if (width <= 0 || height <= 0) return;
    ConvolveScratch::Pool& pool = *scratch.pool_;
    const int tw = tile_side(width, rx), th = tile_side(height, ry);
    Transform t(fft_size(tw + 2 * rx), fft_size(th + 2 * ry), pool);
    HeldScratch first(pool, t.count(), t.half());
    t.set_kernel(kernel, 2 * rx + 1, 2 * ry + 1, first.s);
    // One tile reads each channel whole before writing it, so its results go straight back into rgb.
    const bool one_tile = tw == width && th == height;
    std::vector<float> separate(one_tile ? 0 : rgb.size());
    std::vector<float>& out = one_tile ? rgb : separate;
    const auto at = [width](int x, int y) { return (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)) * 3; };
    // Overlap-save: a tile's outputs [x0, x0 + w) need the inputs [x0 - rx, x0 + w + rx), placed from index 0;
    // output x is then at index x - x0 + 2 rx, clear of the transform's wrap-around.
    const auto run = [&](const Job& job, Scratch& s) {
        const int x0 = job.x0, y0 = job.y0, w = std::min(tw, width - x0), h = std::min(th, height - y0);
        const int ix0 = std::max(0, x0 - rx), ix1 = std::min(width, x0 + w + rx);
        const int iy0 = std::max(0, y0 - ry), iy1 = std::min(height, y0 + h + ry);
        std::fill(s.values.get(), s.values.get() + t.count(), 0.0);
        for (int y = iy0; y < iy1; ++y) {
            double* to = t.row(s, y - (y0 - ry)) + (ix0 - (x0 - rx));
            const float* from = rgb.data() + at(ix0, y) + job.channel;
            for (int x = ix0; x < ix1; ++x, from += 3) *to++ = static_cast<double>(*from);
        }
        t.convolve(s);
        for (int y = y0; y < y0 + h; ++y) {
            const double* from = t.row(s, y - y0 + 2 * ry) + 2 * rx;
            float* to = out.data() + at(x0, y) + job.channel;
            for (int x = 0; x < w; ++x, to += 3) *to = static_cast<float>(from[x]);
        }
    };
    std::vector<Job> jobs;
    for (int y0 = 0; y0 < height; y0 += th)
        for (int x0 = 0; x0 < width; x0 += tw)
            for (std::size_t c = 0; c < 3; ++c) jobs.push_back({x0, y0, c});
    // The jobs shared by two threads (a frame's groups are convolved while the GPU waits): each takes the next.
    std::atomic<std::size_t> next{0};
    const auto work = [&](Scratch& s) {
        for (std::size_t j; (j = next.fetch_add(1)) < jobs.size();) run(jobs[j], s);
    };
    if (t.count() >= kThreadedValues) {
        HeldScratch second(pool, t.count(), t.half());
        std::future<void> helper = std::async(std::launch::async, work, std::ref(second.s));
        work(first.s);
        helper.get();
    } else {
        work(first.s);
    }
    if (!one_tile) rgb = std::move(separate);
}

}  // namespace lensfx::flare
