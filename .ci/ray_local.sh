#!/usr/bin/env bash
# The Ray path, exercised on one machine: a local Ray cluster (head on 127.0.0.1), the Ray launcher in its
# own virtual environment (it pins cloudpickle<3, which clashes with the dev extra's joblib launcher),
# experiment=smoke's 4 jobs through hydra/launcher=ray_cluster, then the analysis of their records.
#   bash .ci/ray_local.sh [SWEEP_DIR]        (about 3 minutes, most of it installing Ray)
set -euo pipefail
cd "$(dirname "$0")/.."
SWEEP="${1:-outputs/sweeps/ray_local_smoke}"
VENV=.ci/.venv-ray
export RAY_USAGE_STATS_ENABLED=0
[ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
"$VENV/bin/pip" install -q -e ".[ray]"
"$VENV/bin/ray" start --head --node-ip-address=127.0.0.1 --port=6399 --num-cpus="$(nproc)" \
    --include-dashboard=false --disable-usage-stats > /dev/null
trap '"$VENV/bin/ray" stop > /dev/null 2>&1 || true' EXIT
RAY_ADDRESS=127.0.0.1:6399 "$VENV/bin/python" launch.py -m experiment=smoke hydra/launcher=ray_cluster \
    hydra.launcher.ray.remote.num_cpus=1 hydra.sweep.dir="$SWEEP"
"$VENV/bin/python" -m analysis "$SWEEP" --out-dir "$SWEEP/analysis"
