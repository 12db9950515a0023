#!/usr/bin/env bash
# The match-length soak (docs/match-log.md): the host runs ten minutes of a busy simulated field
# (bench/scenes/match_soak.yaml, 18,000 frames, in real time) with the logger on, and this script
# reports the host's resident memory over the run, the frames each plugin processed, what the
# logger could not keep up with, the depth frames in the log, and the log's size per minute.
# Usage: tools/soak.sh [SECONDS]   (default 600; shorter runs for a quick look)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
tools/build.sh vision_host kinect3d_plugin omni localisation fusion_plugin logger kinect3d_cli > /dev/null
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
scene="sim:$(pwd)/bench/scenes/match_soak.yaml"
build/bin/vision_host --robot config/robots/demo.yaml \
  --set "host.plugins=[localisation, kinect3d, omni, fusion, logger]" "host.duration_s=$seconds" \
        "kinect3d.source=$scene" "omni.source=$scene" "localisation.source=$scene" "logger.folder=$work" \
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
log=$(ls -d "$work"/*/)
db="$log/match.sqlite"
echo "Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
echo "Resident memory (MB) every 10 s:"
paste -sd' ' <(tail -n +2 "$work/rss.csv" | cut -d, -f2)
mid=$(( ($(wc -l < "$work/rss.csv") + 1) / 2 ))
echo "start (10 s): $(sed -n 2p "$work/rss.csv" | cut -d, -f2) MB, middle: $(sed -n "${mid}p" "$work/rss.csv" | cut -d, -f2) MB, end: $(tail -1 "$work/rss.csv" | cut -d, -f2) MB"
cat "$work/host.out"
grep -c "fell behind" "$work/host.err" | xargs echo "logger 'fell behind' warnings:" || true
build/bin/kinect3d info "log:$log" | grep "^frames:" | xargs echo "depth frames in the log:"
bytes=$(du -sb "$log" | cut -f1)
echo "log: $((bytes / 1024 / 1024)) MB for $seconds s = $((bytes * 60 / seconds / 1024 / 1024)) MB per minute"
# Each plugin's own time from the log's health rows (once a second: steps and their median time), as
# a share of one core: the median step time times the steps, summed over the run.
echo "CPU per plugin (share of one core; median step time):"
sqlite3 -separator ' ' "$db" "SELECT printf('  %-13s %5.1f %%  %6.2f ms a step, %4.1f steps a second', plugin,
  100.0 * sum(processing_p50_s * frames) / count(*), 1000.0 * avg(processing_p50_s), avg(rate_hz))
  FROM health WHERE frames > 0 GROUP BY plugin ORDER BY plugin"
