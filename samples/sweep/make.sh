#!/usr/bin/env bash
# Regenerates the SYNTHETIC sweep samples/sweep/sweep.0000-0008.exr: no photograph, but what a real sweep
# (docs/measured-lenses.md) would record, rendered by lensfx from the petzval-kodak preset (100 mm): a
# point light of irradiance 1 at 0, 2, ... 16 degrees right of the view axis on a 72x48 mm sensor, 192x128
# pixels, its ghosts and starburst, a black level of 1e-4 and Gaussian noise of sigma 2e-5 (seeded).
# Usage: bash samples/sweep/make.sh [path/to/lensfx]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
lensfx="${1:-$here/../../build/lensfx}"
cd "$here"
rm -f sweep.*.exr
for i in $(seq 0 8); do
  "$lensfx" flare --lens petzval-kodak --angle "$((2 * i)),0" --size 192x128 --sensor 72x48 \
    --background 1e-4 --noise 2e-5 --seed "$((i + 1))" -o "$(printf 'sweep.%04d.exr' "$i")"
done
echo "make.sh: wrote $(ls sweep.*.exr | wc -l) frames, $(du -ch sweep.*.exr | tail -1 | cut -f1)"
