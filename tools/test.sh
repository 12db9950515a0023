#!/usr/bin/env bash
# Command 2 of the README (and CI): install, build everything with warnings as errors and run the
# whole test suite; then the framework's and the scene map's tests under ThreadSanitizer
# (tools/sanitize.sh thread), the test suite under AddressSanitizer + UndefinedBehaviorSanitizer
# (tools/sanitize.sh address), and every fuzzer for a bounded time from that same build
# (tools/fuzz.sh). 17 to 41 minutes on 2 cores, packages installed (README gives measured runs).
# The two sanitizers' builds run beside the test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each part says when it starts, so that a slow CI run shows where its time went.
part() { echo "== tools/test.sh: $1, from $((SECONDS / 60)) min $((SECONDS % 60)) s"; }
part "packages"
tools/install_deps.sh --tests
part "build"
tools/build.sh
# The suite leaves about a third of the two cores idle (its host tests run in real time): the
# sanitizers' two builds take that, beside it at the lowest priority. The suite slows by a tenth and
# the whole run gains about 3 minutes (README, the measured runs).
part "test suite, the sanitizers' builds beside it"
sanitizer_builds_log=build/sanitizer-builds.log
setsid nice -n 19 bash -c 'tools/sanitize.sh thread --build-only && tools/sanitize.sh address --build-only' \
  > "$sanitizer_builds_log" 2>&1 &
sanitizer_builds=$!
# A failing suite stops the script: the builds beside it stop with it.
trap 'kill -- -"$sanitizer_builds" 2>/dev/null || true' EXIT
(cd build && ctest --output-on-failure -j2)
part "the sanitizers' builds, finishing"
if ! wait "$sanitizer_builds"; then
  tail -n 60 "$sanitizer_builds_log" >&2
  echo "== tools/test.sh: the sanitizers' builds failed (whole output: $sanitizer_builds_log)" >&2
  exit 1
fi
trap - EXIT
part "ThreadSanitizer"
tools/sanitize.sh thread
part "AddressSanitizer"
tools/sanitize.sh address
part "fuzzers"
tools/fuzz.sh 20
echo "== tools/test.sh: everything passed in $((SECONDS / 60)) min $((SECONDS % 60)) s"
