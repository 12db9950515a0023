#!/usr/bin/env bash
# Installs exactly the Debian 12 packages Kinect3D needs to build and run; with --tests also what
# only the tests need (Chromium, clang and clang-format, the command-line tools the benchmarks use).
# Idempotent: when everything is present it only checks and returns.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  libeigen3-dev
  libpcl-dev
  liboctomap-dev
  libopenni2-dev
  libfreenect-dev               # the Kinect v1 (freenect:), and fakenect, its replay library, for the tests
  libopencv-dev
  libyaml-cpp-dev
  libcli11-dev
  nlohmann-json3-dev
  libgtest-dev
  libsqlite3-dev                # the match log
  sqlite3                       # reading a match log by hand (docs/match-log.md), tools/soak.sh
  liblz4-dev                    # a candidate the benchmark measures against the match log's depth codec
  libjs-chart.js                # the match report's and the viewer's charts
  libjs-three                   # the viewer's 3D view (three.js and its orbit controls)
  libcpp-httplib-dev            # the viewer's web server
  libmsgpack-cxx-dev            # the team message (plugins/team, the match log)
  libzstd-dev                   # the match log's depth and the team packets' compression
  libturbojpeg0-dev             # the match log's colour (libjpeg-turbo's TurboJPEG API)
  libsodium-dev                 # the team packets' authentication with the team key
)
if [ "${1:-}" = "--tests" ]; then
  PACKAGES+=(
    clang-format                # the style test
    clang libclang-rt-14-dev    # the sanitizer build and its fuzzers (tools/sanitize.sh, tools/fuzz.sh)
    curl                        # bench/viewer_live_load.sh polls the viewer as a page does
    chromium                    # the page tests open the pages as a person would
  )
fi

missing=()
for pkg in "${PACKAGES[@]}"; do
  # "install ok installed" is the only status that means the package is usable.
  if [ "$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null)" != "install ok installed" ]; then
    missing+=("$pkg")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

echo "install_deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
$SUDO apt-get update
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends "${missing[@]}"
