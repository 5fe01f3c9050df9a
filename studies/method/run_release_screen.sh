#!/usr/bin/env bash
# The doorknob's release, screened: grasp_held_eased (the method when the records were made; VARIANT=<name>
# another, left out of the runs' names as it was then) and release=still (its release with the object's speed priced
# after the reference lets go, cost.rest_weight) at rest weights 30, 100 (release=still's), 300 and 1000 s^2, on
# the paper doorknob from 47.5 s (job.start_time: the plant at the reference's state 4 s before the reference
# lets go at 51.5 s) to the trial's end, seeds 0-7, one trial at a time; about a seventh of a full trial. Seeds
# vary slowest; resumable (launch.py skips finished records in the same directory):
#   nohup nice -n 15 bash studies/method/run_release_screen.sh > outputs/release_screen.log 2>&1 &
set -u
cd "$(dirname "$0")/../.."
PY=${PY:-python}
OUT=${OUT:-studies/method/release_screen}
# LEVERS: other levers than these, ';'-separated (each several overrides), screened on the same seeds, e.g.
#   LEVERS="release=still_wrist" bash studies/method/run_release_screen.sh
DEFAULT='release=still;release=still cost.rest_weight=30;release=still cost.rest_weight=300'
DEFAULT+=';release=still cost.rest_weight=1000'
IFS=';' read -r -a levers <<< "${LEVERS:-$DEFAULT}"
[[ -z ${LEVERS:-} ]] && levers=("" "${levers[@]}")  # the method itself, the screen's baseline
for seed in ${SEEDS:-0 1 2 3 4 5 6 7}; do
  for lever in "${levers[@]}"; do
    # shellcheck disable=SC2086
    "$PY" launch.py experiment=method task=paper_doorknob seed="$seed" job.start_time=47.5 $lever \
      variant="${VARIANT:-grasp_held_eased}" 'hydra.job.config.override_dirname.exclude_keys=[variant]' \
      hydra.launcher.n_jobs=1 "hydra.sweep.dir=$OUT" || true
  done
done
