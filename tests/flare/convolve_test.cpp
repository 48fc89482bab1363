// The FFT convolution (flare/convolve.h): the direct sum it stands for, on whole images and tile by tile.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <malloc.h>
#include <sys/stat.h>
#include <unistd.h>
#if defined(__SANITIZE_ADDRESS__)  // GCC's mark; clang's is __has_feature(address_sanitizer)
#define LENSFX_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LENSFX_TEST_ASAN 1
#endif
#endif
#if defined(LENSFX_TEST_ASAN)
// ASan's runtime (sanitizer/allocator_interface.h, not installed with every compiler).
extern "C" std::size_t __sanitizer_get_current_allocated_bytes();
#endif

#include <flare/convolve.h>

using namespace lensfx;

namespace {

// out(x, y) = sum of kernel(rx + a, ry + b) in(x - a, y - b), in double: the definition, term by term.
std::vector<double> direct(const std::vector<float>& rgb, int w, int h, const std::vector<float>& kernel, int rx, int ry) {
    std::vector<double> out(rgb.size(), 0.0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int b = -ry; b <= ry; ++b)
                for (int a = -rx; a <= rx; ++a) {
                    const int sx = x - a, sy = y - b;
                    if (sx < 0 || sy < 0 || sx >= w || sy >= h) continue;
                    const double k = kernel[static_cast<std::size_t>((ry + b) * (2 * rx + 1) + rx + a)];
                    for (std::size_t c = 0; c < 3; ++c)
                        out[static_cast<std::size_t>(y * w + x) * 3 + c] += k * static_cast<double>(rgb[static_cast<std::size_t>(sy * w + sx) * 3 + c]);
                }
    return out;
}

// A sparse image of lights (values up to 1000) and a kernel of positive weights, lopsided so a turned or
// shifted kernel shows.
struct Case {
    std::vector<float> rgb, kernel;
};
Case random_case(int w, int h, int rx, int ry, unsigned seed) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    Case c;
    c.rgb.resize(static_cast<std::size_t>(w * h * 3));
    for (float& v : c.rgb) v = u(random) < 0.05f ? 1000.0f * u(random) : 0.0f;
    c.kernel.resize(static_cast<std::size_t>((2 * rx + 1) * (2 * ry + 1)));
    for (std::size_t i = 0; i < c.kernel.size(); ++i) c.kernel[i] = u(random) * (1.0f + static_cast<float>(i % 7));
    return c;
}

// Every value within float rounding of the direct sum (relative to the image's largest result).
void expect_direct(int w, int h, int rx, int ry, unsigned seed) {
    flare::ConvolveScratch scratch;  // the FFTs' arrays (flare/convolve.h)
    Case c = random_case(w, h, rx, ry, seed);
    const std::vector<double> want = direct(c.rgb, w, h, c.kernel, rx, ry);
    flare::convolve_rgb(c.rgb, w, h, c.kernel.data(), rx, ry, scratch);
    double largest = 0.0;
    for (double v : want) largest = std::max(largest, std::abs(v));
    ASSERT_GT(largest, 0.0);
    for (std::size_t i = 0; i < want.size(); ++i)
        ASSERT_NEAR(c.rgb[i], want[i], 1e-6 * largest + 1e-7 * std::abs(want[i])) << "value " << i << " of " << w << "x" << h;
}

}  // namespace

TEST(FftConvolve, IsTheDirectSumOnAWholeImage) {
    expect_direct(37, 23, 4, 6, 1);
    expect_direct(64, 9, 0, 3, 2);  // a kernel one column wide
    expect_direct(5, 5, 7, 7, 3);   // a kernel larger than the image
}

TEST(FftConvolve, PutsTheKernelTheRightWayRound) {
    flare::ConvolveScratch scratch;  // the FFTs' arrays (flare/convolve.h)
    // One light at (10, 6): the result is the kernel itself, its centre on the light, not turned.
    const int w = 24, h = 14, rx = 3, ry = 2;
    std::vector<float> kernel(static_cast<std::size_t>((2 * rx + 1) * (2 * ry + 1)));
    for (std::size_t i = 0; i < kernel.size(); ++i) kernel[i] = static_cast<float>(i + 1);
    std::vector<float> rgb(static_cast<std::size_t>(w * h * 3), 0.0f);
    rgb[static_cast<std::size_t>(6 * w + 10) * 3 + 1] = 1.0f;
    flare::convolve_rgb(rgb, w, h, kernel.data(), rx, ry, scratch);
    for (int b = -ry; b <= ry; ++b)
        for (int a = -rx; a <= rx; ++a)
            EXPECT_NEAR(rgb[static_cast<std::size_t>((6 + b) * w + 10 + a) * 3 + 1], kernel[static_cast<std::size_t>((ry + b) * (2 * rx + 1) + rx + a)], 1e-4)
                << a << "," << b;
    EXPECT_NEAR(rgb[static_cast<std::size_t>(6 * w + 10) * 3], 0.0f, 1e-6);  // the other channels stay dark
}

TEST(FftConvolve, TilesALargeImageSeamlessly) {
    flare::ConvolveScratch scratch;  // the FFTs' arrays (flare/convolve.h)
    // Wider and taller than one transform holds: several tiles each way, lights on their seams.
    const int w = flare::kMaxFftSide + 300, h = 2 * flare::kMaxFftSide - 200, rx = 5, ry = 9;
    Case c = random_case(w, h, rx, ry, 4);
    std::vector<float> kernel = c.kernel;
    // The direct sum checked on rows and columns along the seams only (the whole is slow in a debug build).
    flare::convolve_rgb(c.rgb, w, h, kernel.data(), rx, ry, scratch);
    Case again = random_case(w, h, rx, ry, 4);
    auto direct_at = [&](int x, int y, std::size_t ch) {
        double s = 0.0;
        for (int b = -ry; b <= ry; ++b)
            for (int a = -rx; a <= rx; ++a) {
                const int sx = x - a, sy = y - b;
                if (sx < 0 || sy < 0 || sx >= w || sy >= h) continue;
                s += static_cast<double>(kernel[static_cast<std::size_t>((ry + b) * (2 * rx + 1) + rx + a)]) *
                     static_cast<double>(again.rgb[static_cast<std::size_t>(sy * w + sx) * 3 + ch]);
            }
        return s;
    };
    int checked = 0;
    for (int y = 0; y < h; y += 7)
        for (int x = 0; x < w; x += 3) {
            const bool near_seam = x % (flare::kMaxFftSide - 2 * rx) < 12 || (x + 12) % (flare::kMaxFftSide - 2 * rx) < 12 ||
                                   y % (flare::kMaxFftSide - 2 * ry) < 20 || (y + 20) % (flare::kMaxFftSide - 2 * ry) < 20 ||
                                   x >= w - 12 || y >= h - 20;
            if (!near_seam) continue;
            for (std::size_t ch = 0; ch < 3; ++ch) {
                const double want = direct_at(x, y, ch);
                ASSERT_NEAR(c.rgb[static_cast<std::size_t>(y * w + x) * 3 + ch], want, 1e-3 + 1e-6 * std::abs(want)) << x << "," << y;
            }
            ++checked;
        }
    EXPECT_GT(checked, 1000);
}

TEST(FftConvolve, SizesHaveOnlySmallPrimeFactors) {
    EXPECT_EQ(flare::fft_size(1), 1);
    EXPECT_EQ(flare::fft_size(11), 12);
    EXPECT_EQ(flare::fft_size(97), 98);
    EXPECT_EQ(flare::fft_size(121), 125);
    EXPECT_EQ(flare::fft_size(1024), 1024);
    for (int n = 1; n < 3000; ++n) {
        int m = flare::fft_size(n);
        EXPECT_GE(m, n);
        for (int p : {2, 3, 5, 7})
            while (m % p == 0) m /= p;
        EXPECT_EQ(m, 1) << n;
    }
}

namespace {

// The text of the one fftw-wisdom file in dir ("" when there is none or more than one).
std::string wisdom_text(const std::filesystem::path& dir) {
    std::string text;
    int files = 0;
    if (std::filesystem::exists(dir))
        for (const auto& entry : std::filesystem::directory_iterator(dir))
            if (entry.path().filename().string().rfind("fftw-wisdom-", 0) == 0) {
                std::ifstream in(entry.path(), std::ios::binary);
                std::ostringstream all;
                all << in.rdbuf();
                text = all.str();
                ++files;
            }
    return files == 1 ? text : "";
}

}  // namespace

TEST(FftConvolve, KeepsThePlannersWisdomInTheCacheFolder) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("lensfx-fft-wisdom-" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    flare::keep_fft_wisdom_in(dir.string());
    expect_direct(97, 61, 5, 6, 9);  // sizes no other test plans
    EXPECT_EQ(wisdom_text(dir), "") << "written once, when the folder changes or the process ends";
    flare::keep_fft_wisdom_in("");
    EXPECT_NE(wisdom_text(dir).find("fftw_wisdom"), std::string::npos) << "the planner's wisdom, under its key";
    // A damaged file is read as no wisdom: the next new size is planned afresh, right, and the file made whole.
    for (const auto& entry : std::filesystem::directory_iterator(dir)) std::ofstream(entry.path(), std::ios::binary | std::ios::trunc) << "garbage";
    flare::keep_fft_wisdom_in(dir.string());
    expect_direct(83, 47, 7, 3, 10);
    flare::keep_fft_wisdom_in("");
    EXPECT_NE(wisdom_text(dir).find("fftw_wisdom"), std::string::npos);
    std::filesystem::remove_all(dir);
}

namespace {

// Bytes the process's allocator has handed out and not had back.
std::size_t heap_in_use() {
#if defined(LENSFX_TEST_ASAN)
    return __sanitizer_get_current_allocated_bytes();
#else
    const struct mallinfo2 m = ::mallinfo2();
    return m.uordblks + m.hblkhd;
#endif
}

}  // namespace

// The transforms' arrays belong to the ConvolveScratch they came from, kept for its next convolution and
// freed with it: nothing of them is left with the process (they were once kept for its life, some 50 MB).
TEST(FftConvolve, ScratchIsKeptByItsOwnerAndFreedWithIt) {
    const int w = 700, h = 500, rx = 6, ry = 4;  // over kThreadedValues: three arrays (kernel, two threads)
    Case c = random_case(w, h, rx, ry, 12);
    {
        flare::ConvolveScratch warm;  // the size's plans made first: they are the process's
        std::vector<float> rgb = c.rgb;
        flare::convolve_rgb(rgb, w, h, c.kernel.data(), rx, ry, warm);
    }
    std::vector<float> first = c.rgb, again = c.rgb;
    const std::size_t before = heap_in_use();
    {
        flare::ConvolveScratch scratch;
        EXPECT_EQ(scratch.held_bytes(), 0u);
        flare::convolve_rgb(first, w, h, c.kernel.data(), rx, ry, scratch);
        const std::size_t values = static_cast<std::size_t>(flare::fft_size(w + 2 * rx)) * static_cast<std::size_t>(flare::fft_size(h + 2 * ry));
        EXPECT_GE(scratch.held_bytes(), 3 * values * sizeof(double)) << "kept for the next convolution";
        const std::size_t kept = heap_in_use();
        flare::convolve_rgb(again, w, h, c.kernel.data(), rx, ry, scratch);
        EXPECT_LT(heap_in_use(), kept + (std::size_t{1} << 20)) << "the second convolution reuses the arrays";
        EXPECT_EQ(again, first);
    }
    EXPECT_LT(heap_in_use(), before + (std::size_t{1} << 20)) << "freed with their owner, not kept by the process";
}

namespace {

// The one fftw-wisdom file's path in dir (empty when there is none or more than one).
std::filesystem::path wisdom_file(const std::filesystem::path& dir) {
    std::vector<std::filesystem::path> found;
    for (const auto& entry : std::filesystem::directory_iterator(dir))
        if (entry.path().filename().string().rfind("fftw-wisdom-", 0) == 0) found.push_back(entry.path());
    return found.size() == 1 ? found[0] : std::filesystem::path();
}

// Bytes this process has read through read(2) and its kin so far (/proc/self/io's rchar).
std::uint64_t bytes_read() {
    std::ifstream io("/proc/self/io");
    std::string name;
    std::uint64_t value = 0;
    while (io >> name >> value)
        if (name == "rchar:") return value;
    return 0;
}

}  // namespace

// A wisdom file planted in the cache folder that is huge (64 MiB) or a FIFO is no wisdom: it is not read (a
// FIFO would block the reader, a huge file fill memory), the convolution is right, and the next save makes a
// real wisdom file in its place.
TEST(FftConvolve, AHugeOrSpecialWisdomFileIsAMissAndReplaced) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("lensfx-fft-hostile-" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    flare::keep_fft_wisdom_in(dir.string());
    expect_direct(131, 29, 3, 2, 13);  // sizes no other test plans: each step below plans a new one
    flare::keep_fft_wisdom_in("");
    const std::filesystem::path file = wisdom_file(dir);
    ASSERT_FALSE(file.empty());
    // Its key kept, then 64 MiB of text with no end of string: all of it would be read as wisdom.
    std::string key(8, '\0');
    std::ifstream(file, std::ios::binary).read(key.data(), 8);
    key.resize(8 + *reinterpret_cast<const std::uint64_t*>(key.data()));
    std::ifstream(file, std::ios::binary).read(key.data(), static_cast<std::streamsize>(key.size()));
    {
        std::ofstream huge(file, std::ios::binary | std::ios::trunc);
        huge << key;
        const std::string block(std::size_t{1} << 20, ' ');
        for (int i = 0; i < 64; ++i) huge << block;
    }
    ASSERT_EQ(std::filesystem::file_size(file), key.size() + (std::size_t{64} << 20));
    flare::keep_fft_wisdom_in(dir.string());
    const std::uint64_t read_before = bytes_read();
    expect_direct(151, 41, 2, 3, 14);
    EXPECT_LT(bytes_read() - read_before, std::uint64_t{1} << 20) << "the huge file was read";
    flare::keep_fft_wisdom_in("");
    EXPECT_LT(std::filesystem::file_size(file), std::uintmax_t{1} << 20) << "replaced by the planner's wisdom";
    // A FIFO with no writer: a miss at once (a blocking read would hang here), replaced by a regular file.
    std::filesystem::remove(file);
    ASSERT_EQ(::mkfifo(file.c_str(), 0600), 0);
    flare::keep_fft_wisdom_in(dir.string());
    expect_direct(171, 17, 4, 1, 15);
    flare::keep_fft_wisdom_in("");
    EXPECT_TRUE(std::filesystem::is_regular_file(file));
    std::filesystem::remove_all(dir);
}
