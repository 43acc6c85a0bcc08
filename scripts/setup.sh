#!/usr/bin/env bash
# Idempotent set-up: installs the Debian packages ekf_vislam needs (when missing) and builds the
# catkin workspace in a git-ignored folder of the repository (default <repo>/build, override with
# EKF_VISLAM_WS). Finishes in seconds when everything is installed and built.
#   scripts/setup.sh            install + build
#   scripts/setup.sh --tests    also build the test executables
set -eo pipefail
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:${PATH}
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
WS=${EKF_VISLAM_WS:-${REPO}/build}
BUILD_TESTS=0
[[ "${1:-}" == "--tests" ]] && BUILD_TESTS=1

PACKAGES=(
  g++ make cmake pkg-config libeigen3-dev libyaml-cpp-dev libgtest-dev
  libnodeletlib-dev libnodeletlib-tools libtf2-ros-dev libtf2-eigen-dev
  libnav-msgs-dev libvisualization-msgs-dev libsensor-msgs-dev libgeometry-msgs-dev
  libdiagnostic-updater-dev libdiagnostic-msgs-dev libstd-srvs-dev librosbag-dev librostest-dev
  ros-std-msgs ros-std-srvs ros-geometry-msgs ros-sensor-msgs ros-nav-msgs
  ros-visualization-msgs ros-diagnostic-msgs
  python3-rostest python3-rosbag python3-rospy rosbash python3-rostopic python3-rosnode
  python3-rosservice python3-rosmsg
  python3-std-msgs python3-geometry-msgs python3-sensor-msgs python3-nav-msgs
  python3-visualization-msgs python3-tf2-msgs python3-diagnostic-msgs python3-std-srvs
  python3-numpy python3-matplotlib python3-scipy python3-yaml
  libopencv-dev python3-opencv libcv-bridge-dev python3-cv-bridge libimage-transport-dev
  libmessage-filters-dev python3-message-filters
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "[setup] installing ${#missing[@]} Debian packages: ${missing[*]}"
  SUDO=""
  [[ $(id -u) -ne 0 ]] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" \
    >/tmp/ekf_vislam_apt.log 2>&1 || { tail -30 /tmp/ekf_vislam_apt.log; exit 1; }
fi

# The package in the workspace is a folder of links to the repository's entries, all but the
# workspace itself: a link to the whole repository would contain the workspace again, and rosrun's
# search would report a file system loop.
PKG="${WS}/src/ekf_vislam"
mkdir -p "${WS}/src"
[[ -L "${PKG}" ]] && rm -f "${PKG}"
mkdir -p "${PKG}"
for entry in "${REPO}"/* "${REPO}"/.clang-format; do
  [[ -e "${entry}" ]] || continue
  # Never link a workspace (the default one, build/, or the one being built).
  [[ "$(basename "${entry}")" == build ]] && continue
  [[ "$(cd "${entry}" 2>/dev/null && pwd)" == "${WS}" ]] && continue
  ln -sfn "${entry}" "${PKG}/$(basename "${entry}")"
done
for link in "${PKG}"/* "${PKG}"/.clang-format; do
  if [[ -L "${link}" && ( ! -e "${link}" || "$(basename "${link}")" == build ) ]]; then rm -f "${link}"; fi
done
# catkin snapshots PYTHONPATH at the first configure: the devel python folder must exist by then.
mkdir -p "${WS}/devel/lib/python3/dist-packages"

cd "${WS}"
JOBS=${EKF_VISLAM_JOBS:-2}
catkin_make -DCMAKE_BUILD_TYPE=Release -j"${JOBS}" >"${WS}/build.log" 2>&1 || {
  grep -E "error|Error" -A3 "${WS}/build.log" | head -60; echo "[setup] build failed, see ${WS}/build.log"; exit 1; }
if ((BUILD_TESTS)); then
  catkin_make -j"${JOBS}" tests >>"${WS}/build.log" 2>&1 || {
    grep -E "error|Error" -A3 "${WS}/build.log" | head -60; echo "[setup] test build failed, see ${WS}/build.log"; exit 1; }
fi
warnings=$(grep -c "warning:" "${WS}/build.log" || true)
echo "[setup] workspace ready: ${WS} (compiler warnings in this build: ${warnings})"
