#!/usr/bin/env bash
# Installs missing Debian packages, then configures and builds Kinect3D in build/ (Release).
# Arguments: the targets to build (default: all). Set KINECT3D_WERROR=ON to fail on any warning.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DKINECT3D_WERROR="${KINECT3D_WERROR:-OFF}"
targets=()
for target in "$@"; do targets+=(--target "$target"); done
cmake --build build -j"$(nproc)" "${targets[@]}"
