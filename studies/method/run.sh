#!/usr/bin/env bash
# The method study's records: grasp_held_eased with shaping=clearance_grasp, with reuse=elites, with
# rollout=fine_on_error (= grasp_held_eased_refined), with rollout=fine_until_held, with place=wrist, with
# rollout=fine_grasp_on_error, with rollout=fine_from_contact, with rollout=fine_after_grasp, with
# rollout=fine_budget, with rollout=fine, then with retarget=wrist (candidates on top of it),
# grasp_held_expected_adaptive, grasp_held_expected_long, grasp_held_expected_paced, grasp_held_expected, grasp_held_retract,
# grasp_held_eased, grasp_release_ahead with effort=acquire, grasp_release_ahead, then grasp_release, on the
# four paper tasks, seeds 0-9, then the paper's full method at the same point on the same seeds
# (experiment=method); VARIANTS="full" runs some of them. One seed at a time (seeds vary
# slowest: a stopped run holds every task at the seeds it reached); SEEDS="0 2 4" runs some of them (two
# runners with disjoint seeds share the cores). Resumable: a finished record in the same directory is
# skipped. Two single-threaded trials at a time by default; run niced in the background:
#   nohup nice -n 15 bash studies/method/run.sh > outputs/method.log 2>&1 &
set -u
cd "$(dirname "$0")/../.."
PY=${PY:-python}
OUT=${OUT:-studies/method/records}
for method in ${VARIANTS:-grasp_held_eased+shaping=clearance_grasp grasp_held_eased+reuse=elites grasp_held_eased+rollout=fine_on_error grasp_held_eased+rollout=fine_until_held grasp_held_eased+place=wrist grasp_held_eased+rollout=fine_grasp_on_error grasp_held_eased+rollout=fine_from_contact grasp_held_eased+rollout=fine_after_grasp grasp_held_eased+rollout=fine_budget grasp_held_eased+rollout=fine grasp_held_eased+retarget=wrist grasp_held_expected_adaptive grasp_held_expected_long grasp_held_expected_paced grasp_held_expected grasp_held_retract grasp_held_eased grasp_release_ahead+effort=acquire grasp_release_ahead grasp_release full}; do
  # a method is a variant, then +group=member for each group on top (grasp_release_ahead+effort=acquire)
  groups=""
  if [[ $method == *+* ]]; then groups=${method#*+}; groups=${groups//+/ }; fi
  for seed in ${SEEDS:-0 1 2 3 4 5 6 7 8 9}; do
    # shellcheck disable=SC2086
    "$PY" launch.py experiment=method variant="${method%%+*}" $groups seed="$seed" "hydra.sweep.dir=$OUT" \
      ${EXTRA:-} || true
  done
done
