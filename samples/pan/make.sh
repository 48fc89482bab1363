#!/usr/bin/env bash
# Regenerates the sample shot samples/pan/pan.0001-0024.exr from the OpenEXR project's
# StageEnvLatLong.exr (BSD-3-Clause, see LICENSE here): a 480x270 window of the stage that pans 10 px a
# frame from right to left past the stage lamp (peak 4096), enlarged 2x with a tent filter (no negative
# lobes around the lamp) to 960x540, half float, DWAA level 200 (about 0.3 MB a frame). Needs oiiotool (openimageio-tools).
# Usage: bash samples/pan/make.sh [path/to/StageEnvLatLong.exr]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
src="${1:-$here/../../../shared/data/hdr/MultiResolution/StageEnvLatLong.exr}"
[ -f "$src" ] || { echo "make.sh: $src not found" >&2; exit 1; }
cd "$here"
rm -f pan.*.exr
oiiotool --nosoftwareattrib --frames 1-24 "$src" --cut "480x270+{230+FRAME_NUMBER*10}+20" --resize:filter=triangle 960x540 \
  -d half --compression dwaa:200 --attrib:type=rational FramesPerSecond 24/1 \
  -o:scanline=1 pan.#.exr
cp "$(dirname "$src")/../LICENSE" LICENSE
echo "make.sh: wrote $(ls pan.*.exr | wc -l) frames, $(du -ch pan.*.exr | tail -1 | cut -f1)"
