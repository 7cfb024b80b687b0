#!/usr/bin/env bash
# The long fuzzing run people do (docs/fuzzing.md; CI runs each fuzzer for a minute instead):
# builds the fuzzers in the sanitizer build and runs them one after another, each for SECONDS
# (default 600) at nice 10, from its corpus in the build tree and the seeds, with CTest's options
# (-timeout=10 -rss_limit_mb=2048). New inputs stay in BUILD/fuzz/corpus/NAME for the next run;
# a crash, leak, timeout or over-large allocation leaves its input in BUILD/fuzz/artifacts/NAME/.
# Prints one line per fuzzer (runs, exec/s, corpus, coverage) and exits 1 if any failed.
# Usage: scripts/fuzz.sh [SECONDS] [NAME...]   (NAME: esvo rvol gltf mesh drc; default all)
# Environment: LIBVOX_SANITIZE_BUILD (default build-sanitize), LIBVOX_FUZZ_JOBS (parallel
# fuzzers, default 1: the run is meant to share the machine).
set -euo pipefail
cd "$(dirname "$0")/.."

seconds="${1:-600}"
shift || true
names=("$@")
[ ${#names[@]} -eq 0 ] && names=(esvo rvol gltf mesh drc)
build="${LIBVOX_SANITIZE_BUILD:-build-sanitize}"

[ -f "$build/CMakeCache.txt" ] || ./scripts/configure-sanitize.sh "$build"
cmake --build "$build" --target "${names[@]/#/fuzz_}"

# The same sanitizer options as CTest's (cmake/LibvoxSanitizers.cmake).
export ASAN_OPTIONS="detect_leaks=1:check_initialization_order=1:strict_init_order=1:intercept_tls_get_addr=0"
export LSAN_OPTIONS="suppressions=$PWD/cmake/lsan-suppressions.txt:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

mkdir -p "$build/fuzz/logs"
failed=0
for name in "${names[@]}"; do
  log="$build/fuzz/logs/$name.log"
  # shellcheck disable=SC2046 # the .args file is a space-separated argument list
  if nice -n 10 "$build/fuzz/fuzz_$name" -max_total_time="$seconds" $(cat "$build/fuzz/$name.args") >"$log" 2>&1; then
    result=ok
  else
    result="FAILED (see $log)"
    failed=1
  fi
  done_line=$(grep -E '^#[0-9]+[[:space:]]+DONE' "$log" | tail -1 || true)
  [ -n "$done_line" ] || done_line=$(grep -E '^#[0-9]+' "$log" | tail -1 || true)
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log")
  corpus=$(echo "$done_line" | grep -oE 'corp: [0-9]+/[0-9a-zA-Z]+' || true)
  cov=$(echo "$done_line" | grep -oE 'cov: [0-9]+ ft: [0-9]+' || true)
  echo "fuzz_$name: ${seconds} s, ${runs:-?} runs, ${rate:-?} exec/s, ${corpus:-corp: ?}, ${cov:-cov: ?}: $result"
done
exit "$failed"
