#!/usr/bin/env bash
# Command 2 of the README (and CI): install, build everything with warnings as errors, and run the
# whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
KINECT3D_WERROR=ON tools/build.sh
cd build
ctest --output-on-failure -j2
