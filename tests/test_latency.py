"""The loop's timing: a planning latency applied exactly (MuJoCo MPC's loop, simulated), 0 as the
synchronous loop, and timing the loop could only round refused with one line."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from contactmpc.control.cost import TrackingCost
from contactmpc.control.latency import ComputeLatency
from contactmpc.control.planners import PredictiveSampling, Replay
from contactmpc.control.samplers import PCASplineSpace
from contactmpc.trial import Trial, check_timing
from contactmpc.validate import ConfigError
from tests.helpers import static_reference
from tests.test_launch import QUIET, launch_py


def _trial(scene, ref, duration=0.2, **planner_args):
    planner = PredictiveSampling(num_samples=8, horizon=0.2, nthread=1, **planner_args)
    trial = Trial(scene, ref, PCASplineSpace(0.2), TrackingCost(lambda_v=0.0), planner, 3, duration=duration,
                  progress=False)  # fmt: skip
    return trial, planner


def _same_log(scene, ref, *planner_args: dict) -> None:
    """Trials with each of ``planner_args`` (a plan every 50 ms) log the same, bit for bit (but the plans'
    wall time)."""
    runs = []
    for args in planner_args:
        trial, planner = _trial(scene, ref, replan_period=0.05, **args)
        try:
            runs.append(trial.run().arrays())
        finally:
            planner.close()
    for key in runs[0]:
        if key != "plan_seconds":
            for other in runs[1:]:
                np.testing.assert_array_equal(runs[0][key], other[key], err_msg=key)


def _recorded(monkeypatch, trial, planner):
    """Run ``trial``, recording every plant step's control time and finger targets, and the committed
    control points after every plan: (steps [(t, ctrl)], plans [(t, theta, the time of the state planned
    from)], log)."""
    steps, plans = [], []
    scene = trial.scene
    real_step, real_plan = mujoco.mj_step, planner._plan
    fingers = scene.index.actuators

    def step(m, d, *args):
        steps.append((len(steps) * m.opt.timestep, d.ctrl[fingers].copy()))
        real_step(m, d, *args)

    def plan(t, state, rng, start):  # the time and state planned from (predicted, with compensation)
        info = real_plan(t, state, rng, start)
        plans.append((t, planner.theta.copy(), state[0]))
        return info

    monkeypatch.setattr(mujoco, "mj_step", step)
    monkeypatch.setattr(planner, "_plan", plan)
    try:
        log = trial.run().arrays()
    finally:
        planner.close()
    return steps, plans, log


@pytest.mark.parametrize("latency", [0.0, 0.02])
def test_a_plan_takes_effect_exactly_its_latency_later(monkeypatch, scene_for, latency):
    """Every plant step runs on the plan committed at the last plan start at least ``latency`` before
    it; the steps in between run on the plan before. With latency 0, on the plan of its own period."""
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.3, frames=11)
    trial, planner = _trial(scene, ref, replan_period=0.05, latency=latency)
    steps, plans, log = _recorded(monkeypatch, trial, planner)
    assert trial.latency == latency and trial.replan_interval == 0.05
    np.testing.assert_allclose([p[0] for p in plans], [0.0, 0.05, 0.1, 0.15])
    space, spline = planner.problem.space, planner.problem.spline
    theta0 = planner.problem.theta0
    changed = 0
    for t, ctrl in steps:
        k = int(np.floor((t - latency) / 0.05 + 1e-9))  # the last plan in effect at t
        theta = theta0 if k < 0 else plans[k][1]
        expected = space.controls(theta, spline.basis(np.array([t])))[0]
        np.testing.assert_allclose(ctrl, expected, rtol=0, atol=1e-12, err_msg=f"t={t:.3f}")
        if k >= 1 and abs(t - k * 0.05 - latency) < 1e-9:  # the switch from plan k-1 to plan k
            before = space.controls(plans[k - 1][1], spline.basis(np.array([t])))[0]
            changed += np.abs(before - expected).max() > 1e-6
    assert changed >= 2, "the plans never differed where they switch: nothing was tested"
    np.testing.assert_allclose(log["time"], [0.0, 0.05, 0.1, 0.15])


def test_latency_zero_is_the_synchronous_loop_bit_for_bit(scene_for):
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.3, frames=11)
    _same_log(scene, ref, {}, {"latency": 0.0})


def test_a_latency_longer_than_the_replan_period_replans_continuously(scene_for):
    """MuJoCo MPC's loop: the next plan starts when the last one takes effect, from that state."""
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.3, frames=11)
    trial, planner = _trial(scene, ref, duration=0.25, replan_period=0.01, latency=0.07)
    try:
        log = trial.run().arrays()
    finally:
        planner.close()
    assert trial.replan_interval == 0.07
    np.testing.assert_allclose(log["time"], [0.0, 0.07, 0.14, 0.21])


def test_the_modelled_latency_is_the_planners_compute_on_the_plant_grid(scene_for):
    model = ComputeLatency(sample_step_seconds=16e-6, threads=7)
    # the paper's planner: 128 samples x 250 steps x 16 us / 7 threads = 73.14 ms -> 74 plant steps
    assert model.seconds(128, 250, 0.001) == pytest.approx(0.074)
    assert model.seconds(7, 1000, 0.001) == pytest.approx(0.016)  # exactly on the grid stays there
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.3, frames=11)
    trial, planner = _trial(scene, ref, replan_period=0.01, latency_model=model)
    planner.close()
    assert trial.latency == pytest.approx(model.seconds(8, 20, 0.001)) == pytest.approx(0.001)
    assert trial.replan_interval == 0.01
    with pytest.raises(ConfigError, match="latency = 0.02 s and a latency_model"):
        PredictiveSampling(latency=0.02, latency_model=model)


@pytest.mark.parametrize(
    ("values", "named"),
    [
        ({"horizon": 0.005}, "planner.horizon = 0.005 s is shorter than one planning step"),
        ({"replan_period": 0.0125}, "planner.replan_period = 0.0125 s is not a whole number of plant steps"),
        ({"replan_period": 0.0001}, "planner.replan_period = 0.0001 s is not a whole number"),
        ({"planner_timestep": 0.0105}, "scene.planner_timestep = 0.0105 s is not a whole number"),
        ({"latency": 0.0105}, "planner.latency = 0.0105 s is not a whole number"),
        ({"latency": -0.001}, "planner.latency = -0.001 s is not a whole number"),
    ],
)
def test_timing_the_loop_would_round_is_refused(values, named):
    args = {"plant_timestep": 0.001, "planner_timestep": 0.01, "horizon": 1.0, "replan_period": 0.05,
            "latency": 0.0} | values  # fmt: skip
    with pytest.raises(ConfigError, match=named):
        check_timing(**args)
    check_timing(0.001, 0.01, 1.0, 0.05, 0.0)
    check_timing(0.001, 0.01, 0.01, 0.07, 0.074)  # what the values may be
    check_timing(0.002, 0.01, 1.0, 0.3, 0.1)


@pytest.mark.slow
def test_a_horizon_shorter_than_a_planning_step_stops_the_job_with_one_line(tmp_path):
    run = tmp_path / "run"
    r = launch_py("planner.horizon=0.005", "duration=0.1", f"hydra.run.dir={run}", *QUIET)
    assert r.returncode == 1
    assert r.stderr.strip().splitlines() == [
        "contactmpc: error: ConfigError: planner.horizon = 0.005 s is shorter than one planning step "
        "(scene.planner_timestep = 0.01 s)"
    ]
    record = json.loads((run / "trial.json").read_text())
    assert record["status"] == "error" and "planner.horizon" in record["error"]


def test_compensation_plans_from_the_state_predicted_where_the_plan_takes_effect(monkeypatch, scene_for):
    """planner.compensate_latency: each plan starts at t + latency (its window and its state), from the
    planning model rolled forward from the measured state under the committed policy; the plant steps
    as before (each plan in effect from t + latency). Latency 0: the synchronous loop, bit for bit."""
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.4, frames=11)
    trial, planner = _trial(scene, ref, duration=0.25, replan_period=0.01, latency=0.07,
                            compensate_latency=True)  # fmt: skip
    real_predict = planner.predict
    predicted = []  # the object where each prediction puts it

    def predict(t, state, duration, reach=0.0):
        assert reach == 0.0  # the simulated loop's next plan starts where this one takes effect
        ahead = real_predict(t, state, duration, reach)
        predicted.append(ahead[1][1 + scene.index.object_qpos])
        n = int(round(duration / planner.dt))
        times = t + np.arange(n) * planner.dt
        ctrl = planner.controls(planner.theta[None], planner.problem.spline.basis(times))
        rolled, _, _ = planner.engine.run(state, ctrl)
        np.testing.assert_array_equal(ahead[1][1:], rolled[0, -1, 1:])  # the committed policy rolled out
        assert np.abs(ahead[1][1:] - state[1:]).max() > 0  # the hand moves in between
        return ahead

    monkeypatch.setattr(planner, "predict", predict)
    _, plans, log = _recorded(monkeypatch, trial, planner)
    np.testing.assert_allclose([p[0] for p in plans], [0.07, 0.14, 0.21, 0.28])  # planned 70 ms ahead
    np.testing.assert_allclose([p[2] for p in plans], [0.07, 0.14, 0.21, 0.28])  # from states then
    np.testing.assert_allclose(log["time"], [0.0, 0.07, 0.14, 0.21])  # the loop's clock as before
    # each plan logs how far the object it measured is from where the last plan predicted it (none first)
    error = scene.task.layout.error(log["object_qpos"][1:], np.array(predicted[:-1]))
    assert np.isnan(log["prediction_position_error"][0]) and np.isnan(log["prediction_rotation_error"][0])
    np.testing.assert_array_equal(log["prediction_position_error"][1:], error.position)
    np.testing.assert_array_equal(log["prediction_rotation_error"][1:], error.rotation)
    assert "prediction_position_error" not in _recorded(monkeypatch, *_trial(scene, ref, duration=0.1))[2]
    _same_log(scene, ref, {}, {"compensate_latency": True})  # no latency: nothing to compensate


def test_a_prediction_is_checked_anywhere_along_its_path(scene_for):
    """planner.compensate_latency: the next plan checks where the last prediction put the object at its
    own time, on the prediction's planning steps or between two of them (interpolated), up to ``reach``
    past where the plan takes effect (``job=online``'s plans start when the last is done); NaN outside that
    path. ``reach`` rolls the prediction on without changing the state it gives."""
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.4, frames=11)
    trial, planner = _trial(scene, ref, compensate_latency=True)
    state = trial.start_plant().state(0.0)
    nq = scene.plant_model.nq
    state[1 + nq + scene.index.object_dof[:3]] = [0.3, -0.2, 0.1]  # the apple thrown: a path that moves
    layout, at = scene.task.layout, 1 + scene.index.object_qpos
    t, short = planner.predict(0.0, state, 0.05)
    assert planner.prediction_error(0.1, state) == pytest.approx((np.nan, np.nan), nan_ok=True)
    t_far, far = planner.predict(0.0, state, 0.05, reach=0.05)
    assert t == t_far == pytest.approx(0.05)
    # the state it gives: the same rollout's, up to roundoff: the controls of a longer window are another
    # product of the basis and the control points, whose BLAS kernel (and its sums' order) can differ by
    # shape and processor (seen: 4e-15 on an AMD EPYC, family 25, model 1; equal on others)
    np.testing.assert_allclose(short, far, rtol=1e-12, atol=1e-12)
    assert planner.prediction_error(0.05, far) == (0.0, 0.0)
    _, _, path = planner._path
    assert len(path) == 11  # from t to 50 ms past where the plan takes effect, in 10 ms steps
    assert planner.prediction_error(0.1, path[10]) == (0.0, 0.0)
    moved = np.linalg.norm(path[4, at][:3] - path[3, at][:3])
    assert moved > 1e-3
    between = state.copy()
    between[at] = layout.interpolate(path[3, at], path[4, at], 0.5)
    position, rotation = planner.prediction_error(0.035, between)
    assert position < 1e-9 and rotation < 1e-9
    between[at[:3]] += [0.002, 0.0, 0.0]
    assert planner.prediction_error(0.035, between)[0] == pytest.approx(0.002)
    for outside in (-0.005, 0.105):
        assert np.isnan(planner.prediction_error(outside, between)).all()
    planner.close()


def test_a_prediction_shorter_than_a_planning_step_or_diverged_is_the_state_measured():
    from tests.helpers import PointMassProblem

    problem = PointMassProblem()
    planner = PredictiveSampling(num_samples=4, horizon=1.0, compensate_latency=True)
    problem.bind(planner)
    dt = planner.dt
    assert planner.predict(0.0, problem.state, 0.4 * dt) == (0.0, problem.state)
    t, ahead = planner.predict(0.0, problem.state, 5 * dt)
    assert t == pytest.approx(5 * dt) and ahead[0] == pytest.approx(5 * dt)
    bad = problem.state.copy()
    bad[1:3] = np.nan  # a state the model cannot step from: the rollout diverges
    assert planner.predict(0.0, bad, 5 * dt)[0] == 0.0
    problem.engine.close()
    replay = Replay(horizon=1.0, compensate_latency=True)  # no rollouts: nothing to predict with
    problem.bind(replay)
    replay.engine = None
    assert replay.predict(0.0, problem.state, 5 * dt) == (0.0, problem.state)


PRICED = ComputeLatency(sample_step_seconds=1e-4, threads=1)  # 20 samples x 20 steps: 40 ms; 8: 16 ms


def test_per_plan_latency_charges_each_plan_its_own_price(monkeypatch, scene_for):
    """planner.latency_per_plan: the grasp's 20-sample plans (until ``acquire_until`` after the first
    expected contact, here 0.1 s) land 40 ms after their state, the later 8-sample ones 16 ms; each next plan
    starts when the last takes effect; every plant step runs on the last plan in effect; the record's
    expected log (the trial's schedule) is the log's instants."""
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.3, frames=11)  # contact expected from 0 s
    trial, planner = _trial(scene, ref, duration=0.2, latency_model=PRICED, latency_per_plan=True,
                            acquire_samples=20, acquire_until=0.1)  # fmt: skip
    assert planner.problem.first_contact == 0.0
    assert trial.latency == pytest.approx(0.04)  # the dearest plan's, as the record states
    starts = [0.0, 0.04, 0.08, 0.12, 0.136, 0.152, 0.168, 0.184]
    schedule = trial.schedule()
    np.testing.assert_allclose([k * 1e-3 for k, _, _ in schedule], starts)
    assert [lag for _, lag, _ in schedule] == [40, 40, 40] + [16] * 5
    steps, plans, log = _recorded(monkeypatch, trial, planner)
    np.testing.assert_allclose(log["time"], starts)
    np.testing.assert_array_equal(trial.expected_log()[0], log["time"])
    effect = [k * 1e-3 + lag * 1e-3 for k, lag, _ in schedule]  # where each plan takes effect
    space, spline = planner.problem.space, planner.problem.spline
    for t, ctrl in steps:
        k = sum(e <= t + 1e-9 for e in effect) - 1  # the last plan in effect at t
        theta = planner.problem.theta0 if k < 0 else plans[k][1]
        expected = space.controls(theta, spline.basis(np.array([t])))[0]
        np.testing.assert_allclose(ctrl, expected, rtol=0, atol=1e-12, err_msg=f"t={t:.3f}")


def test_per_plan_latency_of_plans_that_all_cost_the_same_is_the_fixed_loop_bit_for_bit(scene_for):
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.3, frames=11)
    _same_log(scene, ref, {"latency_model": PRICED}, {"latency_model": PRICED, "latency_per_plan": True})


def test_per_plan_latency_prices_the_phase_of_the_plans_state():
    """Each plan's price is its phase's, from the time of its state; the one compensated plan whose state
    is in the acquire window but which acts after it (and draws the later samples) is charged the grasp's.
    Off: every plan the dearest phase's price."""
    from tests.helpers import PointMassProblem

    problem = PointMassProblem()
    args = {"num_samples": 8, "horizon": 0.2, "acquire_samples": 20, "acquire_until": 0.1,
            "latency_model": PRICED, "compensate_latency": True}  # fmt: skip
    on, off = PredictiveSampling(latency_per_plan=True, **args), PredictiveSampling(**args)
    for planner in (on, off):
        problem.bind(planner)
        planner.problem.first_contact = 0.0
    dt = problem.model.opt.timestep
    dear, cheap = PRICED.seconds(20, 20, dt), PRICED.seconds(8, 20, dt)
    assert dear > cheap
    assert [on.latency_at(t, dt) for t in (0.0, 0.09, 0.1)] == [dear, dear, cheap]
    assert on.samples_at(0.09) == 20 and on.samples_at(0.09 + dear) == 8  # the plan across: charged dear
    assert [off.latency_at(t, dt) for t in (0.0, 0.1)] == [dear, dear] == [off.latency_for(dt)] * 2
    problem.engine.close()


@pytest.mark.parametrize(
    ("args", "named"),
    [
        ({}, "not with a fixed latency"),
        (
            {"latency_model": PRICED, "switch_timestep": 0.005},
            "not with a planning model switched on the state",
        ),
        ({"latency_model": PRICED, "pace_lag": 0.03}, "not with a paced reference"),
    ],
)
def test_per_plan_latency_needs_a_model_and_a_schedule_known_from_time(args, named):
    with pytest.raises(ConfigError, match=named):
        PredictiveSampling(latency_per_plan=True, **args)


def test_loop_per_plan_prices_at_the_calibrated_sample_step_and_fixed_changes_nothing():
    """loop=per_plan: the latency model at preset=paper_calibrated's per sample-step cost (the figure the
    plan_cost study checks), the paper's 7 threads, each plan its own price; on the paper tasks' method
    a grasp plan lands 170 ms (the calibrated preset's latency) after its state, a later one 43 ms.
    loop=fixed (the default) composes the config without it."""
    from tests.conftest import compose_config

    per_plan = compose_config(["task=apple", "preset=paper_32samples_calibrated", "loop=per_plan"])
    calibrated = compose_config(["preset=paper_calibrated"])
    model = per_plan.planner.latency_model
    assert model.sample_step_seconds == calibrated.planner.latency_model.sample_step_seconds
    assert model.threads == 7 and per_plan.planner.latency == 0 and per_plan.planner.latency_per_plan
    fixed = compose_config(["preset=paper_32samples_calibrated"])
    priced = ComputeLatency(model.sample_step_seconds, model.threads)
    assert priced.seconds(128, 250, 0.001) == pytest.approx(fixed.planner.latency)
    assert priced.seconds(32, 250, 0.001) == pytest.approx(0.043)
    assert compose_config(["loop=fixed"]) == compose_config([])


@pytest.mark.slow
def test_a_per_plan_trial_records_its_plans_latencies(tmp_path):
    run = tmp_path / "run"
    overrides = ("loop=per_plan", "planner.acquire_samples=64", "duration=0.3", f"hydra.run.dir={run}")
    r = launch_py(*overrides, *QUIET)
    assert r.returncode == 0, r.stderr
    record = json.loads((run / "trial.json").read_text())
    assert record["latency"] == max(float(k) for k in record["plan_latencies"])
    assert sum(record["plan_latencies"].values()) == record["num_plans"]
