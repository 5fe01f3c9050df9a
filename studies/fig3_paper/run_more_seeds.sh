#!/usr/bin/env bash
# Seeds 6-9 of experiment=fig3_paper under the text's reading, for the cells whose completion differs from
# another cell of the same task by 2 of 6 or more (the study's "More seeds where completion differs"): the
# trials of each seed before those of the next (a stopped run holds every cell at the seeds it reached),
# JOBS single-threaded trials at a time (default 2), each the sweep's own job (same record directory
# names, so the study reads them beside seeds 0-5). Resumable: a kept record is skipped.
#   CELLS="paper_doorknob:full,no_contact paper_apple:full,no_contact,joint_space" bash run_more_seeds.sh
#   nohup nice -n 15 bash studies/fig3_paper/run_more_seeds.sh > outputs/fig3_more.log 2>&1 &
set -u
cd "$(dirname "$0")/../.."
: "${CONTACTMPC_PAPER_DATA:?set CONTACTMPC_PAPER_DATA to the mjpc/tasks directory of the paper authors}"
PY=${PY:-python}
OUT=${OUT:-studies/fig3_paper/records}
CELLS=${CELLS:-paper_doorknob:full,no_contact paper_apple:full,no_contact,joint_space paper_bottle:full,no_contact}
for seed in ${SEEDS:-6 7 8 9}; do
  for cell in $CELLS; do
    variants=${cell#*:}
    for variant in ${variants//,/ }; do echo "$seed ${cell%%:*} $variant"; done
  done
done | xargs -P "${JOBS:-2}" -L 1 sh -c '"$0" launch.py -m experiment=fig3_paper hydra/launcher=basic \
    "hydra.sweeper.params.seed=$2" hydra.sweeper.params.fidelity=paper "hydra.sweeper.params.task=$3" \
    "hydra.sweeper.params.variant=$4" "hydra.sweep.dir=$1" > /dev/null 2>&1 || echo "run failed: $*"
    echo "done: seed $2 $3 $4"' "$PY" "$OUT"
