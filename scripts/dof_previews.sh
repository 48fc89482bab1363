#!/usr/bin/env bash
# Renders the lens-blur previews of the README (docs/images/dof/): the Beachball frame as shot and through
# pbrt-dgauss-50 at f/2.8 focused at 3 m, and the deep forest (Balls + Leaves + Trunks of
# ../shared/data/hdr/v2/LowResLeftView, Z read as centimetres) composited sharp and focused at 0.8 m and 5 m.
# Each frame is cut to its display window, reduced to PREVIEW_WIDTH (default 1024) px with a triangle filter
# in scene-linear light and tone mapped by lensfx (its default display) to an 8-bit RGB PNG over black.
# Needs build/lensfx (scripts/build.sh) and oiiotool (openimageio-tools).
# Usage: bash scripts/dof_previews.sh [NAME...]   (NAME: beachball, forest; no NAME: both)
set -euo pipefail
cd "$(dirname "$0")/.."
data="${LENSFX_DATA:-../shared/data/hdr}"
out=docs/images/dof
width="${PREVIEW_WIDTH:-1024}"
lensfx=build/lensfx
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"
for tool in "$lensfx" oiiotool; do
  command -v "$tool" >/dev/null || { echo "dof_previews: $tool not found" >&2; exit 1; }
done

# preview IN.exr OUT.png: the display window's R, G, B (premultiplied, so over black), reduced, tone mapped.
preview() {
  oiiotool "$1" --ch R,G,B --croptofull --resize:filter=triangle "${width}x0" -d half -o "$work/small.exr"
  "$lensfx" -i "$work/small.exr" -o "$2" --dither none -q
}

wanted=("$@")
want() { [ "${#wanted[@]}" -eq 0 ] || [[ " ${wanted[*]} " == *" $1 "* ]]; }

if want beachball; then
  beach="$data/Beachball/singlepart.0001.exr"
  echo "dof_previews: beachball" >&2
  preview "$beach" "$out/beachball_before.png"
  "$lensfx" -i "$beach" -o "$work/beach.exr" --dof --dof-only --lens pbrt-dgauss-50 --fstop 2.8 --focus 3 -q
  preview "$work/beach.exr" "$out/beachball_after_f2.8_3m.png"
fi

if want forest; then
  dir="$data/v2/LowResLeftView"
  deep="$dir/Balls.exr,$dir/Leaves.exr,$dir/Trunks.exr"
  echo "dof_previews: forest" >&2
  # the three deep files merged sample by sample, then flattened: the sharp composite
  oiiotool "$dir/Balls.exr" "$dir/Leaves.exr" --deepmerge "$dir/Trunks.exr" --deepmerge --flatten \
    -o "$work/forest_sharp.exr"
  preview "$work/forest_sharp.exr" "$out/forest_sharp.png"
  for focus in 0.8 5; do
    "$lensfx" -i "$dir/Balls.exr" --deep "$deep" -o "$work/forest.exr" --dof --dof-only --depth-scale 0.01 \
      --lens pbrt-dgauss-50 --fstop 2.8 --focus "$focus" -q
    preview "$work/forest.exr" "$out/forest_focus_${focus}m.png"
  done
fi
