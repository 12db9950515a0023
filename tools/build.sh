#!/usr/bin/env bash
# Installs missing Debian packages, then configures and builds Kinect3D in build/ (Release).
# Arguments: the targets to build (default: all). Warnings are errors (the demo and the tests build
# with the same flags, so switching between them rebuilds nothing); KINECT3D_WERROR=OFF for another
# compiler than Debian 12's.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DKINECT3D_WERROR="${KINECT3D_WERROR:-ON}"
targets=()
for target in "$@"; do targets+=(--target "$target"); done
cmake --build build -j"$(nproc)" "${targets[@]}"
