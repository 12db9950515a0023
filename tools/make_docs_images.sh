#!/usr/bin/env bash
# Regenerates docs/images/: a real Kinect frame next to simulated ones, on one colour map, and the
# match report of the demo robot's run, a calibration page, and the demo's lob in the viewer.
# Needs a build (tools/build.sh), and the folder of the third-party real frames (never in the
# repository) as its argument: tools/make_docs_images.sh <real frames>, which holds
# real-depth/tum_depth.png.
set -euo pipefail
[ $# -eq 1 ] || { echo "usage: tools/make_docs_images.sh <folder of the real frames, holding real-depth/tum_depth.png>" >&2; exit 2; }
real_frame=$(cd "$1" && pwd)/real-depth/tum_depth.png
cd "$(dirname "$0")/.."
[ -f "$real_frame" ] || { echo "make_docs_images: $real_frame is not there" >&2; exit 2; }
real_dir=$(mktemp -d)
trap 'rm -rf "$real_dir"' EXIT
echo "0 $(cd "$(dirname "$real_frame")" && pwd)/tum_depth.png" > "$real_dir/depth.txt"
mkdir -p docs/images
build/bin/kinect3d snapshot "tum:$real_dir" sim:kick_away --frame 0 --frame 16 --out docs/images/sim_vs_real.png
build/bin/kinect3d snapshot sim:clutter sim:shot_goalkeeper --frame 20 --out docs/images/sim_scenes.png
build/bin/kinect3d snapshot sim:people_over_a_head_3 sim:people_from_the_border_1 --frame 20 --out docs/images/people.png
# The match report of the demo's run (docs/match-log.md), as Chromium draws it.
run_dir=$(mktemp -d)
trap 'rm -rf "$real_dir" "$run_dir"' EXIT
build/bin/vision_host --robot config/robots/demo.yaml --set "logger.folder=$run_dir/logs" > /dev/null 2>&1
build/bin/kinect3d report match "$(ls -d "$run_dir"/logs/*/)" --out "$run_dir/report"
chromium --headless --no-sandbox --disable-gpu --window-size=1200,1560 --virtual-time-budget=5000 \
  --screenshot="$(pwd)/docs/images/match_report.png" "file://$run_dir/report/index.html" 2> /dev/null
# The calibration page of a simulated session with one mark written 0.5 m off (docs/calibration.md).
build/bin/kinect3d report calibration --out "$run_dir/calibration-report.md" --keep "$run_dir/sessions" > /dev/null 2>&1
build/bin/kinect3d calibrate --source "tum:$run_dir/sessions/rolled" \
  --marks "$run_dir/sessions/rolled/marks_6one mark 0.5 m off.yaml" --plot "$run_dir/calibration" > /dev/null 2>&1
chromium --headless --no-sandbox --disable-gpu --window-size=1200,640 --virtual-time-budget=5000 \
  --screenshot="$(pwd)/docs/images/calibration.png" "file://$run_dir/calibration/index.html" 2> /dev/null
# The demo's lob in the viewer (docs/viewer.md), rising towards the robot.
build/bin/kinect3d view "$(ls -d "$run_dir"/logs/*/)" --port 0 --bind 127.0.0.1 > "$run_dir/view.out" 2> /dev/null &
viewer=$!
trap 'kill $viewer 2> /dev/null; rm -rf "$real_dir" "$run_dir"' EXIT
for _ in $(seq 100); do
  grep -q "http://" "$run_dir/view.out" && break
  sleep 0.1
done
url=$(grep -o "http://[0-9.:]*/" "$run_dir/view.out")
chromium --headless --no-sandbox --disable-gpu --use-gl=swiftshader --enable-unsafe-swiftshader \
  --window-size=1280,1100 --virtual-time-budget=10000 --screenshot="$(pwd)/docs/images/viewer.png" "${url}?t=0.75" \
  2> /dev/null
