#!/usr/bin/env bash
# Builds the framework (plugin loader, world state, host and its watchdog) with ThreadSanitizer in
# build-tsan/ and runs its tests there: every data race between the host's plugin threads, its
# main loop and the world state fails the run. (The scene map's ray-casting worker inside the
# detector is not covered: its tests are in the detector's suite, the heavy build.)
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install_deps.sh
flags="-fsanitize=thread -fno-omit-frame-pointer"
cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="$flags" -DCMAKE_SHARED_LINKER_FLAGS="$flags" -DCMAKE_MODULE_LINKER_FLAGS="$flags"
cmake --build build-tsan -j"$(nproc)" --target framework_tests
export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1"
# The two tests that run the product's own plugins need the detector's heavy build; they run in
# tools/test.sh's ordinary build.
build-tsan/bin/framework_tests \
  --gtest_filter=-HostProcess.DemoConfigRunsWithShippedPlugins:HostProcess.KeepsRunningWhenItsOutputIsClosed
