#!/bin/bash
# Packs what the issue-17 benchmark needs on a machine without Debian's packages (a lent GPU machine: nothing
# can be installed there) into one folder: the Release lensfx, the shared libraries it loads (all but the C and
# C++ runtimes, which the machine has, newer), libglvnd's vendor-neutral EGL/GL libraries (they find the
# machine's driver through its EGL vendor file), the frames and lens, and device_bench.sh to run there.
#
#   scripts/device_kit.sh [KIT]      # KIT defaults to .devkit (git-ignored through .git/info/exclude)
#
# Then, with the device tool: carry [".devkit"], command "bash .devkit/device_bench.sh", timeout_s 540.
set -euo pipefail
cd "$(dirname "$0")/.."
kit=${1:-.devkit}
binary=build/lensfx
shared=${LENSFX_SHARED:-../shared}
die() { echo "device_kit: $*" >&2; exit 1; }

[ -x "$binary" ] || die "no $binary: build first (scripts/build.sh)"
grep -q 'CMAKE_BUILD_TYPE:STRING=Release' build/CMakeCache.txt || die "build/ is not a Release build"
[ -f "$shared/data/hdr/ScanLines/CandleGlass.exr" ] || die "no $shared/data/hdr/ScanLines/CandleGlass.exr (LENSFX_SHARED)"

# A kit made before is replaced; any other folder of that name is left alone (KIT=. would be the checkout).
if [ -e "$kit" ] && ! { [ -f "$kit/device_bench.sh" ] && [ -f "$kit/lib.tar.xz" ]; }; then
    die "$kit exists and is not a kit made by this script: give a new folder"
fi
rm -rf "$kit"
mkdir -p "$kit/bin" "$kit/lib" "$kit/data"
cp "$binary" "$kit/bin/"

# The libraries lensfx loads, less the runtimes the machine has; the C library's own must match its loader.
base='^(linux-vdso|ld-linux|libc\.so|libm\.so|libstdc\+\+|libgcc_s|libpthread|libdl\.so|librt\.so)'
ldd "$binary" | awk '$3 ~ /^\// {print $3}' | while read -r lib; do
    name=$(basename "$lib")
    [[ $name =~ $base ]] || cp -L "$lib" "$kit/lib/$name"
done
# libepoxy opens these by name at run time (ldd does not list them); the driver comes from the machine.
for name in libEGL.so.1 libOpenGL.so.0 libGL.so.1 libGLX.so.0 libGLdispatch.so.0; do
    cp -L "/lib/x86_64-linux-gnu/$name" "$kit/lib/$name"
done

# The 1080p stage frame (as docs/benchmarks.md makes it), CandleGlass and pbrt's double Gauss.
if [ -f "${PAN1080:-}" ]; then cp "$PAN1080" "$kit/data/pan1080.exr"
else oiiotool samples/pan/pan.0001.exr --resize 1920x1080 -o "$kit/data/pan1080.exr"; fi
cp "$shared/data/hdr/ScanLines/CandleGlass.exr" "$kit/data/"
cp "$shared/reference/lenses/pbrt/dgauss.50mm.dat" "$kit/data/"
cp scripts/device_bench.sh "$kit/"

# The libraries packed (the device tool carries 64 MiB with the working tree).
tar -C "$kit" -cJf "$kit/lib.tar.xz" lib && rm -rf "$kit/lib"
# A kit inside the checkout stays out of git's view (and so travels only where carry names it).
case $kit in
    /* | ../*) ;;
    *) grep -qxF "/$kit/" .git/info/exclude 2>/dev/null || echo "/$kit/" >> .git/info/exclude ;;
esac
echo "device_kit: $(du -sh "$kit" | cut -f1) in $kit; working tree $(git ls-files -z | du -cb --files0-from=- | tail -1 | cut -f1) bytes"
