#!/usr/bin/env bash
# The ROS demo: installs and builds, starts its own roscore, replays the demo approach bag
# (110 -> 51 cm deep, ending aligned) through the spool_detector node, prints the SpoolPose stream
# as `rostopic echo` does and the paths of two pictures, then runs one closed-loop trial through
# ROS (launch/sim.launch: the robot's webcam simulated, the detector tracking, the example
# controller pushing the puller in) and prints its outcome, ends with a one-line summary of both
# (the last line) and stops everything it started. The pictures: approach_sheet.png, every frame's overlay labelled
# with its index, depth and state (aligned frames framed green), and approach_plot.png, depth,
# bearing, spool axis angle and aligned against time.
#   scripts/demo.sh [BAG]   default: the bundled test/data/demo_approach.bag, or one rendered
#                           into the build workspace when that is missing
#   SPOOL_DEMO_DIR          folder of the pictures (default: $SPOOL_WS/demo)
#   SPOOL_DEMO_SEED         the closed-loop trial's seed (default 1)
set -euo pipefail
source "$(dirname "$0")/env.sh"
cd "$SPOOL_ROOT"

"$SPOOL_ROOT/scripts/install_deps.sh" >&2
"$SPOOL_ROOT/scripts/build.sh" >&2
set +u  # the catkin setup scripts read unset variables
source "$SPOOL_WS/devel/setup.bash"
set -u

bag="${1:-$SPOOL_ROOT/test/data/demo_approach.bag}"
if [ $# -eq 0 ] && [ ! -f "$bag" ]; then
  bag="$SPOOL_WS/demo_approach.bag"
  frames="$SPOOL_WS/demo_frames"
  rm -rf "$frames"
  "$SPOOL_WS/devel/lib/spool_vision/spool_render" --out "$frames" --width 640 --height 480 \
    --set approach --count 20 >&2
  /usr/bin/python3 "$SPOOL_ROOT/scripts/frames_to_bag.py" "$frames" "$bag" \
    --encoding mono8 --compression bz2 >&2
fi

source "$SPOOL_ROOT/scripts/own_master.sh" demo

# By path: `roslaunch spool_vision ...` is ambiguous while a workspace inside the repository
# links back to it (build/ws/src/spool_vision).
roslaunch "$SPOOL_ROOT/launch/replay.launch" bag:="$bag" paused:=true >>"$log" 2>&1 &
replay=$!
pids+=($replay)
# The stream as it comes; its summary line is held back for the last line.
stream="$(mktemp)"
/usr/bin/python3 "$SPOOL_ROOT/scripts/echo_poses.py" --bag "$bag" --resume /player/pause_playback \
  --pictures "${SPOOL_DEMO_DIR:-$SPOOL_WS/demo}" | tee "$stream" | head -n -1
summary="$(tail -n 1 "$stream")"
rm -f "$stream"
kill -INT "$replay" && wait "$replay" || true

# Then what the poses are for: one closed-loop trial through ROS (sim.launch: a simulated
# forklift's webcam, the detector tracking, the example controller pushing the puller in).
echo "closed loop (roslaunch spool_vision sim.launch seed:=${SPOOL_DEMO_SEED:-1}):"
trial="$(roslaunch "$SPOOL_ROOT/launch/sim.launch" seed:="${SPOOL_DEMO_SEED:-1}" 2>>"$log" |
  tee -a "$log" | grep -a "^trial seed" || true)"
echo "${trial:-trial: no outcome (see $log)}"
echo "$summary; closed loop: ${trial#trial }"
