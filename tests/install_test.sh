#!/usr/bin/env bash
# Installs the build into a fresh prefix and runs what a team runs on a robot laptop from there:
# the host on the demo robot (plugins and defaults found relative to the installed vision_host),
# and the kinect3d tool. Usage: install_test.sh <build dir>
set -euo pipefail
build_dir=$1
prefix=$(mktemp -d)
work=$(mktemp -d)
trap 'rm -rf "$prefix" "$work"' EXIT
cmake --install "$build_dir" --prefix "$prefix" > /dev/null

# Outputs are captured before they are searched, and searched as here-strings: grep -q ends at its
# first match, and with pipefail an echo piped into it then fails on the closed pipe.
# Run from an unrelated folder, so nothing is found through the working directory (the demo's
# match log goes there, into logs/).
cd "$work"
output=$("$prefix/bin/vision_host" --robot "$prefix/share/kinect3d/config/robots/demo.yaml" \
         --set host.duration_s=20 2>&1)
grep -q "loaded plugin kinect3d .* from $prefix/lib/kinect3d/plugins/kinect3d.so" <<< "$output" \
  || { echo "the installed host did not load its own plugin:"; echo "$output"; exit 1; }
grep -q "ball kinect3d: air" <<< "$output" || { echo "no ball in the air reached the console:"; echo "$output"; exit 1; }
grep -q "world: air, .* from kinect3d+omni" <<< "$output" \
  || { echo "no fused ball in the air reached the console:"; echo "$output"; exit 1; }
ls "$work"/logs/*_demo/match.sqlite > /dev/null || { echo "the demo left no match log in logs/:"; echo "$output"; exit 1; }

# A robot file outside the installed tree takes the installed defaults. Its scene's 90 frames end
# the run; the duration is only a deadline, generous enough for a busy machine (CI rendered 17 a second).
robot=$(mktemp -d)/robot.yaml
printf 'host: {robot_name: elsewhere, plugins: [kinect3d], duration_s: 120}\nkinect3d: {source: "sim:hung_3m", realtime: false}\n' > "$robot"
output=$("$prefix/bin/vision_host" --robot "$robot" 2>&1)
grep -q "every source ended" <<< "$output" \
  || { echo "a robot file outside the tree did not run on the installed defaults:"; echo "$output"; exit 1; }
rm -rf "$(dirname "$robot")"

output=$("$prefix/bin/kinect3d" info sim:hung_3m)
grep -q "frames:            90" <<< "$output" || { echo "kinect3d info failed:"; echo "$output"; exit 1; }
# The simulated OpenNI2 device loads from the installed private OpenNI2.
output=$("$prefix/bin/kinect3d" info "openni2:kinect3d-sim://hung_3m?frames=5" 2>&1)
grep -q "frames:            5" <<< "$output" \
  || { echo "the installed OpenNI2 did not find its drivers:"; echo "$output"; exit 1; }
libraries=$(ldd "$prefix/bin/vision_host" "$prefix/lib/libkinect3d.so" "$prefix/lib/kinect3d/plugins/kinect3d.so")
if grep -q "$(cd "$build_dir" && pwd)" <<< "$libraries"; then
  echo "an installed binary still loads from the build tree:"; echo "$libraries"; exit 1
fi
echo "install test passed: $prefix"
