#!/usr/bin/env bash
# The method study's records: variant=grasp_release on the four paper tasks, seeds 0-9, then the paper's
# full method at the same point on the same seeds (experiment=method). Resumable: a finished record in the
# same directory is skipped. Two single-threaded trials at a time; run niced in the background:
#   nohup nice -n 15 bash studies/method/run.sh > outputs/method.log 2>&1 &
set -u
cd "$(dirname "$0")/../.."
PY=${PY:-python}
OUT=${OUT:-studies/method/records}
for variant in ${VARIANTS:-grasp_release full}; do
  "$PY" launch.py experiment=method variant="$variant" "hydra.sweep.dir=$OUT" ${EXTRA:-} || true
done
