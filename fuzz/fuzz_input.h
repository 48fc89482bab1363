// Helpers shared by the fuzz targets: the fuzzer's bytes as text or as a FILE* stream.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string_view>

#if __has_include(<optics/memory_budget.h>)
#include <optics/memory_budget.h>
#endif

namespace lensfx::fuzz {

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
    return {reinterpret_cast<const char*>(data), size};
}

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// The bytes as a read-only stream in memory (fmemopen), as the stream readers get stdin.
inline File memory_stream(const std::uint8_t* data, std::size_t size) {
    static const char empty = 0;
    if (size == 0) return File(fmemopen(const_cast<char*>(&empty), 0, "rb"));
    return File(fmemopen(const_cast<std::uint8_t*>(data), size, "rb"));
}

#if __has_include(<optics/memory_budget.h>)
// The memory budget the readers get (as --memory-limit 256M would give): an image larger than this is
// the readers' expected refusal, not a finding. Inputs are at most a few KB.
inline MemoryBudget fuzz_budget() { return MemoryBudget{std::size_t{256} << 20}; }
#define LENSFX_FUZZ_BUDGET , lensfx::fuzz::fuzz_budget()
#else
#define LENSFX_FUZZ_BUDGET
#endif

}  // namespace lensfx::fuzz
