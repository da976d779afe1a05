#!/usr/bin/env bash
# The RViz demo in a real X display: starts Xvfb (software GL), a roscore of its own and
# `demo.launch rviz:=true`, waits for the replay to end and checks a screenshot with
# scripts/rviz_demo_check.py (the spool marker, its pose axes, the TF frames in the 3D view, no
# display in error), the logs and that RViz is still up. Uses the existing build (scripts/test.sh
# builds first); stops everything it started, even on failure or a signal.
# The screenshot is kept as build/rviz_demo/rviz_demo.png; the JUnit result goes to
# $SPOOL_TEST_RESULTS/rviz_demo.xml (scripts/test.sh's `counted`) or beside the screenshot.
#   scripts/rviz_demo_check.sh         exit 0 = every check passed
set -euo pipefail
source "$(dirname "$0")/env.sh"
cd "$SPOOL_ROOT"
set +u  # the catkin setup scripts read unset variables
source "$SPOOL_WS/devel/setup.bash"
set -u

out="$SPOOL_ROOT/build/rviz_demo"
results="${SPOOL_TEST_RESULTS:-$out}"
junit="$results/rviz_demo.xml"
# One run at a time per clone: they share the screenshot folder and the launch log. (roscore
# inherits the lock's descriptor; one left running would hold it, hence the time limit.)
mkdir -p "$SPOOL_ROOT/build"
exec 9>"$SPOOL_ROOT/build/rviz_demo.lock"
flock -w 120 9 || { echo "rviz_demo_check: another run holds build/rviz_demo.lock" >&2; exit 1; }
rm -rf "$out" "$junit"
mkdir -p "$out" "$results"

passed=0
interrupted=0
launch_pid=""
on_exit() {
  if [ -n "$launch_pid" ]; then kill -KILL -- "-$launch_pid" 2>/dev/null || true; fi
  # A run that was interrupted or stopped before the checker wrote its result counts as one
  # failed test.
  if [ "$interrupted" -eq 1 ] || { [ "$passed" -ne 1 ] && [ ! -s "$junit" ]; }; then
    printf '<testsuite name="rviz_demo"><testcase classname="rviz_demo" name="run"><failure message="%s, see %s"/></testcase></testsuite>\n' \
      "$([ "$interrupted" -eq 1 ] && echo interrupted || echo "stopped early")" "$ROS_LOG_DIR/rviz_demo.log" >"$junit"
  fi
}
source "$SPOOL_ROOT/scripts/own_master.sh" rviz_demo
# A signal ends the script through exit, so the EXIT trap (own_master.sh's cleanup) still runs.
trap 'interrupted=1; exit 1' INT TERM HUP

# -displayfd: Xvfb takes the first free display number itself and writes it once it is ready.
Xvfb -displayfd 3 -screen 0 1280x1024x24 -nolisten tcp 3>"$out/display" >"$out/xvfb.log" 2>&1 9>&- &
pids+=($!)
for _ in $(seq 100); do [ -s "$out/display" ] && break; sleep 0.1; done
[ -s "$out/display" ] || { echo "rviz_demo_check: Xvfb did not start (see $out/xvfb.log)" >&2; exit 1; }
DISPLAY=":$(cat "$out/display")"
export DISPLAY
# No GPU here, and RViz's Ogre needs GLX: Mesa's software rasteriser.
export LIBGL_ALWAYS_SOFTWARE=1

# By path: `roslaunch spool_vision ...` is ambiguous while a workspace links back to the clone.
# In a session of its own, so that on_exit can end any node roslaunch left behind by its group.
setsid roslaunch "$SPOOL_ROOT/launch/demo.launch" rviz:=true >>"$log" 2>&1 9>&- &
launch_pid=$!
pids+=("$launch_pid")
# In the background: bash runs a trap only once the foreground command is done, `wait` at once.
/usr/bin/python3 "$SPOOL_ROOT/scripts/rviz_demo_check.py" --display "$DISPLAY" --launch-log "$log" \
  --log-dir "$ROS_LOG_DIR" --out "$out/rviz_demo.png" --junit "$junit" 9>&- &
pids+=($!)
status=0
wait "${pids[-1]}" || status=$?
echo "rviz_demo_check: screenshot $out/rviz_demo.png, launch log $log"
[ "$status" -eq 0 ] || { echo "rviz_demo_check: FAILED" >&2; exit 1; }
passed=1
echo "rviz_demo_check: PASS"
