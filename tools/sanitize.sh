#!/usr/bin/env bash
# Builds with a sanitizer in a build folder of its own and runs tests under it. Any finding fails.
#   tools/sanitize.sh [address]  AddressSanitizer + UndefinedBehaviorSanitizer in build-sanitize/,
#                                the whole test suite (the install and style checks excepted: they
#                                test packaging, not code). OpenNI2's own process-wide allocations
#                                are suppressed (tests/sanitizers/lsan.supp says why). Not yet in
#                                CI: on a 2-core VM the build alone takes about 15 minutes.
#   tools/sanitize.sh thread     ThreadSanitizer in build-tsan/, where threads meet: the framework's
#                                tests (plugin loader, world state, host and its watchdog) and the
#                                scene map's (its ray-casting worker), each built without the
#                                detector's heavy build. In CI (tools/test.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
mode="${1:-address}"
case "$mode" in
  address) dir=build-sanitize flags="-fsanitize=address,undefined -fno-omit-frame-pointer" targets=() ;;
  thread) dir=build-tsan flags="-fsanitize=thread -fno-omit-frame-pointer" targets=(--target framework_tests scene_map_tests) ;;
  *) echo "usage: tools/sanitize.sh [address|thread]" >&2; exit 2 ;;
esac
tools/install_deps.sh
cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="$flags" -DCMAKE_SHARED_LINKER_FLAGS="$flags" -DCMAKE_MODULE_LINKER_FLAGS="$flags"
cmake --build "$dir" -j"$(nproc)" "${targets[@]}"
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
ctest --output-on-failure -j2 -E "^(Install|Style)\."
