#!/usr/bin/env bash
# The method in MuJoCo MPC's loop on a machine of THREADS planning threads (the method study's "On a
# machine of N threads"): the task's default method at preset=paper_32samples_calibrated with loop=per_plan
# (each plan applied what its own samples cost on THREADS threads after its state, at the calibrated per
# sample-step cost: the grasp's plans later than the ones after it) on TASKS and SEEDS (seeds vary slowest,
# so a sweep stopped early holds every task at the seeds it reached). VARIANT=<name>: that variant, in the
# runs' names; without it grasp_held_eased (the default when the unnamed runs were made, so a resume
# composes the trial they ran). Simulated time: reproducible, and the cores may be shared. Resumable (a kept record is
# skipped). EXTRA: more overrides, named by TAG in the run's name.
#   TASKS="paper_stapler paper_apple" SEEDS="0 2 4" THREADS=7 nohup nice -n 15 bash studies/method/run_loop.sh &
set -u
cd "$(dirname "$0")/../.."
: "${CONTACTMPC_PAPER_DATA:?set CONTACTMPC_PAPER_DATA to the mjpc/tasks directory of the paper authors}"
PY=${PY:-python}
KEEP=studies/method/loop
THREADS=${THREADS:-7}
for seed in ${SEEDS:-0 1 2 3}; do
  for task in ${TASKS:-paper_stapler}; do
    name="${task}${VARIANT:+_$VARIANT}_threads${THREADS}${TAG:+_$TAG}_seed${seed}"
    [[ -f "$KEEP/$name/trial.json" ]] && continue
    dir="outputs/method_loop/$name"
    # shellcheck disable=SC2086  (EXTRA is several overrides)
    "$PY" launch.py task="$task" variant="${VARIANT:-grasp_held_eased}" seed="$seed" planner.nthread=1 \
      job.progress=false loop=per_plan planner.latency_model.threads="$THREADS" ${EXTRA:-} \
      hydra.run.dir="$dir" || echo "run failed: $name"
    if [[ -f "$dir/trial.json" ]]; then mkdir -p "$KEEP/$name" && cp "$dir/trial.json" "$KEEP/$name/"; fi
  done
done
