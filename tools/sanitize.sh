#!/usr/bin/env bash
# Builds the project with AddressSanitizer + UndefinedBehaviorSanitizer in build-sanitize/ and runs
# the test suite under them (the install and style checks excepted: they test packaging, not code).
# Any finding fails the run; OpenNI2's own process-wide allocations are suppressed
# (tests/sanitizers/lsan.supp says why). Not yet part of CI: on a 2-core VM the build alone takes
# about 15 minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install_deps.sh
flags="-fsanitize=address,undefined -fno-omit-frame-pointer"
cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="$flags" -DCMAKE_SHARED_LINKER_FLAGS="$flags" -DCMAKE_MODULE_LINKER_FLAGS="$flags"
cmake --build build-sanitize -j"$(nproc)"
cd build-sanitize
export ASAN_OPTIONS=detect_leaks=1
export LSAN_OPTIONS="suppressions=$PWD/../tests/sanitizers/lsan.supp"
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --output-on-failure -j2 -E "^(Install|Style)\."
