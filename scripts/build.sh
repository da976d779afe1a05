#!/usr/bin/env bash
# Builds the package in a catkin workspace outside the clone (see env.sh). Extra arguments go to
# catkin_make (e.g. "tests" or "run_tests").
set -euo pipefail
source "$(dirname "$0")/env.sh"

mkdir -p "$SPOOL_WS/src"
ln -sfn "$SPOOL_ROOT" "$SPOOL_WS/src/spool_vision"
cd "$SPOOL_WS"
jobs="${SPOOL_JOBS:-$(nproc)}"
catkin_make -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DCATKIN_ENABLE_TESTING=ON "-j$jobs" "$@" >"$SPOOL_WS/build.log" 2>&1 || {
  tail -n 60 "$SPOOL_WS/build.log"
  echo "build failed: see $SPOOL_WS/build.log" >&2
  exit 1
}
echo "build: ok ($SPOOL_WS)"
