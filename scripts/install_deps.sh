#!/usr/bin/env bash
# Installs the Debian packages the package needs (Debian 12 ships ROS 1 as ordinary
# packages). Idempotent: does nothing when everything is present. Needs root or sudo.
set -euo pipefail
PACKAGES=(
  ros-base-dev catkin libpcl-dev libpcl-conversions-dev libceres-dev libeigen3-dev
  librosbag-dev libtf2-ros-dev libtf2-eigen-dev libtf2-sensor-msgs-dev
  libvisualization-msgs-dev libstd-srvs-dev liblaser-geometry-dev libdiagnostic-updater-dev
  libnodelet-dev libnodeletlib-dev libnodeletlib-tools pluginlib-dev
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  liblemon-dev liboctomap-dev libgtest-dev libbenchmark-dev libyaml-cpp-dev nlohmann-json3-dev
  python3-rostest python3-roslaunch python3-rosbag python3-rosmaster python3-nodelet python3-rostopic
  rosbash rosout librostest-dev python3-sensor-msgs python3-geometry-msgs
  python3-visualization-msgs python3-std-srvs
)
# Only for pictures: headless rviz screenshots (scripts/screenshot.sh) and the real-data
# plots (scripts/evaluate_real.sh); install with --with-rviz.
VIEW_PACKAGES=(rviz xvfb imagemagick x11-utils python3-matplotlib)
if [ "${1:-}" = "--with-rviz" ]; then PACKAGES+=("${VIEW_PACKAGES[@]}"); fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "[novelty_detection] all ${#PACKAGES[@]} system packages present" >&2
  exit 0
fi
echo "[novelty_detection] installing ${#missing[@]} missing packages: ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" != 0 ]; then
  command -v sudo >/dev/null || { echo "need root or sudo to install packages" >&2; exit 1; }
  SUDO=sudo
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "[novelty_detection] system packages installed" >&2
