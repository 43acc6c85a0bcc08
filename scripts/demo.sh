#!/usr/bin/env bash
# The main job: set up, build, take a dataset, convert it to a bag, run dead reckoning, mapping and
# SLAM, evaluate and plot. Results in results/<name>/ (summary.md, PNGs, per-mode outputs).
#   scripts/demo.sh                          a synthetic drive generated on the spot (with truth)
#   scripts/demo.sh DATASET.npz [GT.tum]     a course dataset; ground truth given, or found next
#                                            to it (groundtruth/<name>_imu_gt.tum)
set -eo pipefail
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"${REPO}/scripts/setup.sh"
source "${REPO}/scripts/env.sh"
PY=/usr/bin/python3

if [[ $# -ge 1 ]]; then
  DATASET=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
  [[ -f "${DATASET}" ]] || { echo "demo.sh: ${DATASET}: no such file" >&2; exit 2; }
  NAME=$(basename "${DATASET}" .npz)
  OUT="${REPO}/results/${NAME}"
  mkdir -p "${OUT}"
  GT=${2:-}
  if [[ -z "${GT}" ]]; then
    for candidate in "$(dirname "${DATASET}")/groundtruth/${NAME}_imu_gt.tum" \
                     "$(dirname "${DATASET}")/${NAME}_groundtruth.tum"; do
      [[ -f "${candidate}" ]] && GT=${candidate} && break
    done
  fi
else
  NAME=synthetic
  OUT="${REPO}/results/${NAME}"
  mkdir -p "${OUT}"
  echo "[demo] no dataset given: simulating a drive (seed 1)"
  "${PY}" "${REPO}/scripts/simulate_dataset.py" --seed 1 --out "${OUT}/synthetic"
  DATASET="${OUT}/synthetic.npz"
  GT="${OUT}/synthetic_groundtruth.tum"
fi

echo "[demo] ${NAME}: converting to a bag"
"${PY}" "${REPO}/scripts/dataset_to_bag.py" "${DATASET}" "${OUT}/${NAME}.bag" ${GT:+--groundtruth "${GT}"}
for mode in deadreckoning mapping slam; do
  echo "[demo] ${NAME}: ${mode}"
  rosrun ekf_vislam vislam_offline --bag "${OUT}/${NAME}.bag" --mode "${mode}" --out "${OUT}/${mode}"
done
rm -rf "${OUT}/eval"
if [[ -n "${GT}" ]]; then
  echo "[demo] ${NAME}: evaluating against ${GT}"
  extra=()
  [[ -f "${OUT}/synthetic_landmarks.csv" ]] && extra=(--landmarks-gt "${OUT}/synthetic_landmarks.csv")
  "${PY}" "${REPO}/scripts/evaluate.py" --groundtruth "${GT}" --dataset "${DATASET}" \
    --estimate "${OUT}/slam/trajectory.tum" --label slam \
    --estimate "${OUT}/mapping/trajectory.tum" --label mapping \
    --estimate "${OUT}/deadreckoning/trajectory.tum" --label deadreckoning \
    --landmarks "${OUT}/slam/landmarks.csv" "${extra[@]}" --out "${OUT}/eval" >/dev/null
else
  echo "[demo] ${NAME}: no ground truth found: accuracy not evaluated"
fi
echo
"${PY}" "${REPO}/scripts/demo_summary.py" "${OUT}"
echo
echo "[demo] results in ${OUT}/ (summary.md$( [[ -n "${GT}" ]] && echo ', eval/trajectory_topdown.png, eval/comparison.png, eval/error_along_path.png, eval/consistency_slam.png' || echo ', trajectory_topdown.png'))"
