#!/usr/bin/env bash
# The ROS demo: installs and builds, starts its own roscore, replays the demo approach bag
# (110 -> 51 cm deep, ending aligned) through the spool_detector node, prints the SpoolPose stream
# as `rostopic echo` does and a one-line summary, then stops everything it started.
#   scripts/demo.sh [BAG]   default: the bundled test/data/demo_approach.bag, or one rendered
#                           into the build workspace when that is missing
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

# A master of our own on a free port, so that a running ROS system is neither used nor disturbed.
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI="http://127.0.0.1:$port"
export ROS_IP=127.0.0.1
log="$ROS_LOG_DIR/demo.log"
pids=()
cleanup() {
  # Newest first: the launch (detector and player) before the master.
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
    kill -INT "${pids[i]}" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "${pids[i]}" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "${pids[i]}" 2>/dev/null || true
  done
}
trap cleanup EXIT

roscore -p "$port" >"$log" 2>&1 &
pids+=($!)
master_online() { /usr/bin/python3 -c 'import rosgraph, sys; sys.exit(0 if rosgraph.is_master_online() else 1)'; }
for _ in $(seq 100); do master_online && break; sleep 0.2; done
master_online || { echo "demo: roscore did not start (see $log)" >&2; exit 1; }

# By path: `roslaunch spool_vision ...` is ambiguous while a workspace inside the repository
# links back to it (build/ws/src/spool_vision).
roslaunch "$SPOOL_ROOT/launch/replay.launch" bag:="$bag" paused:=true >>"$log" 2>&1 &
pids+=($!)
/usr/bin/python3 "$SPOOL_ROOT/scripts/echo_poses.py" --bag "$bag" --resume /player/pause_playback
