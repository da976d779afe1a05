# Sourced by the scripts: Debian's python3 first (the pyenv shim lacks the ROS modules) and
# writable ROS folders inside the git-ignored build tree.
SPOOL_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# The catkin workspace lives outside the clone: a workspace inside the package tree makes rospack
# see the package twice (roslaunch "multiple files named"). One workspace per clone.
SPOOL_WS="${SPOOL_WS:-${XDG_CACHE_HOME:-$HOME/.cache}/spool_vision/ws-$(printf %s "$SPOOL_ROOT" | md5sum | cut -c1-8)}"
export PATH="/usr/bin:/bin:$PATH"
export ROS_HOME="${ROS_HOME:-$SPOOL_ROOT/build/ros_home}"
export ROS_LOG_DIR="${ROS_LOG_DIR:-$ROS_HOME/log}"
mkdir -p "$ROS_LOG_DIR"
