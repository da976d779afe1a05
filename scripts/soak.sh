#!/usr/bin/env bash
# Soak test of the node: MINUTES (default 10) of 30 Hz 640x480 bgr8 frames with camera_info
# through spool_detector.launch on a roscore of its own. Prints dropped frames (SpoolPose stamps
# against the published ones), latency p50/p99/max (image stamp to SpoolPose received) and the
# node's RSS over time, then PASS or FAIL against the bars: 0 dropped frames, RSS growth < 1 MB
# after the first minute (a third of a shorter run). Exit 0 = PASS. Builds first.
#   scripts/soak.sh [MINUTES]          e.g. scripts/soak.sh 0.33 for a 20-second smoke run
set -euo pipefail
source "$(dirname "$0")/env.sh"
cd "$SPOOL_ROOT"
minutes="${1:-10}"
seconds=$(/usr/bin/python3 -c "import sys; m = float(sys.argv[1]); assert m > 0; print(m * 60)" "$minutes") ||
  { echo "usage: soak.sh [MINUTES]  (a positive number)" >&2; exit 2; }

"$SPOOL_ROOT/scripts/build.sh" spool_detector spool_vision_generate_messages_py >&2
set +u  # the catkin setup scripts read unset variables
source "$SPOOL_WS/devel/setup.bash"
set -u

work=$(mktemp -d)
on_exit() { rm -rf "$work"; }
source "$SPOOL_ROOT/scripts/own_master.sh" soak

roslaunch "$SPOOL_ROOT/launch/spool_detector.launch" >>"$log" 2>&1 &
pids+=($!)
for _ in $(seq 150); do rosnode list 2>/dev/null | grep -qx /spool_detector && break; sleep 0.2; done
rosnode list 2>/dev/null | grep -qx /spool_detector || { echo "soak: the node did not start (see $log)" >&2; exit 1; }

echo "soak: $seconds s of 30 Hz 640x480 frames (log: $log)" >&2
/usr/bin/python3 "$SPOOL_ROOT/scripts/soak_stream.py" monitor /spool_detector "$work/stamps" &
monitor=$!
/usr/bin/python3 "$SPOOL_ROOT/scripts/soak_stream.py" publish "$seconds" "$work/stamps" >>"$log" 2>&1
wait "$monitor"
