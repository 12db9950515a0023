#!/usr/bin/env bash
# The match-length run of the whole robot stack (README "Measured speed", docs/match-log.md): the host
# runs ten minutes of a busy simulated field (bench/scenes/match_soak.yaml, 18,000 frames at 30 Hz,
# in real time) through every plugin a field player runs: depth with colour, detector and
# trajectory, omni, localisation, fusion, team (sending to a teammate address on loopback) and the
# logger with depth and colour. The field is rendered first, as fast as the simulator can, into a
# match log; the measured run plays that log's depth, colour, omni images and poses at their own
# pace, so that it measures what a robot runs (it reads sensors; it does not render a world) and
# gets every frame at 30 Hz however slow the renderer. This script reports the host's resident
# memory over the run, the frames each plugin processed and dropped, what the logger could not keep
# up with, the depth frames in the log and its size per minute, each plugin's share of one core,
# and the latency from a depth frame's arrival to its world ball, per second and over the run.
# Usage: tools/soak.sh [SECONDS]   (default 600; shorter runs for a quick look)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
tools/build.sh vision_host kinect3d_plugin omni localisation fusion_plugin team logger kinect3d_cli kinect3d_bench > /dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
sed "s/^duration_s: .*/duration_s: $seconds/" bench/scenes/match_soak.yaml > "$work/scene.yaml"
echo "Rendering $seconds s of the field into a match log (not timed) ..."
build/bin/vision_host --robot config/robots/demo.yaml \
  --set "host.plugins=[localisation, kinect3d, omni, logger]" "logger.folder=$work/recording" kinect3d.colour=true \
        "kinect3d.source=sim:$work/scene.yaml" "omni.source=sim:$work/scene.yaml" \
        "localisation.source=sim:$work/scene.yaml" kinect3d.realtime=false omni.realtime=false localisation.realtime=false \
  > "$work/recording.out" 2>&1
recording="log:$(ls -d "$work"/recording/*/)"
build/bin/kinect3d team-key --out "$work/team.key" > /dev/null
build/bin/vision_host --robot config/robots/demo.yaml \
  --set "host.plugins=[localisation, kinect3d, omni, fusion, team, logger]" "logger.folder=$work/run" \
        "kinect3d.source=$recording" "omni.source=$recording" "localisation.source=$recording" kinect3d.colour=true \
        team.team_id=1 team.robot_id=1 "team.key_file=$work/team.key" \
        team.bind_address=127.0.0.1 "team.peers=[127.0.0.1:50421]" \
  > "$work/host.out" 2> "$work/host.err" &
host=$!
echo "second,rss_mb" > "$work/rss.csv"
for ((t = 10; t <= seconds; t += 10)); do
  sleep 10
  kill -0 "$host" 2> /dev/null || break
  rss_kb=$(awk '/VmRSS/ {print $2}' "/proc/$host/status")
  echo "$t,$((rss_kb / 1024))" >> "$work/rss.csv"
done
wait "$host"
log=$(ls -d "$work"/run/*/)
db="$log/match.sqlite"
echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
echo "Resident memory (MB) every 10 s:"
paste -sd' ' <(tail -n +2 "$work/rss.csv" | cut -d, -f2)
mid=$(( ($(wc -l < "$work/rss.csv") + 1) / 2 ))
echo "start (10 s): $(sed -n 2p "$work/rss.csv" | cut -d, -f2) MB, middle: $(sed -n "${mid}p" "$work/rss.csv" | cut -d, -f2) MB, end: $(tail -1 "$work/rss.csv" | cut -d, -f2) MB"
echo "The host's summary (the fusion's latency: each depth frame's, from its arrival to its world ball, over the run):"
cat "$work/host.out"
grep -c "fell behind" "$work/host.err" | xargs echo "logger 'fell behind' warnings:" || true
build/bin/kinect3d info "log:$log" | grep "^frames:" | xargs echo "depth frames in the log:"
bytes=$(du -sb "$log" | cut -f1)
echo "log: $((bytes / 1024 / 1024)) MB for $seconds s = $((bytes * 60 / seconds / 1024 / 1024)) MB per minute"
# From the log's health rows (once a second per plugin): each plugin's own time summed, as a share
# of one core; the frames it dropped (gaps in its source's counter); and the fusion's latency from a
# depth frame's arrival on the host to its world ball.
echo "CPU per plugin (share of one core over the run; median step time; dropped frames):"
sqlite3 -separator ' ' "$db" "SELECT printf('  %-13s %5.1f %%  %6.2f ms a step, %5.1f steps a second, %d dropped', plugin,
  100.0 * sum(processing_total_s) / count(*), 1000.0 * avg(processing_p50_s), avg(rate_hz), max(dropped_frames))
  FROM health GROUP BY plugin ORDER BY plugin"
sqlite3 "$db" "SELECT printf('  the stack    %5.1f %% of one core', 100.0 * sum(processing_total_s) /
  (SELECT count(*) FROM health WHERE plugin = 'fusion')) FROM health"
# Each second's p50 and p99; over the run: their medians, and the worst second's p99.
sqlite3 "$db" "WITH s AS (SELECT latency_p50_s AS p50, latency_p99_s AS p99 FROM health
    WHERE plugin = 'fusion' AND latency_p50_s IS NOT NULL),
  m50 AS (SELECT p50 FROM s ORDER BY p50 LIMIT 1 OFFSET (SELECT count(*) / 2 FROM s)),
  m99 AS (SELECT p99 FROM s ORDER BY p99 LIMIT 1 OFFSET (SELECT count(*) / 2 FROM s))
  SELECT printf('latency, depth frame arrival to world ball: p50 %.2f ms, p99 %.2f ms (medians over %d seconds; worst second p99 %.2f ms)',
    1000.0 * (SELECT p50 FROM m50), 1000.0 * (SELECT p99 FROM m99), (SELECT count(*) FROM s), 1000.0 * max(p99)) FROM s"
# The machine's speed that day, to compare with docs/benchmark.md: shared VMs vary by a factor of two.
echo "This machine now: $(build/bin/kinect3d_bench --scene kick_away --iterations 300 --baseline-frames 5 | grep '^kinect3d at 0.27 m')"
