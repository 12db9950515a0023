#!/usr/bin/env bash
# Regenerates docs/images/: a real Kinect frame next to simulated ones, on one colour map.
# Needs a build (tools/build.sh) (the real frame comes from tests/data/real-depth).
set -euo pipefail
cd "$(dirname "$0")/.."
real_dir=$(mktemp -d)
trap 'rm -rf "$real_dir"' EXIT
echo "0 $(cd tests/data/real-depth && pwd)/tum_depth.png" > "$real_dir/depth.txt"
mkdir -p docs/images
build/bin/kinect3d snapshot "tum:$real_dir" sim:kick_away --frame 0 --frame 16 --out docs/images/sim_vs_real.png
build/bin/kinect3d snapshot sim:clutter sim:shot_goalkeeper --frame 20 --out docs/images/sim_scenes.png
