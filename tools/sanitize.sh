#!/usr/bin/env bash
# Builds with a sanitizer in a build folder of its own and runs tests under it. Any finding fails.
#   tools/sanitize.sh [address]  AddressSanitizer + UndefinedBehaviorSanitizer in build-sanitize/
#                                (clang, -O1), the whole test suite but the tests excluded below.
#                                The same build holds the libFuzzer harnesses (tools/fuzz.sh), so
#                                the libraries are instrumented once for both. OpenNI2's own
#                                process-wide allocations are suppressed (tests/sanitizers/lsan.supp
#                                says why). In CI (tools/test.sh).
#   tools/sanitize.sh address --build-only   the same build, no tests (tools/fuzz.sh uses it).
#   tools/sanitize.sh thread     ThreadSanitizer in build-tsan/, where threads meet: the framework's
#                                tests (plugin loader, world state, host and its watchdog) and the
#                                scene map's (its ray-casting worker), each built without the
#                                detector's heavy build. In CI (tools/test.sh).
#   tools/sanitize.sh thread --build-only   the same build, no tests (tools/test.sh builds both
#                                sanitizers' trees beside the test suite).
set -euo pipefail
cd "$(dirname "$0")/.."
usage() { echo "usage: tools/sanitize.sh [address | thread] [--build-only]" >&2; exit 2; }
mode="${1:-address}"
build_only=false
case "${2:-}" in
  "") ;;
  --build-only) build_only=true ;;
  *) usage ;;
esac
case "$mode" in
  address)
    # The coverage libFuzzer needs is its edge counters alone: its comparison hooks (part of
    # -fsanitize=fuzzer-no-link) made the simulator's renderer, and so the suite, several times
    # slower. UBSan's object-size check is left out for the same reason: ASan finds what it does.
    # -O1 with line tables only keeps the build short, and every report still names file and line.
    dir=build-sanitize
    flags="-fsanitize=address,undefined -fno-sanitize=object-size -fno-sanitize-recover=undefined \
-fsanitize-coverage=inline-8bit-counters,pc-table -fno-omit-frame-pointer -gline-tables-only"
    link="-fsanitize=address,undefined"
    # The tests' own sources at -O1 too (tests/CMakeLists.txt): at -O0 the detector's inline code they
    # call ran ten times slower (a dark-panel test 9 -> 107 s).
    config=(-DCMAKE_CXX_COMPILER=clang++ -DKINECT3D_FUZZ=ON -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS_RELEASE=-O1 -DNDEBUG")
    # What the tests and the fuzzers need (the benchmark is left out).
    targets=(--target kinect3d_tests framework_tests fusion_tests scene_map_tests fuzzers)
    ;;
  thread)
    dir=build-tsan
    flags="-fsanitize=thread -fno-omit-frame-pointer"
    link="$flags"
    config=(-DCMAKE_BUILD_TYPE=RelWithDebInfo)
    targets=(--target framework_tests scene_map_tests)
    ;;
  *) usage ;;
esac
tools/install_deps.sh --tests
cmake -S . -B "$dir" "${config[@]}" -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$link" \
  -DCMAKE_SHARED_LINKER_FLAGS="$link" -DCMAKE_MODULE_LINKER_FLAGS="$link"
cmake --build "$dir" -j"$(nproc)" "${targets[@]}"
if $build_only; then exit 0; fi
if [ "$mode" = thread ]; then
  export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1"
  # The two tests that run the product's own plugins need the detector's heavy build; they run in
  # tools/test.sh's ordinary build.
  "$dir"/bin/framework_tests \
    --gtest_filter=-HostProcess.DemoConfigRunsWithShippedPlugins:HostProcess.KeepsRunningWhenItsOutputIsClosed
  exec "$dir"/bin/scene_map_tests
fi
cd "$dir"
export ASAN_OPTIONS=detect_leaks=1
export LSAN_OPTIONS="suppressions=$PWD/../tests/sanitizers/lsan.supp"
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# Not run here: the install and style checks (they test packaging, not code), and the heaviest
# scenario tests. Those play the demo robot or many simulated scenes through the whole pipeline,
# each for 30 to 80 s under the sanitizers (2 to 20 s without), and the real-time ones fail on
# time there: the detector cannot keep up with 30 frames a second when every access is checked.
# What they run, the tests left in run under the sanitizers too (the host with every plugin and the
# logger, the viewer's server, the detector on each kind of scene); they all run in tools/test.sh's
# ordinary build.
ctest --output-on-failure -j2 -L sanitizer-safe  # the heaviest scenario tests run in the ordinary build (tests/labels.cmake)
