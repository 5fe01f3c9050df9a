#!/usr/bin/env bash
# Options on top of the method (the paper tasks' default) as full trials of experiment=method, one task at a
# time, seeds 0-9 (seeds vary fastest): the overrides are the arguments, e.g.
#   TASKS="stapler bottle" OUT=studies/method/levers nohup nice -n 15 bash studies/method/run_levers.sh \
#     place=wrist pacing=release > outputs/levers.log 2>&1 &
# Resumable: a finished record in the same directory is skipped; two runners with different overrides share
# the cores (each trial single-threaded).
set -u
cd "$(dirname "$0")/../.."
PY=${PY:-python}
OUT=${OUT:-studies/method/levers}
for task in ${TASKS:-stapler bottle apple doorknob}; do
  for seed in ${SEEDS:-0 1 2 3 4 5 6 7 8 9}; do
    "$PY" launch.py experiment=method task="paper_$task" "$@" seed="$seed" "hydra.sweep.dir=$OUT" || true
  done
done
