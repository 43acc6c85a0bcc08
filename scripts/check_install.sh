#!/usr/bin/env bash
# Installs the package (the workspace's catkin install space, WS/install) and runs it from there
# alone, in an environment that has seen neither the repository nor the devel space, as a user
# who installed it would:
#   - the installed tools on a simulated drive: simulate_dataset.py, dataset_to_bag.py,
#     vislam_offline (its config/default.yaml found in the install space), evaluate.py,
#     make_variant.py, track_stereo_images, track_stereo_bag; the trajectory must equal the devel
#     space's bit for bit;
#   - each launch file against a roscore: its nodes up, every nodelet loaded.
# Prints one line per check and "check_install: N checks passed"; exits 1 at the first failure.
#   scripts/check_install.sh        (after scripts/setup.sh)
set -eo pipefail
export PATH=/usr/bin:/bin:${PATH}
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
WS=${EKF_VISLAM_WS:-${REPO}/build}
INSTALL=${WS}/install
TMP=$(mktemp -d /tmp/ekf_vislam_install.XXXXXX)
ROSCORE_PID=""
cleanup() {
  if [[ -n "${ROSCORE_PID}" ]]; then
    kill -TERM "${ROSCORE_PID}" 2>/dev/null || true
    wait "${ROSCORE_PID}" 2>/dev/null || true
  fi
  rm -rf "${TMP}"
}
trap cleanup EXIT
PASSED=0
pass() { echo "ok: $*"; PASSED=$((PASSED + 1)); }
fail() { echo "check_install: FAILED: $*" >&2; exit 1; }

[[ -d "${WS}/build" ]] || fail "${WS}/build does not exist: run scripts/setup.sh first"
cmake --build "${WS}/build" --target install -- -j2 > "${TMP}/install.log" 2>&1 ||
  { tail -20 "${TMP}/install.log" >&2; fail "the install target"; }
[[ -f "${INSTALL}/setup.bash" ]] || fail "no ${INSTALL}/setup.bash after the install target"
pass "installed into ${INSTALL}"

# A free port for this check's own roscore.
PORT=$(/usr/bin/python3 -c \
  'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')
# "${INSTALLED[@]}" CMD ARGS: CMD in a clean environment with only the install space sourced,
# run from ${TMP}; every step execs the next, so a background run's $! is CMD's own pid.
INSTALLED=(env -i HOME="${HOME:-/root}" PATH=/usr/bin:/bin ROS_HOSTNAME=localhost
  ROS_MASTER_URI="http://localhost:${PORT}" ROS_HOME="${TMP}/ros_home"
  bash -c 'install=$0 dir=$1; shift; command=("$@"); set --  # setup.bash reads "$@"
           source "${install}/setup.bash" && cd "${dir}" && exec "${command[@]}"'
  "${INSTALL}" "${TMP}")
installed() { "${INSTALLED[@]}" "$@"; }
# step NAME CMD ARGS: runs CMD installed, its output appended to ${TMP}/steps.log; on failure
# prints that log and fails naming the step.
step() {
  local name=$1
  shift
  installed "$@" >> "${TMP}/steps.log" 2>&1 || { cat "${TMP}/steps.log" >&2; fail "${name}"; }
}

where=$(installed rospack find ekf_vislam) || fail "rospack find ekf_vislam"
[[ "${where}" == "${INSTALL}/share/ekf_vislam" ]] ||
  fail "rospack finds ${where}, not the install space"
pass "rospack find ekf_vislam: ${where}"

step simulate_dataset.py rosrun ekf_vislam simulate_dataset.py --seed 7 --frames 120 --out sim
step dataset_to_bag.py rosrun ekf_vislam dataset_to_bag.py sim.npz sim.bag
step vislam_offline rosrun ekf_vislam vislam_offline --bag sim.bag --out run_installed
grep -q "^vislam_offline: configuration ${INSTALL}/share/ekf_vislam/config/default.yaml$" \
  "${TMP}/steps.log" || fail "vislam_offline did not read the installed config/default.yaml"
pass "simulate_dataset.py, dataset_to_bag.py, vislam_offline with the installed configuration"

# The devel space's vislam_offline on the same bag gives the same trajectory.
source "${REPO}/scripts/env.sh" > /dev/null 2>&1
rosrun ekf_vislam vislam_offline --bag "${TMP}/sim.bag" --out "${TMP}/run_devel" \
  > "${TMP}/devel.log" 2>&1 ||
  { cat "${TMP}/devel.log" >&2; fail "the devel space's vislam_offline"; }
cmp -s "${TMP}/run_installed/trajectory.tum" "${TMP}/run_devel/trajectory.tum" ||
  fail "the installed and the devel vislam_offline give different trajectories"
pass "the installed vislam_offline's trajectory equals the devel space's bit for bit"

step evaluate.py rosrun ekf_vislam evaluate.py --estimate run_installed/trajectory.tum \
  --groundtruth sim_groundtruth.tum --out eval
step make_variant.py rosrun ekf_vislam make_variant.py sim.npz --groundtruth sim_groundtruth.tum \
  --twist accurate --keep-fraction 0.5 --out variant.npz
step track_stereo_images rosrun ekf_vislam track_stereo_images --help
step track_stereo_bag rosrun ekf_vislam track_stereo_bag --help
pass "evaluate.py, make_variant.py, track_stereo_images, track_stereo_bag"

# Background runs ignore SIGINT: they are stopped with SIGTERM, which roslaunch handles too.
setsid "${INSTALLED[@]}" roscore -p "${PORT}" > "${TMP}/roscore.log" 2>&1 &
ROSCORE_PID=$!
for _ in $(seq 1 60); do
  installed rosnode list > /dev/null 2>&1 && break
  sleep 0.5
done
installed rosnode list > /dev/null 2>&1 || fail "roscore on port ${PORT} did not come up"

# launch arguments | the nodes that must be running
check_launch() {
  local launch_args=$1 expected=$2 log="${TMP}/launch.log"
  # shellcheck disable=SC2086
  setsid "${INSTALLED[@]}" roslaunch ekf_vislam ${launch_args} > "${log}" 2>&1 &
  local pid=$!
  local nodes=""
  for _ in $(seq 1 120); do  # up to 60 s: the test may run beside others
    sleep 0.5
    nodes=$(installed rosnode list 2>/dev/null | tr '\n' ' ')
    local missing=0
    for node in ${expected}; do [[ " ${nodes} " == *" ${node} "* ]] || missing=1; done
    ((missing == 0)) && break
  done
  sleep 2  # a nodelet that fails to load ends its loader node after it registered
  nodes=$(installed rosnode list 2>/dev/null | tr '\n' ' ')
  kill -TERM "${pid}" 2>/dev/null || true
  wait "${pid}" 2>/dev/null || true
  for node in ${expected}; do
    [[ " ${nodes} " == *" ${node} "* ]] && continue
    cat "${log}" >&2
    fail "roslaunch ekf_vislam ${launch_args}: ${node} not running (${nodes})"
  done
  if grep -qi "failed to load nodelet\|exception\|process has died" "${log}"; then
    cat "${log}" >&2
    fail "roslaunch ekf_vislam ${launch_args}: an error in its output"
  fi
  pass "roslaunch ekf_vislam ${launch_args}: ${expected}"
}
check_launch "vislam.launch" "/vislam_manager /vislam"
check_launch "vislam.launch standalone:=true" "/vislam"
check_launch "stereo_vislam.launch" "/stereo_vislam_manager /stereo_tracker /vislam"
check_launch "twist_combiner.launch" "/twist_combiner"

echo "check_install: ${PASSED} checks passed"
