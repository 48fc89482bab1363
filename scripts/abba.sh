#!/bin/bash
# Two programs timed alternately (A B B A, N rounds) on the same arguments: the medians of wall and CPU
# (user + system) seconds, and each run's wall time. Alternating cancels most of a shared machine's drift;
# compare figures from one call only. --gap S idles S seconds before each run, as a run started by hand would
# follow the last (a virtual machine's host may take back memory freed for longer than a second or two).
#   scripts/abba.sh [--gap S] N PROGRAM_A PROGRAM_B ARGS...
# e.g. scripts/abba.sh --gap 3 4 old/lensfx build/lensfx -i pan1080.exr -o /tmp/x.exr --lens canon-70-200
set -euo pipefail
usage() { sed -n '2,7p' "$0" >&2; exit 2; }
gap=0
if [ "${1:-}" = --gap ]; then
    [ $# -ge 2 ] && [[ $2 =~ ^[0-9]+([.][0-9]+)?$ ]] || usage
    gap=$2
    shift 2
fi
[ $# -ge 3 ] && [[ $1 =~ ^[1-9][0-9]*$ ]] || usage
/usr/bin/time --version >/dev/null 2>&1 || { echo "abba.sh: needs GNU time as /usr/bin/time (Debian: apt-get install time)" >&2; exit 2; }
n=$1 a=$2 b=$3
shift 3
wa=() wb=() ca=() cb=()
times=$(mktemp) errors=$(mktemp)
trap 'rm -f "$times" "$errors"' EXIT
for _ in $(seq "$n"); do
    for which in a b b a; do
        program=$a
        [ "$which" = b ] && program=$b
        sleep "$gap"
        # %e wall, %U user, %S system, written to $times; the program's output dropped, its errors kept for a failure
        if ! /usr/bin/time -f "%e %U %S" -o "$times" "$program" "$@" >/dev/null 2>"$errors"; then
            echo "abba.sh: $program failed (a failed run's time is not worth a median):" >&2
            tail -n 5 "$errors" >&2
            exit 1
        fi
        read -r wall cpu < <(awk '{print $1, $2 + $3}' "$times")
        if [ "$which" = a ]; then wa+=("$wall") ca+=("$cpu"); else wb+=("$wall") cb+=("$cpu"); fi
    done
done
median() { printf '%s\n' "$@" | sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
echo "A $a: wall $(median "${wa[@]}") s, CPU $(median "${ca[@]}") s  [${wa[*]}]"
echo "B $b: wall $(median "${wb[@]}") s, CPU $(median "${cb[@]}") s  [${wb[*]}]"
