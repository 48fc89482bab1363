#!/bin/bash
# Runs issue 17's benchmark from a kit made by scripts/device_kit.sh, on a machine with a GPU (or, to check
# the kit, here): per lens, the 1080p stage frame with scene culling and with --no-scene-cull, best of
# REPEAT runs after one warm-up (which fills the bounds-table cache); then CandleGlass with pbrt's double
# Gauss. Prints the GPU the EGL device platform found, a table of seconds and ratios, and copies canon's
# outputs to $OUT (when set), to be set beside llvmpipe's of the same commands back here.
#
#   bash .devkit/device_bench.sh            # GPU=device (default) or GPU=surfaceless (Mesa), REPEAT=3
set -uo pipefail
kit=$(cd "$(dirname "$0")" && pwd)
gpu=${GPU:-device}
repeat=${REPEAT:-3}
out=${OUT:-}
die() { echo "device_bench: $*" >&2; exit 1; }
[[ $repeat =~ ^[1-9][0-9]?$ ]] || die "REPEAT=$repeat: a count of timed runs, 1 to 99"
case $gpu in device|surfaceless|auto) ;; *) die "GPU=$gpu: device, surfaceless or auto" ;; esac
[ -f "$kit/lib.tar.xz" ] && [ -x "$kit/bin/lensfx" ] || die "$kit is not a kit made by scripts/device_kit.sh"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
trap 'exit 143' TERM INT  # the folder goes with a signal too

# The libraries unpacked; the machine's NVIDIA EGL vendor file where the environment names none.
tar -C "$work" -xJf "$kit/lib.tar.xz" 2>/dev/null || die "cannot unpack $kit/lib.tar.xz into $work (a full disk?)"
export LD_LIBRARY_PATH="$work/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
for nv in /usr/local/nvidia/lib64 /usr/local/nvidia/lib; do  # the driver's libraries, where ld.so.conf lacks them
    [ -d "$nv" ] && LD_LIBRARY_PATH="$LD_LIBRARY_PATH:$nv"
done
vendor=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
if [ -z "${__EGL_VENDOR_LIBRARY_FILENAMES:-}" ] && [ -f "$vendor" ] && [ "$gpu" = device ]; then
    export __EGL_VENDOR_LIBRARY_FILENAMES=$vendor
fi
export LENSFX_CACHE_DIR="$work/cache"  # a fresh cache of lensfx's tables (the driver keeps its shaders'), filled by the warm-up run
lensfx="$kit/bin/lensfx"
data="$kit/data"

command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
nproc
"$lensfx" --version || { ldd "$lensfx" | grep "not found"; die "lensfx does not start (a missing library?)"; }
"$lensfx" gpu --gpu "$gpu" || die "no GL context on the $gpu platform"

# Seconds of the best of `repeat` runs (after one warm-up) of lensfx with the given arguments, nan where any run
# fails (a quick failure is no time); the last output kept.
best_of() {
    local best="" t0 t1 t
    "$lensfx" --gpu "$gpu" -q "$@" >/dev/null 2>"$work/err" || { echo "FAILED: $(tail -1 "$work/err")" >&2; echo nan; return; }
    for _ in $(seq "$repeat"); do
        t0=$(date +%s.%N)
        "$lensfx" --gpu "$gpu" -q "$@" >/dev/null 2>>"$work/err" || { echo "FAILED: $(tail -1 "$work/err")" >&2; echo nan; return; }
        t1=$(date +%s.%N)
        t=$(awk -v a="$t0" -v b="$t1" 'BEGIN {print b - a}')
        if [ -z "$best" ] || awk -v t="$t" -v b="$best" 'BEGIN {exit !(t < b)}'; then best=$t; fi
    done
    printf '%.3f\n' "$best"
}

printf '%-24s %-15s %9s %9s %8s\n' image lens cull_s all_s speedup
for lens in canon-70-200 nikon-80-200 itoh-zoom; do
    cull=$(best_of -i "$data/pan1080.exr" -o "$work/cull_$lens.exr" --lens "$lens")
    all=$(best_of -i "$data/pan1080.exr" -o "$work/all_$lens.exr" --lens "$lens" --no-scene-cull)
    printf '%-24s %-15s %9s %9s %7sx\n' pan1080.exr "$lens" "$cull" "$all" "$(awk -v a="$all" -v c="$cull" 'BEGIN {printf "%.1f", a / c}')"
done
candle=$(best_of -i "$data/CandleGlass.exr" -o "$work/candle.exr" --lens "$data/dgauss.50mm.dat" --fov 40 --threshold 20 --gain 1000)
printf '%-24s %-15s %9s\n' CandleGlass.exr dgauss.50mm "$candle"
# One run's report: where the frame's time went (stages) on this machine.
"$lensfx" --gpu "$gpu" -q -i "$data/pan1080.exr" -o "$work/cull_report.exr" --lens canon-70-200 --report "$work/report.json"
grep -o '"flare[.a-z]*": [0-9.]*' "$work/report.json" | head -12

if [ -n "$out" ]; then
    cp "$work"/cull_canon-70-200.exr "$work"/all_canon-70-200.exr "$work"/candle.exr "$work/report.json" "$out/" ||
        echo "device_bench: the outputs were not all copied to $out" >&2
fi
[ -s "$work/err" ] && { echo "stderr:"; sort -u "$work/err" | head -5; }
exit 0
