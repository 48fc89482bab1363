# Warning and sanitizer flags shared by every lensfx target (applied through lensfx_warnings).
add_library(lensfx_warnings INTERFACE)
target_compile_options(lensfx_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align -Woverloaded-virtual
  -Wnull-dereference -Wdouble-promotion -Wimplicit-fallthrough
  $<$<BOOL:${LENSFX_WERROR}>:-Werror>)

if(LENSFX_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()

# Fuzzing (fuzz/, docs/fuzzing.md): every library gets libFuzzer's coverage instrumentation and the sanitizers;
# only the fuzz targets link libFuzzer's driver (-fsanitize=fuzzer, in fuzz/CMakeLists.txt).
if(LENSFX_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "LENSFX_FUZZ needs clang (libFuzzer): -DCMAKE_CXX_COMPILER=clang++")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
