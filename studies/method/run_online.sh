#!/usr/bin/env bash
# The method study's online runs (issue 33, item 3): job=online (the plant in wall-clock time, the planner
# replanning in a second thread) on 2 planning threads, per task and method at slowdown 1, then 2, then 3,
# stopping at the first slowdown at which both runs (seeds 0 and 1) complete: the smallest slowdown at which
# the method completes the task on 2 threads of this CPU, i.e. real time on 2 x that many threads.
# Run on a quiet machine (the runs measure wall-clock time: stop other jobs while they run), from the
# repository root, with CONTACTMPC_PAPER_DATA set:
#   bash studies/method/run_online.sh      (VARIANTS="grasp_held_expected_adaptive", the paper tasks' default)
# Each run's record goes to outputs/method_online/<run>/ (trial.json + timeseries.npz); its trial.json is kept
# in studies/method/online/<run>/trial.json. A run whose record exists is skipped (resume=true). Budget: a run
# takes its trial's control time x slowdown in wall time (39-69 s at slowdown 1). PACED=170 paces the planner
# to a plan every 0.170 s of control time at most (job.min_interval; three digits, ms), the runs named _paced170;
# HELD=170 holds each plan to act no sooner than 0.170 s of control time after its state (job.apply_after), _held170.
# (EXTRA="job.simulated_timing=true" sets both from the preset instead: at the paper tasks' default, 0.170 and 0.170.)
# SUFFIX=_again appends to the runs' names: a second set of runs beside the kept ones, not over them.
# SEEDS="2 3 4" runs other seeds than 0 and 1 (with SLOWDOWNS=1: how often the method completes in real time).
set -uo pipefail
cd "$(dirname "$0")/../.."
: "${CONTACTMPC_PAPER_DATA:?set CONTACTMPC_PAPER_DATA to the mjpc/tasks directory of the paper authors}"
PY=${PY:-python}
KEEP=studies/method/online
for method in ${VARIANTS:-grasp_held_expected_adaptive}; do
  # a method is a variant, then +group=member for each group on top (grasp_release_ahead+effort=acquire)
  variant=${method%%+*}; groups=""
  if [[ $method == *+* ]]; then groups=${method#*+}; groups=${groups//+/ }; fi
  for task in ${TASKS:-paper_doorknob paper_apple paper_bottle paper_stapler}; do
    for slowdown in ${SLOWDOWNS:-1 2 3}; do
      every=1
      for seed in ${SEEDS:-0 1}; do
        name="${task}_${method//[+=]/_}${PACED:+_paced${PACED}}${HELD:+_held${HELD}}_slowdown${slowdown}_seed${seed}${SUFFIX:-}"
        dir="outputs/method_online/$name"
        # shellcheck disable=SC2086
        $PY launch.py job=online task="$task" variant="$variant" $groups planner.nthread=2 \
          job.slowdown="$slowdown" job.progress=false seed="$seed" ${PACED:+job.min_interval=0.$PACED} \
          ${HELD:+job.apply_after=0.$HELD} \
          ${EXTRA:-} hydra.run.dir="$dir" \
          || echo "run failed: $name"
        if [[ -f "$dir/trial.json" ]]; then
          mkdir -p "$KEEP/$name" && cp "$dir/trial.json" "$KEEP/$name/trial.json"
        fi
        $PY -c "import json,sys; sys.exit(0 if json.load(open('$dir/trial.json')).get('completed') else 1)" \
          2>/dev/null || every=0
      done
      if [[ $every == 1 ]]; then break; fi
    done
  done
done
echo "records kept in $KEEP"
