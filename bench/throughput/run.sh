#!/usr/bin/env bash
# Pass-through throughput of lensfx against oiiotool on the same frames, in one run.
# Makes (once) a 1920x1080 RGBA half EXR sequence from the real CandleGlass.exr (its own alpha; each frame
# a different vertical crop of the enlarged image), then times, alternating, `lensfx -i seq -o out` and
# `oiiotool --frames ... seq -o out`, both writing the same compression. Prints fps of each (best of
# REPEATS) and the ratio. Not a test.
# Usage: bash bench/throughput/run.sh [LENSFX_BINARY] [FRAMES=24] [COMPRESSION=piz] [REPEATS=3]
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
lensfx="${1:-$root/build/lensfx}"
frames="${2:-24}"
compression="${3:-piz}"
repeats="${4:-3}"
src="$root/../shared/data/hdr/ScanLines/CandleGlass.exr"
work="${LENSFX_BENCH_DIR:-/tmp/lensfx-bench-throughput}"
seq_dir="$work/seq-$compression"
mkdir -p "$seq_dir" "$work/out-lensfx" "$work/out-oiiotool"
if [ ! -f "$seq_dir/seq.$(printf %04d "$frames").exr" ]; then
  echo "making $frames frames 1920x1080 RGBA half ($compression) in $seq_dir" >&2
  oiiotool --nosoftwareattrib --frames "1-$frames" "$src" --resize 1920x1555 --cut "1920x1080+0+{FRAME_NUMBER*8}" \
    -d half --compression "$compression" -o "$seq_dir/seq.#.exr"
fi
cat "$seq_dir"/seq.*.exr > /dev/null  # both runs read from the page cache

now() { date +%s.%N; }
calc() { awk "BEGIN { print $1 }"; }
best_l=1000000; best_o=1000000
for ((i = 1; i <= repeats; i++)); do
  rm -f "$work"/out-lensfx/* "$work"/out-oiiotool/*
  t0=$(now); "$lensfx" -q -i "$seq_dir/seq.####.exr" -o "$work/out-lensfx/seq.####.exr" --frames "1-$frames" --compression "$compression"; t1=$(now)
  oiiotool --frames "1-$frames" "$seq_dir/seq.#.exr" --compression "$compression" -o "$work/out-oiiotool/seq.#.exr"; t2=$(now)
  l=$(calc "$t1 - $t0"); o=$(calc "$t2 - $t1")
  printf 'run %d: lensfx %.2f s, oiiotool %.2f s\n' "$i" "$l" "$o"
  best_l=$(calc "($l < $best_l) ? $l : $best_l"); best_o=$(calc "($o < $best_o) ? $o : $best_o")
done
idiff -q "$work/out-lensfx/seq.0001.exr" "$work/out-oiiotool/seq.0001.exr" > /dev/null && same=identical || same=DIFFERENT
printf 'machine: %s, %s cores\n' "$(lscpu | sed -n 's/^Model name: *//p')" "$(nproc)"
printf '%d frames 1920x1080 RGBA half, %s: lensfx %.2f fps, oiiotool %.2f fps, ratio %.2f (pixels %s)\n' \
  "$frames" "$compression" "$(calc "$frames / $best_l")" "$(calc "$frames / $best_o")" "$(calc "$best_o / $best_l")" "$same"
