#!/usr/bin/env bash
# Installs, builds and runs the main job on the bundled sample shot: samples/pan (24 frames, 960x540,
# a stage lamp panning through the frame) -> out/pan.####.exr, plus PNG previews of two frames and a
# per-frame timing report. Idempotent; run as root on Debian 12 (or as a user with sudo).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
mkdir -p out
# The main job: every light of the shot flared through the Brendel Tessar at f/5.6. The gains and
# --starburst-scale are artistic (1 = physical; at physical strength these ghosts are too faint to see):
# the lamp's ghosts 20x, its star 4x and 10x as long, the backdrop's flare (an extended source) at 0.2 of
# those so it does not veil the frame. The thin orange/blue streak above the lamp is in the plate.
build/lensfx -i samples/pan/pan.####.exr -o out/pan.####.exr --lens brendel-tessar --fstop 5.6 --grid 64 \
  --ghost-gain 20 --starburst-gain 4 --starburst-scale 10 --extended-gain 0.2 --report out/pan.report.json --progress
for f in 0001 0012; do
  build/lensfx -i samples/pan/pan.$f.exr -o out/before.$f.png -q   # ACES SDR video, sRGB
  build/lensfx -i out/pan.$f.exr -o out/pan.$f.png -q
done
echo "demo: wrote out/pan.0001-0024.exr, previews out/{before,pan}.{0001,0012}.png, timings out/pan.report.json"
