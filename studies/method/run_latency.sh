#!/usr/bin/env bash
# The method at another latency than the calibrated one (the method study's "At another latency"): the
# task's default method at preset=paper_32samples_calibrated (VARIANT=<name>: that variant, in the runs'
# names; without one grasp_release_ahead_acquire, the default when the unnamed runs were made, so a resume
# composes the trial they ran) on TASKS and
# SEEDS with each plan applied LATENCY s after its state (planner.latency) and plans still started every
# 0.17 s (planner.replan_period; EVERY=0.06 starts them that often instead, the runs named _every06; a
# LATENCY over 0.17 starts them that often), as a machine that plans faster (or slower) than the calibrated
# latency would apply them. Simulated time: reproducible, and the cores may be shared. Resumable (a kept
# record is skipped). EXTRA: more overrides (a lever on top of the method), named by TAG in the run's name
# (TAG=approach3 EXTRA="planner.approach_reset=3.0").
#   TASKS=paper_stapler SEEDS="0 1 2 3" LATENCY=0.06 nohup nice -n 15 bash studies/method/run_latency.sh &
set -u
cd "$(dirname "$0")/../.."
: "${CONTACTMPC_PAPER_DATA:?set CONTACTMPC_PAPER_DATA to the mjpc/tasks directory of the paper authors}"
PY=${PY:-python}
KEEP=studies/method/latency
LATENCY=${LATENCY:-0.06}
for task in ${TASKS:-paper_stapler}; do
  for seed in ${SEEDS:-0 1 2 3}; do
    name="${task}${VARIANT:+_$VARIANT}_latency${LATENCY#0.}${EVERY:+_every${EVERY#0.}}${TAG:+_$TAG}_seed${seed}"
    [[ -f "$KEEP/$name/trial.json" ]] && continue
    dir="outputs/method_latency/$name"
    # shellcheck disable=SC2086  (EXTRA is several overrides)
    "$PY" launch.py task="$task" variant="${VARIANT:-grasp_release_ahead_acquire}" seed="$seed" planner.nthread=1 \
      job.progress=false planner.latency="$LATENCY" planner.replan_period="${EVERY:-0.17}" ${EXTRA:-} \
      hydra.run.dir="$dir" || echo "run failed: $name"
    if [[ -f "$dir/trial.json" ]]; then mkdir -p "$KEEP/$name" && cp "$dir/trial.json" "$KEEP/$name/"; fi
  done
done
