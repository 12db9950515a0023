#!/usr/bin/env bash
# Installs missing Debian packages, then configures and builds Kinect3D in build/ (Release).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"
