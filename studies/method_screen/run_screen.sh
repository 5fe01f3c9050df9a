#!/usr/bin/env bash
# The cheap screen of the method levers (issue 33): each lever on the paper's stapler and bottle at
# preset=paper_32samples (text's reading), a trial started 3 s before the reference's first expected
# contact and ended 4 s after it (job.start_before_contact / job.end_after_contact), seeds 0-5, one trial
# at a time. Seeds vary slowest (a sweep stopped early holds every lever at the seeds it reached);
# resumable: launch.py skips finished records in the same directory.
#   nohup nice -n 15 studies/method_screen/run_screen.sh > outputs/method_screen.log 2>&1 &
#   python -m analysis.study method_screen    # the report (studies/method_screen/README.md)
set -u
cd "$(dirname "$0")/../.."
OUT=${OUT:-studies/method_screen/records}
PY=${PY:-python}
COMMON=(preset=paper_32samples fidelity=paper planner.nthread=1 job.progress=false
        job.start_before_contact=3.0 job.end_after_contact=4.0 hydra/launcher=basic
        "hydra.sweep.dir=$OUT" task=paper_stapler,paper_bottle)
# the method's point: its preset (paper_32samples_calibrated) on the stapler (or TASKS)
at_method_point() {
  COMMON=("${COMMON[@]/preset=paper_32samples/preset=paper_32samples_calibrated}")
  COMMON=("${COMMON[@]/task=paper_stapler,paper_bottle/task=${TASKS:-paper_stapler}}")
}
# SET=full (default): the levers on top of the paper's method; SET=clearance: on top of wrist_clearance,
# with the clearance baseline at the paper point's 128 samples (a second pair to check the screen's ranking
# against full trials: the stapler study's 5 of 6 at 128 samples against 2 of 6 at 32)
if [[ ${SET:-full} == clearance ]]; then
LEVERS=(
  "variant=wrist_clearance"
  "variant=wrist_clearance planner.iterations=4 planner.anneal=0.1 planner.early_stop=0.01"
  "variant=wrist_clearance planner.update=elite_softmax"
  "variant=wrist_clearance planner.num_samples=128"
)
COMMON=("${COMMON[@]/task=paper_stapler,paper_bottle/task=${TASKS:-paper_stapler}}")
# SET=compensation: the paper's method and wrist_clearance, each planning from the state predicted for when
# its plan takes effect (compensation=predict), on both tasks
elif [[ ${SET:-full} == compensation ]]; then
LEVERS=(
  "variant=full compensation=predict"
  "variant=wrist_clearance compensation=predict"
)
# SET=method: the method (grasp_release_ahead_acquire at its own preset, paper_32samples_calibrated) at the
# calibrated 170 ms latency and with each plan applied after 60 ms (plans still every 170 ms), on the stapler:
# does the screen show the full trials' sensitivity to timing, and what does the method do on seeds it was not
# chosen on (SEEDS="10 11 ...")?
# SET=guidance: contact guidance in the planning model (guidance=object: the object pulled along the
# reference, stiffest in a plan's first iteration, off in its last) on top of the iterations it needs, beside
# the same iterations without it, on both tasks
elif [[ ${SET:-full} == guidance ]]; then
LEVERS=(
  "variant=full planner.iterations=4 planner.anneal=0.1 planner.early_stop=0.01"
  "variant=full planner.iterations=4 planner.anneal=0.1 planner.early_stop=0.01 guidance=object"
)
# SET=guidance_method: the same guidance on the method's groups at the method's preset, on the stapler, its
# 128 rollouts a plan while contact is acquired spent as 4 iterations of 32 (effort=uniform: no 128-sample
# iterations), beside the same iterations without it and the method in the screen (SET=method) at the
# calibrated latency
elif [[ ${SET:-full} == guidance_method ]]; then
LEVERS=(
  "variant=grasp_release_ahead planner.iterations=4 planner.anneal=0.1 planner.early_stop=0.01 guidance=object"
  "variant=grasp_release_ahead planner.iterations=4 planner.anneal=0.1 planner.early_stop=0.01"
)
at_method_point
elif [[ ${SET:-full} == method ]]; then
LEVERS=(
  "variant=grasp_release_ahead_acquire"
  "variant=grasp_release_ahead_acquire planner.latency=0.06 planner.replan_period=0.17"
)
at_method_point
# SET=method_levers: levers on top of the method itself, on the stapler at the calibrated latency, against the
# method's own screen trials (SET=method): the grasp's phase (the wrist sampled, 128 samples a plan) held 1 s
# longer, to 3 s after the first contact (the reference starts lifting at 1.4-1.7 s); the wrist's sampling
# noise doubled (2 cm on its slides). Neither changes what one plan costs.
elif [[ ${SET:-full} == method_levers ]]; then
LEVERS=(
  "variant=grasp_release_ahead_acquire planner.acquire_until=3.0 sampler.root_window=[-1.0,3.0]"
  "variant=grasp_release_ahead_acquire sampler.root_sigma2=4.0e-4"
)
at_method_point
# SET=method_lift: the method and the grasp's phase held to 3 s after the first contact (until3) together, for
# a task the method levers were not screened on (TASKS=paper_apple: the reference lifts the apple 1.9-2.4 s
# after its first contact, where the method's 128 samples a plan end at 2 s; the method's lift losses)
elif [[ ${SET:-full} == method_lift ]]; then
LEVERS=(
  "variant=grasp_release_ahead_acquire"
  "variant=grasp_release_ahead_acquire planner.acquire_until=3.0 sampler.root_window=[-1.0,3.0]"
)
at_method_point
# SET=method_cost: the method's cost weighted otherwise, on the stapler at the calibrated latency, against the
# method's own screen trials (SET=method): the contact term x3, the object term x3, and the surface term on top
# of the clearance term (each expected link pulled onto the stapler wherever it touches it, after its first
# expected contact); and the wrist's rotation sampled with a quarter of the method's variance (its targets
# wander 0.1-0.3 rad from the reference's during the grasp). None changes the rollouts a plan runs.
elif [[ ${SET:-full} == method_cost ]]; then
LEVERS=(
  "variant=grasp_release_ahead_acquire cost.lambda_c=3.0"
  "variant=grasp_release_ahead_acquire cost.lambda_o=3.0"
  "variant=grasp_release_ahead_acquire cost.surface_weight=1.0"
  "variant=grasp_release_ahead_acquire sampler.root_rotation_sigma2=0.0025"
)
at_method_point
# SET=method_cost2: the two of them that lifted the stapler most often in the first seeds, together
elif [[ ${SET:-full} == method_cost2 ]]; then
LEVERS=(
  "variant=grasp_release_ahead_acquire cost.surface_weight=1.0 sampler.root_rotation_sigma2=0.0025"
)
at_method_point
# SET=method_pacing: the method with its reference paced by the object (pacing=hold: the reference's clock
# holds while the stapler is more than 2 cm from where the reference has it, up to 3 s in all, so the lift
# waits for a grasp; the trial runs 3 s longer), on the stapler at the calibrated latency, against the
# method's own screen trials (SET=method); and the same with the reference's clock slowed to 0.3 instead of
# held while the stapler lags (planner.pace_rate=0.3: the lift slowed, not stopped)
elif [[ ${SET:-full} == method_pacing ]]; then
LEVERS=(
  "variant=grasp_release_ahead_acquire pacing=hold"
  "variant=grasp_release_ahead_acquire pacing=hold planner.pace_rate=0.3"
)
at_method_point
# SET=retarget: the method with the reference's grasp corrected by one wrist translation (retarget=wrist: the
# offset that best puts the links the reference expects in contact on the object's surface), against the method's
# own screen trials (SET=method, SET=method_lift); TASKS=paper_apple first
elif [[ ${SET:-full} == retarget ]]; then
LEVERS=(
  "variant=grasp_release_ahead_acquire retarget=wrist"
)
at_method_point
# SET=planner_dt: the method with a planning model of 5 ms steps instead of 10 (scene.planner_timestep=0.005: twice the
# steps a rollout, the plant's 1 ms unchanged), against the method's own screen trials; TASKS=paper_apple first (the
# method study's lift replays)
elif [[ ${SET:-full} == planner_dt ]]; then
LEVERS=(
  "variant=grasp_release_ahead_acquire scene.planner_timestep=0.005"
)
at_method_point
# SET=clearance_links: the clearance term holding every link off until the reference first expects 5 links at
# once (cost.clearance_links=5; the method: each link until its own first expected contact), against the method's
# own screen trials (SET=method; TASKS=paper_apple: SET=method_lift's)
elif [[ ${SET:-full} == clearance_links ]]; then
LEVERS=(
  "variant=grasp_release_ahead_acquire cost.clearance_links=5"
)
at_method_point
else
LEVERS=(
  "variant=full"
  "variant=wrist_clearance"
  "variant=full planner.iterations=4 planner.anneal=0.1 planner.early_stop=0.01"
  "variant=full planner.update=elite_softmax"
  "variant=full sampler.noise_ramp=4.0"
  "variant=full planner.iterations=4 planner.anneal=0.1 planner.early_stop=0.01 planner.update=elite_softmax sampler.noise_ramp=4.0"
)
fi
for seed in ${SEEDS:-0 1 2 3 4 5}; do
  for lever in "${LEVERS[@]}"; do
    # shellcheck disable=SC2086  (a lever is several overrides)
    "$PY" launch.py -m "${COMMON[@]}" $lever "seed=$seed" || true
  done
done
