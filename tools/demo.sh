#!/usr/bin/env bash
# Command 1 of the README: install, build what the demo runs, and run the vision host on the demo
# robot. Extra arguments go to vision_host, e.g. tools/demo.sh --set host.duration_s=5
set -euo pipefail
cd "$(dirname "$0")/.."
tools/build.sh vision_host kinect3d_plugin omni localisation fusion_plugin console logger kinect3d_cli
exec build/bin/vision_host --robot config/robots/demo.yaml "$@"
