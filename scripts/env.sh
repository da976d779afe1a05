# Sourced by the scripts: Debian's python3 first (the pyenv shim lacks the ROS modules) and
# writable ROS folders inside the git-ignored build tree.
SPOOL_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SPOOL_WS="${SPOOL_WS:-$SPOOL_ROOT/build/ws}"
export PATH="/usr/bin:/bin:$PATH"
export ROS_HOME="${ROS_HOME:-$SPOOL_ROOT/build/ros_home}"
export ROS_LOG_DIR="${ROS_LOG_DIR:-$ROS_HOME/log}"
mkdir -p "$ROS_LOG_DIR"
