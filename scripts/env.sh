# Source me: `source scripts/env.sh`. Gives a shell where rosrun/roslaunch/rostest find ekf_vislam.
_ekf_vislam_repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
export PATH=/usr/bin:/bin:${PATH}
export ROS_HOSTNAME=${ROS_HOSTNAME:-localhost}
export ROS_MASTER_URI=${ROS_MASTER_URI:-http://localhost:11311}
export ROSCONSOLE_STDOUT_LINE_BUFFERED=1
_ekf_vislam_ws=${EKF_VISLAM_WS:-${_ekf_vislam_repo}/build}
if [ -f "${_ekf_vislam_ws}/devel/setup.bash" ]; then
  # shellcheck disable=SC1091
  source "${_ekf_vislam_ws}/devel/setup.bash"
else
  echo "ekf_vislam: ${_ekf_vislam_ws} is not built yet; run scripts/setup.sh first" >&2
fi
export EKF_VISLAM_REPO=${_ekf_vislam_repo}
if [ -z "${EKF_VISLAM_DATA:-}" ] && [ -d "${_ekf_vislam_repo}/../shared/data" ]; then
  export EKF_VISLAM_DATA=$(cd "${_ekf_vislam_repo}/../shared/data" && pwd)
fi
unset _ekf_vislam_repo _ekf_vislam_ws
