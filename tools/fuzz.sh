#!/usr/bin/env bash
# Builds the libFuzzer harnesses (tests/fuzz) with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer in build-fuzz/, replays every stored input of each (tests/data/fuzz/
# <harness>/: seeds, and every input that ever made one fail), then fuzzes each for SECONDS
# (default 20). A finding fails the run and leaves its input in build-fuzz/crashes/<harness>/:
# fix it, and add the input to tests/data/fuzz/<harness>/ so it stays a regression test.
# Usage: tools/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-20}"
tools/install_deps.sh
flags="-fsanitize=address,undefined,fuzzer-no-link -fno-sanitize-recover=undefined -fno-omit-frame-pointer -g"
link="-fsanitize=address,undefined"
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=clang++ -DKINECT3D_FUZZ=ON \
  -DBUILD_TESTING=OFF -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_SHARED_LINKER_FLAGS="$link" -DCMAKE_EXE_LINKER_FLAGS="$link"
cmake --build build-fuzz -j"$(nproc)" --target fuzzers
export ASAN_OPTIONS=detect_leaks=1
export LSAN_OPTIONS="suppressions=$PWD/tests/sanitizers/lsan.supp"
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
for seeds in tests/data/fuzz/*/; do
  harness=$(basename "$seeds")
  corpus=build-fuzz/corpus/$harness
  crashes=build-fuzz/crashes/$harness
  rm -rf "$crashes"
  mkdir -p "$corpus" "$crashes"
  echo "fuzz: $harness for ${seconds} s (stored inputs: $(ls "$seeds" | wc -l))"
  # New inputs go to the build's corpus; the stored ones are read first, every run.
  build-fuzz/bin/"$harness" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$crashes/" "$corpus" "$seeds" 2>&1 | grep -E "^(#[0-9]+ +DONE|Done|stat::number_of_executed_units|==[0-9]+==ERROR|SUMMARY|.*runtime error)" || true
  if [ -n "$(ls -A "$crashes")" ]; then
    echo "fuzz: $harness FAILED on the inputs in $crashes (replay: build-fuzz/bin/$harness <input>)" >&2
    exit 1
  fi
done
echo "fuzz: no finding"
