#!/usr/bin/env bash
# Replays every stored input of each libFuzzer harness (tests/fuzz; tests/data/fuzz/<harness>/:
# seeds, and every input that ever made one fail), then fuzzes each for SECONDS (default 20). The
# harnesses come from the AddressSanitizer + UndefinedBehaviorSanitizer build in build-sanitize/
# (tools/sanitize.sh address --build-only). A finding fails the run and leaves its input in
# build-sanitize/fuzz/crashes/<harness>/: fix it, and add the input to tests/data/fuzz/<harness>/
# so it stays a regression test.
# Usage: tools/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-20}"
tools/sanitize.sh address --build-only
export ASAN_OPTIONS=detect_leaks=1
export LSAN_OPTIONS="suppressions=$PWD/tests/sanitizers/lsan.supp"
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# One harness: its stored inputs, then SECONDS of fuzzing; its report in build-sanitize/fuzz/<harness>.log.
fuzz_one() {
  local harness=$1 seconds=$2
  local seeds=tests/data/fuzz/$harness corpus=build-sanitize/fuzz/corpus/$harness crashes=build-sanitize/fuzz/crashes/$harness
  rm -rf "$crashes"
  mkdir -p "$corpus" "$crashes"
  # New inputs go to the build's corpus; the stored ones are read first, every run.
  local status=0
  build-sanitize/bin/"$harness" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$crashes/" "$corpus" "$seeds" > "build-sanitize/fuzz/$harness.log" 2>&1 || status=$?
  echo "fuzz: $harness for $seconds s (stored inputs: $(ls "$seeds" | wc -l)): $(grep -h '^stat::number_of_executed_units' \
    "build-sanitize/fuzz/$harness.log" | awk '{print $2}') runs"
  if [ "$status" != 0 ] || [ -n "$(ls -A "$crashes")" ]; then
    grep -E "^(==[0-9]+==ERROR|SUMMARY)|runtime error" "build-sanitize/fuzz/$harness.log" >&2 || true
    echo "fuzz: $harness FAILED (exit $status; inputs in $crashes, replay: build-sanitize/bin/$harness <input>;" \
      "report: build-sanitize/fuzz/$harness.log)" >&2
    return 1
  fi
}
export -f fuzz_one
# Each fuzzer is one process on one core: as many at a time as there are cores.
ls tests/data/fuzz | grep '^fuzz_' | xargs -P "$(nproc)" -I{} bash -c 'fuzz_one "$1" "$2"' _ {} "$seconds"
echo "fuzz: no finding"
