# Finds every third-party dependency (Debian 12 packages; see scripts/install-deps.sh) and gives each an
# imported target, so the library folders only name targets.
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)

find_package(fmt REQUIRED)
find_package(nlohmann_json 3.10 REQUIRED)
find_package(tomlplusplus REQUIRED)
find_package(CLI11 REQUIRED)
find_package(OpenImageIO REQUIRED)
find_package(OpenEXR REQUIRED)
# Debian puts OpenColorIOConfig.cmake straight into /usr/share/cmake, where find_package does not look.
pkg_check_modules(OCIO REQUIRED IMPORTED_TARGET OpenColorIO)

pkg_check_modules(EGL REQUIRED IMPORTED_TARGET egl)
pkg_check_modules(EPOXY REQUIRED IMPORTED_TARGET epoxy)
pkg_check_modules(FFTW3 REQUIRED IMPORTED_TARGET fftw3)

# Debian ships OpenCV's CMake package only with the full libopencv-dev meta package; we need only
# core and imgproc, so find those two directly.
find_path(OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
foreach(module core imgproc)
  find_library(OPENCV_${module}_LIBRARY opencv_${module} REQUIRED)
  add_library(OpenCV::${module} UNKNOWN IMPORTED)
  set_target_properties(OpenCV::${module} PROPERTIES
    IMPORTED_LOCATION ${OPENCV_${module}_LIBRARY}
    INTERFACE_INCLUDE_DIRECTORIES ${OPENCV_INCLUDE_DIR})
endforeach()
set_property(TARGET OpenCV::imgproc APPEND PROPERTY INTERFACE_LINK_LIBRARIES OpenCV::core)

if(LENSFX_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
