#!/usr/bin/env bash
# Stereo images to trajectory, offline: the tracker over a KITTI-layout folder (image_left/ and
# image_right/ or KITTI's image_0/ and image_1/, calib.txt, times.txt, poses.txt or --poses
# FILE, e.g. KITTI's poses/NN.txt), its features with the poses' accurate twist
# (0.05 m/s and 0.005 rad/s white noise, 0.001 rad/s gyro offset, seeded; --twist-noise V W and
# --gyro-offset B choose others) as a bag, SLAM and dead reckoning through vislam_offline, and
# evaluate.py against the poses. Prints one line per mode: ATE (m, after SE(3) alignment), RPE (%),
# mean position NEES, and the path length.
#   scripts/images_end_to_end.sh FOLDER [--poses FILE] [--out DIR] [--config estimator.yaml]
#                                [--tracker-config tracker.yaml] [--seed N] [--first-frame N]
#                                [--twist-noise V W] [--gyro-offset B]
set -eo pipefail
export PATH=/usr/bin:/bin:${PATH}
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
FOLDER=""
POSES=""
OUT=""
SEED=0
ESTIMATOR=()
TRACKER=()
FIRST=()
TWIST=()
while (($#)); do
  case "$1" in
    --out) OUT=$2; shift 2 ;;
    --poses) POSES=$(readlink -f "$2"); shift 2 ;;
    --config) ESTIMATOR=(--config "$(readlink -f "$2")"); shift 2 ;;
    --tracker-config) TRACKER=(--config "$(readlink -f "$2")"); shift 2 ;;
    --seed) SEED=$2; shift 2 ;;
    --first-frame) FIRST=(--first-frame "$2"); shift 2 ;;
    --twist-noise) TWIST+=(--twist-noise "$2" "$3"); shift 3 ;;
    --gyro-offset) TWIST+=(--gyro-offset "$2"); shift 2 ;;
    -h|--help) sed -n 2,11p "$0"; exit 0 ;;
    *) FOLDER=$1; shift ;;
  esac
done
POSES=${POSES:-${FOLDER}/poses.txt}
[[ -f "${POSES}" ]] || { echo "images_end_to_end: no ${POSES}: FOLDER/poses.txt or --poses FILE" >&2; exit 2; }
source "${REPO}/scripts/env.sh" >/dev/null
LIB=$(catkin_find --first-only --libexec ekf_vislam)
OUT=${OUT:-$(mktemp -d)}
mkdir -p "${OUT}"
"${LIB}/track_stereo_images" --folder "${FOLDER}" --poses "${POSES}" \
  --out "${OUT}/tracks.npz" --time-offset 1000 --seed "${SEED}" --quiet "${TRACKER[@]}" "${FIRST[@]}" \
  "${TWIST[@]}" \
  >"${OUT}/tracker.log"
/usr/bin/python3 "${REPO}/scripts/dataset_to_bag.py" "${OUT}/tracks.npz" "${OUT}/tracks.bag" >/dev/null
for mode in slam deadreckoning; do
  "${LIB}/vislam_offline" --bag "${OUT}/tracks.bag" --mode "${mode}" --out "${OUT}/${mode}" \
    "${ESTIMATOR[@]}" >"${OUT}/${mode}.log" 2>&1
done
/usr/bin/python3 "${REPO}/scripts/evaluate.py" --groundtruth "${OUT}/tracks_groundtruth.tum" \
  --estimate "${OUT}/slam/trajectory.tum" --label slam \
  --estimate "${OUT}/deadreckoning/trajectory.tum" --label deadreckoning --out "${OUT}/eval" >/dev/null
/usr/bin/python3 - "${OUT}/eval/metrics.json" <<'PY'
import json, sys
estimates = json.load(open(sys.argv[1]))['estimates']
for mode, m in estimates.items():
    rpe = '-' if m['rpe_percent'] is None else '%.2f' % m['rpe_percent']
    print('%-13s ATE %.4f m, RPE %s %%, position NEES %.2f, path %.1f m'
          % (mode, m['ate_rmse_m'], rpe, m['nees_position']['mean'], m['path_length_m']))
PY
echo "images_end_to_end: outputs in ${OUT}"
