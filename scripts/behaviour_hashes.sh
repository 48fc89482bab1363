#!/usr/bin/env bash
# Prints "sha256  command" for a fixed set of lensfx runs, so a restructuring can show that it changed no
# output: run it on the old binary and on the new one and diff the two lists. Every output file is hashed
# whole (PNG, EXR, PFM, raw streams; EXR files carry no build or time metadata), except a TIFF, which carries
# the time it was written (DateTime): it is hashed as oiiotool describes it (pixels' SHA-1, other attributes).
#   bash scripts/behaviour_hashes.sh [LENSFX] > hashes.txt     (LENSFX: default build/lensfx)
# FLARE_SIZE=WxH sets the size of the per-lens `lensfx flare` runs (default 240x160).
set -euo pipefail
cd "$(dirname "$0")/.."
LENSFX=$(realpath "${1:-build/lensfx}")
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
export LENSFX_CACHE_DIR=none      # no cache hit or miss may change a result
S=samples/pan
FLARE_SIZE=${FLARE_SIZE:-240x160}

# content FILE : what is hashed of an output file.
content() {
    case "$1" in
        *.tif) oiiotool --info -v --hash "$1" | grep -v DateTime | sed "s|$T/||g" ;;
        *) cat "$1" ;;
    esac
}
# run CMD... : runs a command whose outputs land in $T/out*, prints each output's hash and the command.
run() {
    rm -f "$T"/out*
    "$@" > "$T/stdout" 2> "$T/stderr" || { echo "FAILED ($?): $*" ; cat "$T/stderr"; return 0; }
    local f
    for f in "$T"/out*; do
        [ -e "$f" ] && echo "$(content "$f" | sha256sum | cut -c1-16)  $(basename "$f"): $*" | sed "s|$T/||g; s|$LENSFX|lensfx|g"
    done
}
# stream CMD... : hashes a command's stdout.
stream() {
    echo "$(bash -c "$*" 2> "$T/stderr" | sha256sum | cut -c1-16)  stdout: $*" | sed "s|$T/||g; s|$LENSFX|lensfx|g"
}

# The README's main job (scripts/demo.sh), on four frames of the sample shot.
run "$LENSFX" -i "$S/pan.####.exr" -o "$T/out.####.exr" --frames 9-12 --lens brendel-tessar --fstop 5.6 --grid 64 \
    --gain 20 --starburst-scale 20 -q
# The demo's own options (extended sources' footprints at --extended-gain 0.2), and added extended lights.
run "$LENSFX" -i "$S/pan.####.exr" -o "$T/out.####.exr" --frames 1,12 --lens brendel-tessar --fstop 5.6 --grid 64 \
    --ghost-gain 20 --starburst-gain 4 --starburst-scale 10 --extended-gain 0.2 -q
run "$LENSFX" -i "$S/pan.0012.exr" -o "$T/out.exr" --lens mld-double-gauss --add-light 300,200,5000,14 \
    --add-light 700,120,2000,30 --gain 20 -q
# One light through every preset lens at two angles (ghosts and starburst).
for lens in presets/lenses/*.toml; do
    name=$(basename "$lens" .toml)
    for angle in 3,2 14,9; do
        run "$LENSFX" flare --lens "$name" --angle "$angle" --size "$FLARE_SIZE" -o "$T/out.exr"
    done
done
run "$LENSFX" flare --lens cooke-triplet --angle 8,5 --size 240x160 --bands 7 --band-filter -o "$T/out.exr" --preview "$T/out.png"
# Colour: the displays and views, PNG bit depths, JPEG, EXR with a display, working spaces, CPU and GPU transforms.
F=$S/pan.0012.exr
run "$LENSFX" -i "$F" -o "$T/out.png" -q
run "$LENSFX" -i "$F" -o "$T/out.png" --bits 16 --exposure -1 -q
run "$LENSFX" -i "$F" -o "$T/out.png" --view Un-tone-mapped -q
run "$LENSFX" -i "$F" -o "$T/out.png" --display rec709 -q
run "$LENSFX" -i "$F" -o "$T/out.png" --display rec2100-pq --bits 16 -q
run "$LENSFX" -i "$F" -o "$T/out.jpg" -q
run "$LENSFX" -i "$F" -o "$T/out.exr" --display srgb -q
run "$LENSFX" -i "$F" -o "$T/out.png" --colorspace ACEScg -q
run "$LENSFX" -i "$F" -o "$T/out.png" --colour-on gpu --gpu surfaceless -q
run "$LENSFX" -i "$F" -o "$T/out.png" --lens cooke-triplet --gain 20 -q
run "$LENSFX" -i "$F" -o "$T/out.exr" --lens cooke-triplet --colorspace ACEScg -q
run "$LENSFX" -i "$F" -o "$T/out.hdr" -q
run "$LENSFX" -i "$F" -o "$T/out.tif" -q
# Streams: EXR, PFM and raw planar float in and out.
stream "cat $S/pan.0011.exr $F | $LENSFX -i - -o - -q"
stream "cat $S/pan.0011.exr $F | $LENSFX -i - -o - --stream-format pfm -q"
stream "cat $S/pan.0011.exr $F | $LENSFX -i - -o - --pix-fmt gbrapf32le --lens cooke-triplet -q"
stream "cat $S/pan.0011.exr $F | $LENSFX -i - -o - --stream-format pfm -q | $LENSFX -i - -o - -q"
stream "cat $S/pan.0011.exr $F | $LENSFX -i - -o - --pix-fmt gbrpf32le -q | $LENSFX -i - -o - --pix-fmt gbrpf32le --size 960x540 --stream-format exr -q"
stream "$LENSFX lens info cooke-triplet --json"
stream "$LENSFX lens trace mld-double-gauss --height 5 --angle 3 --wavelength 550 --json"
