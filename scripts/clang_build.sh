#!/usr/bin/env bash
# Builds targets of the clang project in test/sanitizers (the core with AddressSanitizer and
# UndefinedBehaviorSanitizer: the libFuzzer targets and the sanitized gtests) in the git-ignored
# build/sanitizers. The catkin build stays on GCC and does not need clang.
set -euo pipefail
source "$(dirname "$0")/env.sh"

dir="$SPOOL_ROOT/build/sanitizers"
mkdir -p "$dir"
log="$dir/build.log"
{
  [ -f "$dir/CMakeCache.txt" ] || cmake -S "$SPOOL_ROOT/test/sanitizers" -B "$dir" -DCMAKE_CXX_COMPILER=clang++
  cmake --build "$dir" -j "${SPOOL_JOBS:-$(nproc)}" --target "$@"
} >"$log" 2>&1 || {
  tail -n 40 "$log"
  echo "clang build failed: see $log" >&2
  exit 1
}
echo "clang build: ok ($*)"
