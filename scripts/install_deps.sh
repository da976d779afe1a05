#!/usr/bin/env bash
# Installs the Debian packages spool_vision needs (ROS 1 from Debian, OpenCV, Eigen, CLI11,
# nlohmann-json, matplotlib for the report charts, GTest, Google Benchmark; clang with libFuzzer
# and the sanitizer runtimes, llvm-symbolizer for readable reports; tf2-tools for demo.launch's
# static transform; Xvfb, Mesa's software GL and PIL for the RViz screenshot check). Idempotent:
# packages already installed are skipped, and apt is not touched when nothing is missing.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config
  ros-base-dev catkin ros-message-generation ros-message-runtime rosbash
  libcv-bridge-dev libimage-transport-dev libsensor-msgs-dev libcamera-info-manager-dev
  libimage-geometry-dev libtf2-ros-dev libgeometry-msgs-dev libvisualization-msgs-dev
  libdiagnostic-updater-dev libdynamic-reconfigure-config-init-mutex-dev
  libnodeletlib-dev pluginlib-dev librostest-dev libstd-msgs-dev
  libactionlib-dev libactionlib-msgs-dev libnav-msgs-dev python3-actionlib python3-actionlib-msgs python3-nav-msgs
  python3-rostest python3-rosbag python3-rostopic python3-roslaunch python3-sensor-msgs
  python3-dynamic-reconfigure python3-cv-bridge python3-numpy
  python3-opencv python3-yaml python3-matplotlib python3-std-srvs python3-rosgraph-msgs python3-diagnostic-msgs ros-image-view
  # image_proc's rectify nodelet (image_proc_rectify.test): the node is in ros-image-proc, the
  # nodelets' plugin description in libimage-proc-dev
  ros-image-proc libimage-proc-dev
  python3-tf2-ros python3-geometry-msgs python3-visualization-msgs tf-tools tf2-tools rviz
  xvfb libgl1-mesa-dri python3-pil
  libnodeletlib-tools
  libopencv-dev libeigen3-dev libyaml-cpp-dev libcli11-dev nlohmann-json3-dev libgtest-dev libgmock-dev libbenchmark-dev
  clang libclang-rt-dev llvm
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

echo "install_deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
