#!/usr/bin/env bash
# Renders the gallery of docs/gallery.md: before/after previews of every frame of ../shared/data/hdr that
# holds lights, and of the sample shot (samples/pan), each flared with the settings a compositor would pick
# (separate ghost, starburst and extended-source gains rather than one big --gain). The flare is rendered at
# full resolution, then the frame is cut to its display window, reduced to PREVIEW_WIDTH (default 800) px
# with a triangle filter in scene-linear light, tone mapped by lensfx (ACES SDR video, sRGB) to 8 bits
# without dither and stored as a 256-colour PNG (ffmpeg's palettegen), so the whole gallery stays near 6 MB.
# Needs build/lensfx (scripts/build.sh), oiiotool (openimageio-tools) and ffmpeg.
# Usage: bash scripts/gallery.sh [NAME...]   (no NAME: every item; NAME: only those, e.g. CandleGlass)
set -euo pipefail
cd "$(dirname "$0")/.."
data="${LENSFX_DATA:-../shared/data/hdr}"
out=docs/gallery
width="${PREVIEW_WIDTH:-800}"
lensfx=build/lensfx
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"
for tool in "$lensfx" oiiotool ffmpeg; do
  command -v "$tool" >/dev/null || { echo "gallery: $tool not found" >&2; exit 1; }
done

# preview IN.exr OUT.png [lensfx colour options...]: the display window, reduced, tone mapped, 256 colours.
preview() {
  local in="$1" png="$2"
  shift 2
  local full
  full="$(oiiotool --info "$in" | sed -E 's/^.*: *([0-9]+) x.*$/\1/')"  # frames narrower than that are not enlarged
  oiiotool "$in" --ch R,G,B --croptofull --resize:filter=triangle "$((full < width ? full : width))x0" -d half -o "$work/small.exr"
  "$lensfx" -i "$work/small.exr" -o "$work/small.png" --dither none -q "$@"
  ffmpeg -loglevel error -y -i "$work/small.png" \
    -vf "split[a][b];[a]palettegen=max_colors=256:stats_mode=full[p];[b][p]paletteuse=dither=sierra2_4a" "$png"
}

# item NAME IN.exr "COLOUR OPTIONS" FLARE OPTIONS...: NAME-before.png (unless the item before had the same
# input) and NAME-after.png.
last_in=""
item() {
  local name="$1" in="$2" colour="$3"
  shift 3
  if [ "${#wanted[@]}" -gt 0 ] && [[ ! " ${wanted[*]} " == *" $name "* ]]; then return; fi
  echo "gallery: $name: $*" >&2
  # shellcheck disable=SC2086 # the colour options are words
  [ "$in" = "$last_in" ] || preview "$in" "$out/$name-before.png" $colour
  last_in="$in"
  "$lensfx" -i "$in" -o "$work/after.exr" "$@"
  # shellcheck disable=SC2086
  preview "$work/after.exr" "$out/$name-after.png" $colour
}

wanted=("$@")

# Real frames. Lights are found above luminance 20 unless the item says otherwise.
item CandleGlass "$data/ScanLines/CandleGlass.exr" "" \
  --lens pbrt-dgauss-50 --fstop 2.8 --grid 32 --ghost-gain 20 --starburst-gain 2 --starburst-scale 6
item StillLife "$data/ScanLines/StillLife.exr" "" \
  --lens mld-double-gauss --fstop 5.6 --grid 32 --ghost-gain 100 --starburst-gain 2 --starburst-scale 8
item Desk "$data/ScanLines/Desk.exr" "" \
  --lens pbrt-dgauss-50 --fstop 4 --grid 32 --ghost-gain 10 --extended-gain 0.3
# Tree's brightest pixel is 10.9 (no light at the threshold 20): the sun is added behind the leaves. Its spikes
# keep their physical length (no --starburst-scale): the light is some 1e6 times the shaded ground, so even
# so they reach some 300 px; lengthened 8x they crossed the whole frame as white bars.
item Tree "$data/ScanLines/Tree.exr" "" \
  --lens brendel-tessar --fstop 8 --grid 32 --add-light 800,140,20000,4 --ghost-gain 5 --starburst-gain 2
item GoldenGate "$data/Tiles/GoldenGate.exr" "" \
  --lens brendel-tessar --fstop 11 --grid 32 --max-lights 40 --min-light 1e-4 --ghost-gain 10 --starburst-gain 6 --starburst-scale 10
item StageEnvLatLong "$data/MultiResolution/StageEnvLatLong.exr" "" \
  --lens pbrt-wide-22 --fstop 5.6 --grid 32 --ghost-gain 10 --starburst-gain 2 --starburst-scale 10 --extended-gain 0.2
item BrightRings "$data/TestImages/BrightRings.exr" "" \
  --lens cooke-triplet --fstop 8 --grid 32 --ghost-gain 5 --extended-gain 0.5
item BrightRingsNanInf "$data/TestImages/BrightRingsNanInf.exr" "" \
  --lens cooke-triplet --fstop 8 --grid 32 --ghost-gain 5 --extended-gain 0.5

# The sample shot: the stage pan with scripts/demo.sh's settings (these previews are also the README's),
# and its backdrop at one big --gain against the controls (--extended-gain 0.2).
demo=(--lens brendel-tessar --fstop 5.6 --grid 64 --ghost-gain 20 --starburst-gain 4 --starburst-scale 10 --extended-gain 0.2)
item pan-01 samples/pan/pan.0001.exr "" "${demo[@]}"
item pan-12 samples/pan/pan.0012.exr "" "${demo[@]}"
item pan-12-gain100 samples/pan/pan.0012.exr "" \
  --lens brendel-tessar --fstop 5.6 --grid 64 --gain 100 --starburst-scale 20
echo "gallery: $(ls "$out"/*.png | wc -l) previews in $out, $(du -ch "$out"/*.png | tail -1 | cut -f1)" >&2
