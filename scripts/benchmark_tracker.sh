#!/usr/bin/env bash
# Speed of the stereo tracker: runs track_stereo_images over a KITTI-layout folder (default: the
# 1241x376 highway clip ../shared/data/kitti_clips/odometry_01_000000-000050) and prints the
# median and p99 milliseconds per stereo pair (tracking only: image decoding excluded), the
# frame rate they mean and each stage's median, for each of --repeat runs, after a line naming
# the machine, then the same over all runs' pairs together, and the slowest of each pair's median
# over the runs (the pairs' own cost, without the machine's stalls). --config: tracker options
# (default: built-in).
#   scripts/benchmark_tracker.sh [FOLDER] [--repeat N] [--config tracker.yaml]
set -eo pipefail
export PATH=/usr/bin:/bin:${PATH}
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
FOLDER=""
REPEAT=3
CONFIG=()
while (($#)); do
  case "$1" in
    --repeat) REPEAT=$2; shift 2 ;;
    --config) CONFIG=(--config "$2"); shift 2 ;;
    -h|--help) sed -n 2,9p "$0"; exit 0 ;;
    *) FOLDER=$1; shift ;;
  esac
done
DATA=${EKF_VISLAM_DATA:-${REPO}/../shared/data}
FOLDER=${FOLDER:-${DATA}/kitti_clips/odometry_01_000000-000050}
[[ -f "${FOLDER}/calib.txt" ]] || { echo "benchmark_tracker: no ${FOLDER}/calib.txt"; exit 2; }
source "${REPO}/scripts/env.sh" >/dev/null 2>&1 || true
TOOL=$(command -v track_stereo_images || true)
[[ -n "${TOOL}" ]] || TOOL=$(ls "${EKF_VISLAM_WS:-${REPO}/build}"/devel/lib/ekf_vislam/track_stereo_images)
TMP=$(mktemp -d)
trap 'rm -rf "${TMP}"' EXIT
PYTHONPATH="${REPO}/src" /usr/bin/python3 -c \
  'from ekf_vislam_tools.report import machine_description; print(machine_description())'
for run in $(seq 1 "${REPEAT}"); do
  "${TOOL}" --folder "${FOLDER}" --out "${TMP}/tracks.npz" --stats "${TMP}/stats_${run}.csv" --quiet "${CONFIG[@]}"
  /usr/bin/python3 - "${TMP}/stats_${run}.csv" "${run}" "${FOLDER}" <<'PY'
import csv, sys
import numpy as np
rows = list(csv.DictReader(open(sys.argv[1])))
ms = np.array([float(r['ms_total']) for r in rows])
features = np.array([int(r['published']) for r in rows])
print('run %s: %d pairs of %s: ms per pair median %.2f, p99 %.2f, max %.2f (pair %d; the first, '
      'which starts every track, %.2f) -> %.1f fps at the median, %.1f at p99; features per frame '
      'mean %.1f'
      % (sys.argv[2], len(ms), sys.argv[3].rstrip('/').split('/')[-1], np.median(ms),
         np.percentile(ms, 99), ms.max(), ms.argmax(), ms[0], 1000 / np.median(ms),
         1000 / np.percentile(ms, 99), features.mean()))
stages = ('pyramids', 'temporal', 'refine', 'ransac', 'stereo', 'detect')
print('  stage medians, ms: ' + ', '.join(
    '%s %.2f' % (s, np.median([float(r['ms_' + s]) for r in rows])) for s in stages))
PY
done
# All runs' pairs together: a p99 over one short clip is nearly its slowest pair.
/usr/bin/python3 - "${TMP}" "${REPEAT}" <<'PY'
import csv, sys
import numpy as np
files = ['%s/stats_%d.csv' % (sys.argv[1], k) for k in range(1, int(sys.argv[2]) + 1)]
runs = [[float(r['ms_total']) for r in csv.DictReader(open(f))] for f in files]
ms = np.concatenate(runs)
print('all %s runs: %d pairs: ms per pair median %.2f, p99 %.2f -> %.1f fps at p99; %.1f %% of the '
      'pairs over 33.3 ms' % (sys.argv[2], len(ms), np.median(ms), np.percentile(ms, 99),
                              1000 / np.percentile(ms, 99), 100 * np.mean(ms > 1000 / 30)))
# Each pair's median over the runs: what the pair's content costs, without the machine's own
# stalls (which land on other pairs in every run).
if len(runs) > 1 and len(set(map(len, runs))) == 1:
    per_pair = np.median(np.array(runs), axis=0)
    print('each pair\'s median over the runs: slowest %.2f ms (pair %d), p99 %.2f ms'
          % (per_pair.max(), per_pair.argmax(), np.percentile(per_pair, 99)))
PY
