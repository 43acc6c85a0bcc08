#!/usr/bin/env bash
# The landmark study (SLAM against the fraction of landmark ids kept, both twists, 0027 and 0034):
# sets up, builds, then runs scripts/landmark_study.py with these arguments.
set -eo pipefail
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"${REPO}/scripts/setup.sh" >/dev/null
source "${REPO}/scripts/env.sh"
exec /usr/bin/python3 "${REPO}/scripts/landmark_study.py" "$@"
