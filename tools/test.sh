#!/usr/bin/env bash
# Command 2 of the README (and CI): install, build everything with warnings as errors and run the
# whole test suite; then the framework's and the scene map's tests under ThreadSanitizer
# (tools/sanitize.sh thread), the test suite under AddressSanitizer + UndefinedBehaviorSanitizer
# (tools/sanitize.sh address), and every fuzzer for a bounded time from that same build
# (tools/fuzz.sh). 20 to 40 minutes on 2 cores, packages installed (README gives measured runs).
set -euo pipefail
cd "$(dirname "$0")/.."
# Each part says when it starts, so that a slow CI run shows where its time went.
part() { echo "== tools/test.sh: $1, from $((SECONDS / 60)) min $((SECONDS % 60)) s"; }
part "packages"
tools/install_deps.sh --tests
part "build"
tools/build.sh
part "test suite"
(cd build && ctest --output-on-failure -j2)
part "ThreadSanitizer"
tools/sanitize.sh thread
part "AddressSanitizer"
tools/sanitize.sh address
part "fuzzers"
tools/fuzz.sh 20
echo "== tools/test.sh: everything passed in $((SECONDS / 60)) min $((SECONDS % 60)) s"
