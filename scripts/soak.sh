#!/usr/bin/env bash
# Reliability soak (a one-hour synthetic drive through vislam_offline: memory, state bound, map
# size, per-frame time first vs second half) and outlier study (ATE with 5 % and 20 % extra gross
# outliers): prints the machine and one table. About 100 s on 2 cores. Arguments go to
# scripts/soak.py.
set -eo pipefail
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"${REPO}/scripts/setup.sh" >/dev/null
source "${REPO}/scripts/env.sh"
exec /usr/bin/python3 "${REPO}/scripts/soak.py" "$@"
