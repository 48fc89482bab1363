#!/usr/bin/env bash
# Builds the libFuzzer targets (build-fuzz/: Debian's clang-14, ASan + UBSan, every library instrumented)
# and runs each for SECONDS (default 60) from its seed corpus fuzz/corpus/<target>/, which is read, never
# written: new inputs go to a scratch folder. Prints the executions and findings of every target and exits
# non-zero when any found a crash, sanitizer report, leak, timeout or out-of-memory; the inputs that did
# are kept in build-fuzz/findings/<target>/. See docs/fuzzing.md.
#   scripts/fuzz.sh [SECONDS] [TARGET...]      e.g. scripts/fuzz.sh 300 pfm_reader lens_toml
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift $(($# > 0 ? 1 : 0))
targets=("$@")
if ((${#targets[@]} == 0)); then
  targets=(exr_reader pfm_reader raw_reader lens_toml lens_pbrt lens_lentil track_file look_file options)
fi

cxx=${LENSFX_FUZZ_CXX:-clang++-14}
launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" \
  -DCMAKE_CXX_COMPILER="$cxx" -DLENSFX_FUZZ=ON \
  -DLENSFX_BUILD_TESTS=OFF -DLENSFX_BUILD_BENCH=OFF -DLENSFX_WERROR=OFF "${launcher[@]}" >/dev/null
cmake --build build-fuzz --target fuzzers -j "${LENSFX_FUZZ_JOBS:-2}"

scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
failed=()
total_execs=0
printf '%-12s %6s %12s %9s  %s\n' target seconds executions corpus findings
for t in "${targets[@]}"; do
  binary=build-fuzz/fuzz/fuzz_$t
  findings=build-fuzz/findings/$t
  mkdir -p "$scratch/$t" "$findings"
  max_len=4096
  extra=()
  if [ "$t" = options ]; then
    max_len=512
    extra=(-dict=fuzz/options.dict)
  fi
  log=build-fuzz/findings/$t.log
  status=0
  "$binary" -max_total_time="$seconds" -max_len="$max_len" -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=10 \
    -print_final_stats=1 -artifact_prefix="$findings/" "${extra[@]}" "$scratch/$t" "fuzz/corpus/$t" >"$log" 2>&1 || status=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  corpus=$(find "$scratch/$t" -type f | wc -l)
  result=none
  if ((status != 0)); then
    result="FOUND: $(grep -m1 -E '^(==[0-9]+==ERROR|SUMMARY|.*runtime error|.*deadly signal)' "$log" || echo "exit $status") -> $findings/ (log $log)"
    failed+=("$t")
  fi
  printf '%-12s %6s %12s %9s  %s\n' "$t" "$seconds" "${execs:-?}" "$corpus" "$result"
  total_execs=$((total_execs + ${execs:-0}))
done
echo "fuzz: ${#targets[@]} targets, $total_execs executions, ${#failed[@]} with findings${failed:+ (${failed[*]})}"
((${#failed[@]} == 0))
