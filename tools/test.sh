#!/usr/bin/env bash
# Command 2 of the README (and CI): install, build everything with warnings as errors, run the
# whole test suite, the framework's and the scene map's tests under ThreadSanitizer
# (tools/sanitize.sh thread), then every fuzzer for a bounded time (tools/fuzz.sh). About 18 to 20
# minutes on 2 cores, packages installed.
set -euo pipefail
cd "$(dirname "$0")/.."
KINECT3D_WERROR=ON tools/build.sh
(cd build && ctest --output-on-failure -j2)
tools/sanitize.sh thread
tools/fuzz.sh 20
