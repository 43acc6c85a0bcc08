#!/usr/bin/env bash
# A recorded stereo bag to trajectory, offline: track_stereo_bag over its images (raw or
# compressed, the topics of stereo_vislam.launch unless given), then SLAM and dead reckoning
# through vislam_offline, and, when the bag holds a ground truth (nav_msgs/Odometry on
# --groundtruth-topic, default /groundtruth/odometry), evaluate.py against it. Prints the
# tracker's summary line, then one line per mode: ATE (m, after SE(3) alignment), RPE (%), mean
# position NEES and the path length (without a ground truth: the path length only).
#   scripts/bag_end_to_end.sh BAG [--out DIR] [--config estimator.yaml]
#                             [--tracker-config tracker.yaml] [--groundtruth-topic T]
#                             [--no-twist] [--rectify (raw images: ros/rectify)]
#                             [track_stereo_bag's topic options: --left-topic T ...]
set -eo pipefail
export PATH=/usr/bin:/bin:${PATH}
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
BAG=""
OUT=""
ESTIMATOR=()
TRACKER=()
GROUNDTRUTH=/groundtruth/odometry
while (($#)); do
  case "$1" in
    --out) OUT=$2; shift 2 ;;
    --config) ESTIMATOR=(--config "$(readlink -f "$2")"); shift 2 ;;
    --tracker-config) TRACKER+=(--config "$(readlink -f "$2")"); shift 2 ;;
    --groundtruth-topic) GROUNDTRUTH=$2; shift 2 ;;
    --*-topic) TRACKER+=("$1" "$2"); shift 2 ;;
    --no-twist|--rectify) TRACKER+=("$1"); shift ;;
    -h|--help) sed -n 2,11p "$0"; exit 0 ;;
    -*) echo "bag_end_to_end: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) BAG=$(readlink -f "$1"); shift ;;
  esac
done
[[ -f "${BAG}" ]] || { echo "bag_end_to_end: no bag given or found (see --help)" >&2; exit 2; }
source "${REPO}/scripts/env.sh" >/dev/null
LIB=$(catkin_find --first-only --libexec ekf_vislam)
OUT=${OUT:-$(mktemp -d)}
mkdir -p "${OUT}"
"${LIB}/track_stereo_bag" --bag "${BAG}" --out "${OUT}/features.bag" "${TRACKER[@]}" \
  2>"${OUT}/tracker.log" || { cat "${OUT}/tracker.log" >&2; exit 1; }
for mode in slam deadreckoning; do
  "${LIB}/vislam_offline" --bag "${OUT}/features.bag" --mode "${mode}" --out "${OUT}/${mode}" \
    "${ESTIMATOR[@]}" >"${OUT}/${mode}.log" 2>&1
done
/usr/bin/python3 - "${BAG}" "${GROUNDTRUTH}" "${OUT}/groundtruth.tum" <<'PY'
import sys
from ekf_vislam_tools.bag_reading import read_odometry_poses
from ekf_vislam_tools.trajectory import write_tum
t, T = read_odometry_poses(sys.argv[1], sys.argv[2])
if len(t):
    write_tum(sys.argv[3], t, T)
PY
if [[ -f "${OUT}/groundtruth.tum" ]]; then
  /usr/bin/python3 "${REPO}/scripts/evaluate.py" --groundtruth "${OUT}/groundtruth.tum" \
    --estimate "${OUT}/slam/trajectory.tum" --label slam \
    --estimate "${OUT}/deadreckoning/trajectory.tum" --label deadreckoning \
    --out "${OUT}/eval" >/dev/null
  /usr/bin/python3 - "${OUT}/eval/metrics.json" <<'PY'
import json, sys
for mode, m in json.load(open(sys.argv[1]))['estimates'].items():
    rpe = '-' if m['rpe_percent'] is None else '%.2f' % m['rpe_percent']
    print('%-13s ATE %.4f m, RPE %s %%, position NEES %.2f, path %.1f m'
          % (mode, m['ate_rmse_m'], rpe, m['nees_position']['mean'], m['path_length_m']))
PY
else
  /usr/bin/python3 - "${OUT}" <<'PY'
import sys
import numpy as np
for mode in ('slam', 'deadreckoning'):
    p = np.loadtxt('%s/%s/trajectory.tum' % (sys.argv[1], mode), ndmin=2)[:, 1:4]
    print('%-13s no ground truth in the bag; path %.1f m, %d poses'
          % (mode, np.linalg.norm(np.diff(p, axis=0), axis=1).sum(), len(p)))
PY
fi
echo "bag_end_to_end: outputs in ${OUT}"
