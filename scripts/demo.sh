#!/usr/bin/env bash
# Installs, builds and runs the main job on the bundled sample shot: samples/pan (24 frames, 960x540,
# a stage lamp panning through the frame) -> out/pan.####.exr, plus PNG previews of two frames and a
# per-frame timing report. Idempotent; run as root on Debian 12 (or as a user with sudo).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
mkdir -p out
build/lensfx -i samples/pan/pan.####.exr -o out/pan.####.exr --report out/pan.report.json --progress
for f in 0001 0012; do
  oiiotool out/pan.$f.exr --colorconvert linear sRGB -d uint8 -o out/pan.$f.png
done
echo "demo: wrote out/pan.0001-0024.exr, previews out/pan.0001.png and out/pan.0012.png, timings out/pan.report.json"
