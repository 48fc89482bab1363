#!/usr/bin/env bash
# The measured-lens workflow on the synthetic sweep (make.sh): fit a measured lens, render it beside the
# physical lens it came from (PNG previews), use it in the filter, and predict where flare occurs.
# Usage: bash samples/sweep/demo.sh [OUT_DIR] [path/to/lensfx]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
out="${1:-/tmp/lensfx-sweep-demo}"
lensfx="${2:-$here/../../build/lensfx}"
mkdir -p "$out"
rm -f "$out"/petzval-measured.toml "$out"/*.png "$out"/*.json "$out"/*.exr
"$lensfx" lens fit "$here/sweep.####.exr" --angles 0:16:2 --sensor 72x48 --focal-length 100 \
  --name "petzval-kodak, measured (synthetic sweep)" -o "$out/petzval-measured.toml" --report "$out/fit-report.json"
for a in 7,0 5,6; do
  "$lensfx" flare --lens "$out/petzval-measured.toml" --angle "$a" --size 480x320 --sensor 72x48 --preview "$out/measured-$a.png" --exposure 12
  "$lensfx" flare --lens petzval-kodak --parts ghosts --angle "$a" --size 480x320 --sensor 72x48 --preview "$out/physical-$a.png" --exposure 12
done
"$lensfx" -i "$here/../pan/pan.0001.exr" -o "$out/pan-measured.exr" --lens "$out/petzval-measured.toml" --sensor 72
"$lensfx" predict --lens "$out/petzval-measured.toml" --angles 0:16:1 --sensor 72x48 --map "$out/predict-map.png"
echo "demo.sh: results in $out"
