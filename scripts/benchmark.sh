#!/usr/bin/env bash
# Accuracy, speed and memory on the course datasets (../shared/data or EKF_VISLAM_DATA) and on
# synthetic drives: prints the table the README quotes. Arguments go to scripts/benchmark.py.
set -eo pipefail
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"${REPO}/scripts/setup.sh" >/dev/null
source "${REPO}/scripts/env.sh"
exec /usr/bin/python3 "${REPO}/scripts/benchmark.py" "$@"
