#!/usr/bin/env bash
# Sets up, builds the tests and runs every test (gtest, rostest, Python) through ctest, whose exit
# status is honest. Ends with ctest's summary line. Extra arguments go to ctest (e.g. -R estimator).
set -eo pipefail
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"${REPO}/scripts/setup.sh" --tests
source "${REPO}/scripts/env.sh"
WS=${EKF_VISLAM_WS:-${REPO}/build}
export ROS_HOME=$(mktemp -d /tmp/ekf_vislam_ros_home.XXXXXX)
cd "${WS}/build"
ctest -j"${EKF_VISLAM_JOBS:-2}" --output-on-failure "$@"
