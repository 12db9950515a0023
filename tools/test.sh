#!/usr/bin/env bash
# Command 2 of the README: install, build, and run the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/build.sh
cd build
ctest --output-on-failure -j2
