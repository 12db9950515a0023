#!/usr/bin/env bash
# Command 2 of the README (and CI): install, build everything with warnings as errors and run the
# whole test suite; then the framework's and the scene map's tests under ThreadSanitizer
# (tools/sanitize.sh thread), the test suite under AddressSanitizer + UndefinedBehaviorSanitizer
# (tools/sanitize.sh address), and every fuzzer for a bounded time from that same build
# (tools/fuzz.sh). About 15 minutes on 2 cores, packages installed.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install_deps.sh --tests
tools/build.sh
(cd build && ctest --output-on-failure -j2)
tools/sanitize.sh thread
tools/sanitize.sh address
tools/fuzz.sh 20
