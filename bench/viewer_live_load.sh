#!/usr/bin/env bash
# What a page open on `kinect3d view --live` costs the robot (docs/viewer.md): the same busy field
# (bench/scenes/match_soak.yaml, its depth rendered in real time) run twice in the viewer's live
# mode for SECONDS each, once with no page and once with a client polling as the page does in live
# mode (the run, the newest frame and its depth image every 2 s), and the depth plugin's frame
# rate from each run's log (its health, once a second; the first 5 s left out).
# Usage: bench/viewer_live_load.sh [SECONDS]   (default 60)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
tools/build.sh vision_host kinect3d_plugin omni localisation fusion_plugin logger kinect3d_cli > /dev/null
work=$(mktemp -d)
trap 'kill $(jobs -p) 2> /dev/null || true; rm -rf "$work"' EXIT
scene="sim:$(pwd)/bench/scenes/match_soak.yaml"
echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); $seconds s per run"
for mode in none page; do
  build/bin/kinect3d view --live config/robots/demo.yaml --port 0 \
    --set "host.plugins=[localisation, kinect3d, omni, fusion, logger]" "kinect3d.source=$scene" \
          "omni.source=$scene" "localisation.source=$scene" "logger.folder=$work/$mode" \
    > "$work/$mode.out" 2> "$work/$mode.err" &
  view=$!
  until url=$(grep -o 'http://[^ ]*/' "$work/$mode.out"); do sleep 0.2; done
  end=$((SECONDS + seconds))
  requests=0
  poll_s=0
  while [ $SECONDS -lt $end ]; do
    sleep 2
    if [ $mode = page ]; then
      poll_s=$(curl -s -o "$work/run.json" -w '%{time_total}' "${url}api/run")
      frames=$(grep -o '"frames_t_s":\[[^]]*\]' "$work/run.json" | tr -cd ',' | wc -c)
      curl -s -o /dev/null "${url}api/frame/$frames"
      curl -s -o /dev/null "${url}api/depth/$frames.png"
      requests=$((requests + 3))
    fi
  done
  kill -TERM $view
  wait $view || true
  log=$(ls -d "$work/$mode"/*/)
  rate=$(sqlite3 "$log/match.sqlite" "select round(avg(rate_hz), 1) || ' Hz (p50 ' || round(1000 * avg(processing_p50_s), 2)
    || ' ms)' from health where plugin = 'kinect3d' and wall_time_s > (select min(wall_time_s) + 5 from health)")
  echo "$mode: depth plugin at $rate over $seconds s; page requests: $requests; the last /api/run took $poll_s s"
done
