# Sourced by the scripts that need a ROS master of their own (demo.sh, soak.sh): starts roscore
# on a free port, so that a running ROS system is neither used nor disturbed, and on exit stops
# every process the script added to `pids`, newest first, then runs `on_exit` if it is defined.
#   source own_master.sh NAME      the log is $ROS_LOG_DIR/NAME.log (in `log`)
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI="http://127.0.0.1:$port"
export ROS_IP=127.0.0.1
log="$ROS_LOG_DIR/$1.log"
pids=()
cleanup() {
  for ((i = ${#pids[@]} - 1; i >= 0; i--)); do
    kill -INT "${pids[i]}" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "${pids[i]}" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "${pids[i]}" 2>/dev/null || true
  done
  if declare -F on_exit >/dev/null; then on_exit; fi
}
trap cleanup EXIT

roscore -p "$port" >"$log" 2>&1 &
pids+=($!)
master_online() { /usr/bin/python3 -c 'import rosgraph, sys; sys.exit(0 if rosgraph.is_master_online() else 1)'; }
for _ in $(seq 100); do master_online && break; sleep 0.2; done
master_online || { echo "$1: roscore did not start (see $log)" >&2; exit 1; }
