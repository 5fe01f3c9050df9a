"""The method levers (issue 33): the cheap screen (a trial that starts late) and the planner's levers
(iterations with annealed noise and early stopping, the elite-weighted update, the noise ramp along the
horizon), the carry and the grip. Off: the plan or trial of before, bit for bit; on: a property."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from contactmpc.control.cost import TrackingCost
from contactmpc.control.grip import Grip, trapezoids
from contactmpc.control.latency import ComputeLatency
from contactmpc.control.planners import CEM, PredictiveSampling
from contactmpc.control.planners.base import expected_fingers, improvement
from contactmpc.control.release import ReleaseSchedule
from contactmpc.control.samplers import PCASplineSpace
from contactmpc.trial import Trial
from contactmpc.validate import ConfigError
from tests.helpers import PointMassProblem, assert_resets_once_at, rest_state, static_reference
from tests.test_trial import TINY, run_job


def _paper_plan(planner, problem, t, rng):
    """The plan of before the levers, written out: Gaussian samples around the nominal (row 0 the nominal),
    the cheapest rollout committed. Returns the committed control points."""
    window = problem.spline.window_indices(t, planner.horizon)
    nominal = planner.theta[window]
    noise = rng.standard_normal((planner.num_samples - 1,) + nominal.shape) * planner.window_std(window)
    candidates = np.concatenate([nominal[None], nominal[None] + noise], axis=0)
    thetas = np.broadcast_to(planner.theta, (len(candidates),) + planner.theta.shape).copy()
    thetas[:, window] = candidates
    total, _, _ = planner.evaluate(problem.state, t, thetas)
    out = planner.theta.copy()
    out[window] = candidates[int(np.argmin(total))]
    return out


def assert_same_series(first, second) -> None:
    """The time series of two trials (their records' paths) are alike bit for bit, but for the plans'
    wall times; ``second`` may log more."""
    a, b = (np.load(p.parent / "timeseries.npz") for p in (first, second))
    for key in a.files:
        if key != "plan_seconds":
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def late_apple(late_contact_reference) -> list[str]:
    """The overrides of a tiny apple trial on the reference whose first contact comes late."""
    return ["task=apple", f"task.reference_path={late_contact_reference[1]}", *TINY, "job.progress=false"]


def test_levers_off_plan_as_before_bit_for_bit():
    problem = PointMassProblem(sigma=0.4)
    off = PredictiveSampling(
        num_samples=16, horizon=1.0, iterations=1, anneal=1.0, early_stop=0.0, update="max"
    )
    problem.bind(off)
    expected = _paper_plan(off, problem, 0.0, np.random.default_rng(5))
    off.plan(0.0, problem.state, np.random.default_rng(5))
    np.testing.assert_array_equal(off.theta, expected)
    assert off.rollouts_per_plan() == 16
    problem.engine.close()


def test_elite_softmax_never_costs_more_than_max_selection_on_the_same_candidates():
    problem = PointMassProblem(sigma=0.5)
    elite = PredictiveSampling(num_samples=20, horizon=1.0, update="elite_softmax", elite_fraction=0.2)
    greedy = PredictiveSampling(num_samples=20, horizon=1.0)
    problem.bind(elite)
    problem.bind(greedy)
    used_mean = 0
    for seed in range(8):
        a = elite.plan(0.0, problem.state, np.random.default_rng(seed))
        b = greedy.plan(0.0, problem.state, np.random.default_rng(seed))
        assert a.best_cost <= b.best_cost
        used_mean += a.best_cost < b.best_cost
        greedy.theta[:] = elite.theta  # both go on from the same nominal: the same candidates again
    assert used_mean > 0  # the mean was committed at least once (else the property says nothing)
    assert elite.rollouts_per_plan() == 21
    problem.engine.close()


def test_iterations_anneal_the_noise_stop_early_and_are_charged():
    problem = PointMassProblem(sigma=0.4)
    planner = PredictiveSampling(num_samples=8, horizon=1.0, iterations=4, anneal=0.1)
    problem.bind(planner)
    window = problem.spline.window_indices(0.0, 1.0)
    assert planner.noise_scale(0.0, window, 0) is None
    np.testing.assert_allclose(planner.noise_scale(0.0, window, 2), 0.1**0.5)
    info = planner.plan(0.0, problem.state, np.random.default_rng(0))
    assert info.iterations == 4 and info.best_cost <= info.nominal_cost
    assert planner.rollouts_per_plan() == 32
    assert planner.latency_for(0.001) == 0.0  # no latency model: the fixed latency
    model = ComputeLatency(sample_step_seconds=1e-4, threads=1)
    # early stop: a threshold no iteration can reach stops after the first
    stop = PredictiveSampling(num_samples=8, horizon=1.0, iterations=4, early_stop=10.0)
    problem.bind(stop)
    assert stop.plan(0.0, problem.state, np.random.default_rng(0)).iterations == 1
    charged = PredictiveSampling(num_samples=8, horizon=1.0, iterations=4, latency_model=model)
    single = PredictiveSampling(num_samples=8, horizon=1.0, latency_model=model)
    for p in (charged, single):
        problem.bind(p)
    assert charged.latency_for(0.001) == pytest.approx(model.seconds(32, charged.steps, 0.001))
    assert charged.latency_for(0.001) > single.latency_for(0.001)
    assert improvement(2.0, 1.0) == 0.5 and improvement(np.inf, 1.0) == np.inf
    assert improvement(np.inf, np.inf) == 0.0
    problem.engine.close()


def test_iterations_with_cem_run():
    problem = PointMassProblem(sigma=0.4)
    planner = CEM(num_samples=8, num_elites=3, horizon=1.0, iterations=3, anneal=0.1)
    problem.bind(planner)
    info = planner.plan(0.0, problem.state, np.random.default_rng(0))
    assert info.iterations == 3 and np.isfinite(info.best_cost)
    problem.engine.close()


def test_noise_ramp_grows_along_the_horizon(scene_for):
    scene = scene_for("apple")
    ref = static_reference(scene, duration=4.0, frames=41)
    space = PCASplineSpace(0.2, noise_ramp=4.0)
    planner = PredictiveSampling(num_samples=400, horizon=2.0, nthread=1)
    trial = Trial(scene, ref, space, TrackingCost(), planner, 0, num_control_points=16, progress=False)
    spline = trial.spline
    window = spline.window_indices(1.0, 2.0)
    scale = space.horizon_noise(spline, window, 1.0, 2.0)[:, 0]
    greville = np.array([spline.knots[j + 1 : j + spline.degree + 1].mean() for j in window])
    np.testing.assert_allclose(scale, 1 + 3 * np.clip((greville - 1.0) / 2.0, 0, 1))
    assert scale[0] == 1.0 and scale[-1] == 4.0 and np.all(np.diff(scale) >= 0)
    # the drawn noise follows it: its spread per control point over the samples
    planner._noise_scale = planner.noise_scale(1.0, window)
    cands = planner.sample(np.random.default_rng(0), planner.theta[window], window)
    std = planner.window_std(window)
    spread = ((cands[1:] - cands[0])[..., std > 0] / std[std > 0]).std(axis=(0, 2))
    np.testing.assert_allclose(spread, scale, rtol=0.1)  # 399 x d draws each: ~4 % sampling error
    assert PCASplineSpace(0.2).horizon_noise(spline, window, 1.0, 2.0) is None
    planner.close()


@pytest.fixture(scope="module")
def late_contact_reference(tmp_path_factory, scene_for):
    """A short reference of the synthetic apple whose object rises and whose contacts start at frame 4."""
    ref = static_reference(scene_for("apple"), duration=1.0, frames=11)
    ref.object_qpos[:, 2] += np.linspace(0.0, 0.05, 11)
    ref.contact_active[:4] = False
    return ref, str(ref.save(tmp_path_factory.mktemp("late") / "apple.npz"))


def test_a_late_start_puts_the_plant_at_the_references_state(scene_for, late_contact_reference):
    scene, ref = scene_for("apple"), late_contact_reference[0]
    planner = PredictiveSampling(num_samples=4, horizon=0.1, replan_period=0.05, nthread=1)
    trial = Trial(scene, ref, PCASplineSpace(0.2), TrackingCost(), planner, 0, progress=False, start_time=0.3)
    d = trial.start_plant().data
    np.testing.assert_array_equal(scene.hand_qpos(d), planner.targets(np.array([0.3]))[0])
    expected = trial.track.object_qpos[trial.track.index(0.3)]
    np.testing.assert_array_equal(scene.object_qpos(d), expected)
    assert expected[2] > ref.object_qpos[0, 2] + 0.001  # (the object has moved by then)
    assert not d.qvel.any()
    with pytest.raises(ConfigError, match="not before the trial's end"):
        Trial(scene, ref, PCASplineSpace(0.2), TrackingCost(), planner, 0, duration=0.3, start_time=0.3)
    planner.close()


def test_a_trial_started_late_runs_and_off_is_the_whole_trial(tmp_path, late_contact_reference):
    overrides = ["task=apple", f"task.reference_path={late_contact_reference[1]}", *TINY]
    overrides += ["job.progress=false", "duration=0.6"]
    base = run_job(overrides, tmp_path / "base")
    same = run_job(overrides + ["job.start_time=0"], tmp_path / "zero")
    assert_same_series(base, same)
    late = run_job(overrides + ["job.start_time=0.3"], tmp_path / "late")
    record = json.loads(late.read_text())
    assert record["status"] == "ok" and record["start_time"] == 0.3
    assert "start_time" not in json.loads(base.read_text())
    assert record["simulated_seconds"] == pytest.approx(0.3)
    series = np.load(late.parent / "timeseries.npz")
    np.testing.assert_allclose(series["time"], [0.3, 0.35, 0.4, 0.45, 0.5, 0.55])
    np.testing.assert_array_equal(series["object_qpos"][0], series["expected_object_qpos"][0])


def test_start_and_end_relative_to_the_first_contact(tmp_path, late_contact_reference):
    overrides = late_apple(late_contact_reference)
    record = json.loads(
        run_job(
            overrides + ["job.start_before_contact=0.1", "job.end_after_contact=0.1"], tmp_path
        ).read_text()
    )
    assert record["status"] == "ok"
    first = record["contact_span_start"]
    assert record["start_time"] == pytest.approx(first - 0.1, abs=0.06)
    assert record["simulated_seconds"] == pytest.approx(0.2, abs=0.06)
    with pytest.raises(ConfigError, match="both set"):
        run_job(overrides + ["job.start_time=1", "job.start_before_contact=1"], tmp_path / "both")


def count_candidates(planner) -> list[int]:
    """The candidates each of ``planner``'s evaluations rolls out, appended as it plans."""
    sizes = []
    real = planner.evaluate

    def evaluate(state, t, thetas):
        sizes.append(len(thetas))
        return real(state, t, thetas)

    planner.evaluate = evaluate
    return sizes


def assert_plans_alike(planner, other, t: float, state) -> None:
    """From ``planner``'s nominal, a plan of ``other`` at ``t`` commits what ``planner``'s does, bit for bit
    (the same draws, the same best cost)."""
    other.theta[:] = planner.theta
    a = planner.plan(t, state, np.random.default_rng(3))
    b = other.plan(t, state, np.random.default_rng(3))
    np.testing.assert_array_equal(planner.theta, other.theta)
    assert a.best_cost == b.best_cost


def test_acquire_samples_draw_more_until_after_the_first_contact_and_are_priced():
    """planner.acquire_samples: a plan before ``acquire_until`` after the first expected contact rolls out
    that many candidates, one after it ``num_samples``; off (None), ``num_samples`` everywhere, the same
    draws as before; a latency model prices the larger plan."""
    problem = PointMassProblem(sigma=0.4)
    planner = PredictiveSampling(num_samples=8, horizon=0.5, acquire_samples=20, acquire_until=0.2)
    off = PredictiveSampling(num_samples=8, horizon=0.5)
    problem.bind(planner)
    problem.bind(off)
    planner.problem.first_contact = off.problem.first_contact = 0.1
    sizes = count_candidates(planner)
    infos = [planner.plan(t, problem.state, np.random.default_rng(0)) for t in (0.0, 0.29, 0.3, 0.5)]
    assert sizes == [20, 20, 8, 8] == [info.samples for info in infos]
    assert [planner.samples_at(t) for t in (0.0, 0.3)] == [20, 8] and off.samples_at(0.0) == 8
    # after the window the plan is the one without the option, bit for bit (same nominal, same draws)
    assert_plans_alike(planner, off, 0.5, problem.state)
    model = ComputeLatency(sample_step_seconds=1e-4, threads=1)
    priced = PredictiveSampling(num_samples=8, horizon=0.5, acquire_samples=20, latency_model=model)
    problem.bind(priced)
    assert priced.rollouts_per_plan() == 20
    problem.engine.close()


def test_acquire_horizon_shortens_the_grasps_plans_only_and_is_priced():
    """planner.acquire_horizon: a plan in the acquire window rolls out and scores that much of the
    reference (its steps, the control points its window meets), one after it the full horizon, the plan
    without the option bit for bit; a latency model prices the dearer phase."""
    problem = PointMassProblem(sigma=0.4)
    short = PredictiveSampling(num_samples=8, horizon=0.5, acquire_until=0.2, acquire_horizon=0.2)
    off = PredictiveSampling(num_samples=8, horizon=0.5, acquire_until=0.2)
    for p in (short, off):
        problem.bind(p)
        p.problem.first_contact = 0.1
    dt = problem.model.opt.timestep
    steps, windows = [], []
    real = short.evaluate

    def evaluate(state, t, thetas):
        steps.append(short.steps)
        windows.append(len(short.problem.spline.window_indices(t, short._horizon_now)))
        return real(state, t, thetas)

    short.evaluate = evaluate
    for t in (0.0, 0.29, 0.3):
        short.plan(t, problem.state, np.random.default_rng(0))
    full, cut = round(0.5 / dt), round(0.2 / dt)
    assert steps == [cut, cut, full]
    assert windows[0] < len(off.problem.spline.window_indices(0.0, 0.5))
    assert [short.horizon_at(t) for t in (0.0, 0.3)] == [0.2, 0.5] and off.horizon_at(0.0) == 0.5
    short.evaluate = real
    assert_plans_alike(short, off, 0.5, problem.state)  # after the window: the plan without the option
    model = ComputeLatency(sample_step_seconds=1e-4, threads=1)
    dear = PredictiveSampling(
        num_samples=8, horizon=0.5, acquire_samples=40, acquire_horizon=0.2, latency_model=model
    )
    cheap = PredictiveSampling(
        num_samples=8, horizon=0.5, acquire_samples=12, acquire_horizon=0.2, latency_model=model
    )
    for p in (dear, cheap):
        problem.bind(p)
    assert dear.latency_for(dt) == model.seconds(40, cut, dt) > model.seconds(8, full, dt)
    assert cheap.latency_for(dt) == model.seconds(8, full, dt) > model.seconds(12, cut, dt)
    problem.engine.close()


def test_step_budget_cuts_the_samples_to_the_rollout_steps_a_plan_may_run():
    """planner.step_budget: a plan draws at most ``step_budget // steps`` samples (in the acquire window as
    after it) and a latency model prices the cut plan; a budget the plan fits in changes nothing,
    the same draws as without it."""
    problem = PointMassProblem(sigma=0.4)
    cut = PredictiveSampling(
        num_samples=8, horizon=0.5, acquire_samples=20, acquire_until=0.2, step_budget=600
    )
    roomy = PredictiveSampling(
        num_samples=8, horizon=0.5, acquire_samples=20, acquire_until=0.2, step_budget=10**6
    )
    off = PredictiveSampling(num_samples=8, horizon=0.5, acquire_samples=20, acquire_until=0.2)
    for p in (cut, roomy, off):
        problem.bind(p)
        p.problem.first_contact = 0.1
    per_plan = 600 // cut.steps  # between the 8 samples after the acquire window and its 20
    assert 8 < per_plan < 20
    assert [cut.samples_at(t) for t in (0.0, 0.5)] == [per_plan, 8]
    assert [roomy.samples_at(t) for t in (0.0, 0.5)] == [20, 8] == [off.samples_at(t) for t in (0.0, 0.5)]
    sizes = count_candidates(cut)
    cut.plan(0.0, problem.state, np.random.default_rng(0))
    assert sizes == [per_plan]
    assert_plans_alike(roomy, off, 0.0, problem.state)
    model = ComputeLatency(sample_step_seconds=1e-4, threads=1)
    priced = PredictiveSampling(
        num_samples=8, horizon=0.5, acquire_samples=20, step_budget=600, latency_model=model
    )
    problem.bind(priced)
    assert priced.rollouts_per_plan() == per_plan
    problem.engine.close()


def test_switch_timestep_plans_on_the_finer_model_from_after_the_first_contact(
    scene_for, late_contact_reference
):
    """planner.switch_timestep: plans before ``switch_after`` past the first expected contact are the plans
    without the option, bit for bit; from then on the planner rolls out the model stepped at the switch's
    step, on its track, and plans what a planner bound to a scene stepped there from the start plans, from
    the same nominal; a latency model prices the larger of the two phases' plans."""
    ref = late_contact_reference[0]
    coarse, fine = scene_for("apple"), scene_for("apple", "scene.planner_timestep=0.005")
    assert coarse.planner_timestep == 0.01

    def bound(scene, **options):
        planner = PredictiveSampling(num_samples=6, horizon=0.1, replan_period=0.05, nthread=1, **options)
        trial = Trial(scene, ref, PCASplineSpace(0.2), TrackingCost(), planner, 0, progress=False)
        return planner, trial

    switching, trial = bound(coarse, switch_timestep=0.005, switch_after=0.1)
    off, _ = bound(coarse)
    stepped, _ = bound(fine)
    state = trial.start_plant().state(0.0)
    first = trial.problem.first_contact
    assert first > 0.1
    before, after = first + 0.05, first + 0.1
    assert_plans_alike(switching, off, before, state)
    assert (switching.dt, switching.steps, switching.engine.model.opt.timestep) == (0.01, 10, 0.01)
    assert switching.switched_at is None
    assert_plans_alike(switching, stepped, after, state)  # it switches in this plan
    assert switching.switched_at == pytest.approx(after)
    assert (switching.dt, switching.steps, switching.engine.model.opt.timestep) == (0.005, 20, 0.005)
    assert switching.problem.track.dt == 0.005 and switching.problem.cost.track is switching.problem.track
    assert trial.problem.track.dt == 0.01  # the trial's own problem is left as it was
    assert not switching.phase(after + 1.0) and switching.switched_at == pytest.approx(after)  # once
    model = ComputeLatency(sample_step_seconds=1e-4, threads=1)
    priced, _ = bound(coarse, switch_timestep=0.005, latency_model=model)
    # the finer phase's 6 samples x 20 steps, not the first's x 10
    assert priced.latency_for(0.001) == model.seconds(6, 20, 0.001) > model.seconds(6, 10, 0.001)
    for planner in (switching, off, stepped, priced):
        planner.close()
    with pytest.raises(ConfigError, match="planner.switch_timestep = 0.0055 s is not a whole number"):
        bound(coarse, switch_timestep=0.0055)


def _switching(scene, ref, **options):
    """A small predictive-sampling planner with ``options`` and the trial that binds it to ``ref``."""
    planner = PredictiveSampling(num_samples=6, horizon=0.1, replan_period=0.05, nthread=1, **options)
    trial = Trial(scene, ref, PCASplineSpace(0.2), TrackingCost(), planner, 0, progress=False)
    return planner, trial


def test_switch_back_after_plans_on_the_scene_s_model_again_from_the_release(scene_for):
    """planner.switch_back_after: a switched planner plans its own problem on the scene's planning model
    again from that long after the reference's last expected contact on, once, as a planner that never
    switched plans from the same nominal; not before, and never where it had not switched. It needs a model
    to leave."""
    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)
    ref.contact_active[:4] = False
    ref.contact_active[8:] = False  # the reference lets go

    def bound(**options):
        return _switching(scene, ref, **options)

    planner, trial = bound(switch_timestep=0.005, switch_after=0.0, switch_back_after=0.0)
    off, _ = bound()
    assert planner.switches_back and not off.switches_back  # the record says when
    first, last = trial.problem.first_contact, trial.problem.last_contact
    assert last is not None and last > first + 0.1
    state = trial.start_plant().state(0.0)
    assert planner.phase(first) and planner.dt == 0.005
    assert not planner.phase(last - 0.05) and planner.dt == 0.005 and planner.switched_back_at is None
    assert_plans_alike(planner, off, last, state)  # it goes back in this plan
    assert planner.dt == 0.01 and planner.problem is trial.problem and planner.switched_back_at == last
    assert planner.engine.model.opt.timestep == 0.01
    assert not planner.phase(last + 0.5) and planner.dt == 0.01  # once
    unswitched, trial = bound(switch_timestep=0.005, switch_after=None, switch_back_after=0.0)
    assert not unswitched.phase(last) and unswitched.dt == 0.01 and unswitched.switched_back_at is None
    for p in (planner, off, unswitched):
        p.close()
    with pytest.raises(ConfigError, match="switch_back_after needs planner.switch_timestep"):
        PredictiveSampling(switch_back_after=0.0)


def test_switch_for_plans_on_the_scene_s_model_again_that_long_after_the_switch(scene_for):
    """planner.switch_for: a switched planner plans its own problem on the scene's planning model again from
    that long after its switch on (reference time), once, as a planner that never switched plans from the
    same nominal; not before, and never where it had not switched; the record says when. It needs a model
    to leave and cannot join planner.switch_back_after."""
    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)
    ref.contact_active[:4] = False

    def bound(**options):
        return _switching(scene, ref, **options)

    planner, trial = bound(switch_timestep=0.005, switch_after=0.1, switch_for=0.3)
    off, _ = bound()
    assert planner.switches_back  # the record says when
    first = trial.problem.first_contact
    state = trial.start_plant().state(0.0)
    assert not planner.phase(first) and planner.dt == 0.01  # its switch is 0.1 s on
    assert planner.phase(first + 0.15) and planner.dt == 0.005 and planner.switched_at == first + 0.15
    assert not planner.phase(first + 0.4) and planner.dt == 0.005  # 0.25 s after the switch: not yet
    assert planner.switched_back_at is None
    assert_plans_alike(planner, off, first + 0.45, state)  # 0.3 s after the switch: it goes back here
    assert planner.dt == 0.01 and planner.problem is trial.problem
    assert planner.switched_back_at == pytest.approx(first + 0.45)
    assert planner.engine.model.opt.timestep == 0.01
    assert not planner.phase(first + 0.8) and planner.dt == 0.01  # once
    unswitched, _ = bound(switch_timestep=0.005, switch_after=None, switch_for=0.0)
    assert not unswitched.phase(first + 0.8) and unswitched.dt == 0.01 and unswitched.switched_back_at is None
    for p in (planner, off, unswitched):
        p.close()
    with pytest.raises(ConfigError, match="switch_for needs planner.switch_timestep"):
        PredictiveSampling(switch_for=1.0)
    with pytest.raises(ConfigError, match="switch_for and planner.switch_back_after: choose one"):
        PredictiveSampling(switch_timestep=0.005, switch_for=1.0, switch_back_after=0.0)


def test_switch_error_switches_once_the_model_has_mispredicted_the_object_in_a_row(
    scene_for, late_contact_reference
):
    """planner.switch_error: from the first expected contact on, the plan whose last ``switch_count``
    predictions each missed the object by more than it switches (a miss under it, or a plan without a
    prediction, starts the count again); before the first contact no miss counts; a trial's plans pass their
    logged prediction; it needs a model to switch to and the predictions of compensate_latency."""
    ref = late_contact_reference[0]
    scene = scene_for("apple")

    def bound(**options):
        planner = PredictiveSampling(num_samples=4, horizon=0.1, replan_period=0.05, nthread=1,
                                     switch_timestep=0.005, compensate_latency=True, **options)  # fmt: skip
        trial = Trial(scene, ref, PCASplineSpace(0.2), TrackingCost(), planner, 0, progress=False)
        return planner, trial

    planner, trial = bound(switch_after=None, switch_error=0.001, switch_count=2)
    first = trial.problem.first_contact
    miss, hit = (0.002, 0.0), (0.0005, 0.0)
    assert not planner.phase(first - 0.1, miss) and not planner.phase(
        first - 0.05, miss
    )  # not before contact
    assert not planner.phase(first, miss) and not planner.phase(first + 0.05, hit)  # a hit: from 0 again
    assert not planner.phase(first + 0.1, miss) and not planner.phase(first + 0.15, (np.nan, np.nan))
    assert not planner.phase(first + 10.0)  # no time rule (switch_after None), no prediction
    assert planner.dt == 0.01
    assert not planner.phase(first + 0.2, miss) and planner.phase(first + 0.25, miss)  # two in a row
    assert planner.dt == 0.005 and not planner.phase(first + 0.3, miss)  # once
    planner.close()
    # in a trial with a latency, every plan from the second on has a prediction to check: with a
    # threshold no miss stays under, it switches at the second plan from the first contact on
    eager, trial = bound(switch_after=None, switch_error=1e-12, switch_count=1, latency=0.05)
    switched = []
    real_phase = eager.phase

    def phase(s, prediction=None):
        now = real_phase(s, prediction)
        if now:
            switched.append((s, prediction))
        return now

    eager.phase = phase
    trial.duration = first + 0.2
    log = trial.run().arrays()
    ((at, prediction),) = switched
    assert at >= first - 1e-9 and prediction[0] > 1e-12 and eager.switched_at == at
    i = int(np.flatnonzero(np.isclose(log["time"], at - 0.05))[0])  # the plan it switched at, planned ahead
    assert log["prediction_position_error"][i] == prediction[0]
    eager.close()
    for options in ({"switch_timestep": None}, {"compensate_latency": False}):
        with pytest.raises(ConfigError, match="switch_error needs planner.switch_timestep"):
            PredictiveSampling(**{"switch_timestep": 0.005, "compensate_latency": True, "switch_error": 0.001,
                                  **options})  # fmt: skip


def test_approach_reset_puts_the_committed_points_back_to_the_reference_before_the_first_contact(scene_for):
    """planner.approach_reset: at the first plan at or after that many seconds before the first expected
    contact, the committed control points whose support meets the rest of the trial go back to the
    reference's own (theta0), once; a plan before it, or the option off, leave them as they are.
    Real rollouts (one sample: the nominal, so what is committed is what the plan started from)."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    state = rest_state(scene.plant_model)
    rng = np.random.default_rng(0)
    reference = static_reference(scene, duration=1.0, frames=26)
    reference.contact_active[:] = False
    reference.contact_active[13:, 0] = True  # the first expected contact at frame 13 of 26

    def walked(approach_reset):
        problem = Problem.build(scene, reference, PCASplineSpace(0.2), TrackingCost(), 0.2, 12)
        planner = PredictiveSampling(num_samples=1, horizon=0.2, nthread=1, approach_reset=approach_reset)
        planner.bind(problem)
        planner.theta = problem.theta0 + 0.3
        return planner, problem

    planner, problem = walked(0.2)
    at = problem.first_contact - 0.2
    assert at > 0.1
    assert_resets_once_at(planner, problem, at, state, rng, problem.theta0)
    planner.close()
    planner, problem = walked(None)  # off: never
    planner.plan(problem.first_contact, state, rng)
    np.testing.assert_array_equal(planner.theta, problem.theta0 + 0.3)
    planner.close()


@pytest.fixture(scope="module")
def rising_problem(scene_for):
    """The synthetic apple's scene with a reference whose object rises 5 cm while every link expects
    contact (the guide's path), bound for a 0.5 s horizon."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=26)
    ref.object_qpos[:, 2] += np.linspace(0.0, 0.05, 26)
    return Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.5, 12)


def test_guidance_pulls_the_object_in_the_planning_model_only_and_the_last_iteration_goes_without(
    rising_problem,
):
    """planner.guidance: the guided model's stiffest iteration holds the object near the reference's pose
    where the unguided one lets it go; the weld softens over the iterations and is off in the last, whose
    rollouts are the planning model's own (to rounding); the plan's nominal cost is the unguided one's, so
    the committed sample never scores worse than it."""
    from contactmpc.control.guidance import ObjectGuidance

    problem = rising_problem
    scene = problem.scene
    guided = PredictiveSampling(
        num_samples=4, horizon=0.5, nthread=1, iterations=3, guidance=ObjectGuidance()
    )
    plain = PredictiveSampling(num_samples=4, horizon=0.5, nthread=1, iterations=3)
    guided.bind(problem)
    plain.bind(problem)
    g = guided.guidance
    np.testing.assert_allclose(g.weights(3), [1.0, 0.5, 0.0])
    assert [float(m.eq_solref[g.weld, 0]) for m in g.models[:2]] == [0.05, 0.1]
    state = rest_state(scene.plant_model)
    t = 0.3
    ctrl = guided.controls(guided.theta[None], guided.basis(t))
    window = problem.track.window(t, guided.steps)
    target = problem.track.object_qpos[window.start + guided.steps - 1, :3]
    obj = 1 + scene.index.object_qpos[:3]  # (the state's first entry is the time)
    end = {}
    for i, w in enumerate(g.weights(3)):
        states, _, _ = guided.engine.run(state, ctrl, [g.models[i]], g.inputs(window, guided.steps, w))
        end[i] = states[0, -1].copy()  # (the engine reuses its output buffers)
    unguided, _, _ = plain.engine.run(state, ctrl)
    assert np.linalg.norm(end[0][obj] - target) < 0.01  # held within 1 cm of the reference
    assert np.linalg.norm(unguided[0, -1][obj] - target) > 0.1  # without it, the object goes elsewhere
    # the last iteration: the model's own dynamics (another model, so equal to rounding, not bit for bit)
    np.testing.assert_allclose(end[2], unguided[0, -1], rtol=0, atol=1e-6)
    info = guided.plan(t, state, np.random.default_rng(0))
    assert info.iterations == 3 and info.best_cost <= info.nominal_cost
    guided.close()
    plain.close()


def test_guidance_refuses_what_it_cannot_do(rising_problem, scene_for):
    """One iteration (nothing would plan unguided), a robust ensemble beside it, or an object without one
    free body: a ConfigError naming the problem."""
    from contactmpc.control.guidance import ObjectGuidance
    from contactmpc.control.robust import ModelEnsemble

    with pytest.raises(ConfigError, match="iterations >= 2"):
        PredictiveSampling(num_samples=2, horizon=0.5, nthread=1, guidance=ObjectGuidance()).bind(
            rising_problem
        )
    both = PredictiveSampling(
        num_samples=2, horizon=0.5, nthread=1, iterations=2, guidance=ObjectGuidance(), robust=ModelEnsemble()
    )
    with pytest.raises(ConfigError, match="choose one"):
        both.bind(rising_problem)
    door = scene_for("doorknob")
    with pytest.raises(ConfigError, match="0 free object bodies"):
        ObjectGuidance().bind(door, None, 2)
    with pytest.raises(ConfigError):
        ObjectGuidance(during="sometimes")


def test_guidance_runs_in_a_trial(tmp_path, late_contact_reference):
    """guidance=object composes and runs a trial (the synthetic apple, two iterations); the record says so."""
    overrides = ["task=apple", f"task.reference_path={late_contact_reference[1]}", *TINY]
    overrides += ["job.progress=false", "duration=0.3", "guidance=object", "planner.iterations=2"]
    record = json.loads(run_job(overrides, tmp_path).read_text())
    assert record["status"] == "ok"
    assert record["config"]["planner"]["guidance"]["_target_"] == "contactmpc.control.guidance.ObjectGuidance"


def test_pacing_holds_the_reference_in_the_span_while_the_object_lags_up_to_its_budget(scene_for):
    """planner.pace_lag: the reference's clock holds (rate 0) from where a plan takes effect while the
    reference expects contact and the object is more than pace_lag from the reference's; it runs on once the
    reference is pace_budget behind, outside the span, and with the object where the reference has it. Off:
    the reference's time is control time itself."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)
    ref.contact_active[:4] = False  # first expected contact at 0.4 s of the demonstration: 0.8 s of control
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 12)
    off = PredictiveSampling(num_samples=2, horizon=0.2, nthread=1)
    off.bind(problem)
    assert off.reference_time(1.234) == 1.234
    planner = PredictiveSampling(num_samples=2, horizon=0.2, nthread=1, pace_lag=0.02, pace_budget=0.5)
    planner.bind(problem)
    m = scene.planner_model
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    at_rest = problem.track.object_qpos[0]
    lagging = at_rest.copy()
    lagging[2] -= 0.05  # 5 cm below the reference's object

    def at(qo):
        state[1 + scene.index.object_qpos] = qo
        return state

    planner.pace(0.5, 0.5, at(lagging))  # before the first expected contact: runs on
    assert planner.reference_time(0.7) == pytest.approx(0.7)
    planner.pace(1.0, 1.0, at(at_rest))  # in the span, the object where the reference has it: runs on
    assert planner.reference_time(1.2) == pytest.approx(1.2)
    planner.pace(1.2, 1.2, at(lagging))  # lagging: held from 1.2 on, for the budget's 0.5 s at most
    np.testing.assert_allclose(planner.reference_time(np.array([1.1, 1.2, 1.5, 1.7, 2.0])), [1.2] * 4 + [1.5])
    planner.pace(1.4, 1.2, at(at_rest))  # caught up: runs on from where it is, 0.2 s behind
    assert planner.reference_time(1.9) == pytest.approx(1.7)
    planner.pace(1.6, 1.4, at(lagging))  # held again, for the 0.3 s of budget left
    assert planner.reference_time(1.9) == pytest.approx(1.4)
    assert planner.reference_time(2.5) == pytest.approx(2.0)
    planner.pace(2.5, 2.0, at(lagging))  # the budget spent: runs on
    assert planner.reference_time(2.7) == pytest.approx(2.2)
    planner.bind(problem)  # a new trial's: the clock starts with control time again
    assert planner.reference_time(2.7) == pytest.approx(2.7)
    with pytest.raises(ConfigError, match="pace_rate"):
        PredictiveSampling(pace_lag=0.02, pace_rate=1.0)
    planner.close()
    off.close()


def test_pace_retry_rewinds_to_before_the_first_contact_once_the_object_has_lain_lost(scene_for):
    """planner.pace_retry: once the free object has lain that long not lifted while the reference lifts it,
    off the reference and with at most pace_retry_fingers fingers on it (in the span), and the reference's
    clock is not held for it (its wait spent), a paced reference's clock runs backwards at pace_retry_rate
    to pace_retry_to before the first expected contact (the committed control points from there on the
    reference's own, the carry's shift with them; with pace_retry_follow the wrist moved across the table to
    the object), then on with control time; a rewind that does not fit what is left of pace_retry_budget is
    not made; an object lifted, held by more fingers, or fallen over is never rewound for. Off: the clock of
    a planner without the option."""
    scene, problem, at = _paced_problem(scene_for)
    first, track = problem.first_contact, problem.track
    assert first == pytest.approx(0.4)
    track.object_qpos[track.index(0.42) :, 2] += 0.05  # the reference lifts the object 5 cm from 0.42 s
    kwargs = dict(num_samples=2, horizon=0.2, nthread=1, pace_lag=0.02, pace_budget=0.2)
    retry = dict(pace_retry=0.3, pace_retry_to=0.1, pace_retry_rate=2.0)

    def bound(**options):
        planner = PredictiveSampling(**{**kwargs, **options})
        planner.bind(problem)
        return planner

    planner, off = bound(**retry, pace_retry_budget=1.4), bound()
    rest = problem.track.object_qpos[0]
    on_table = rest.copy()
    on_table[0] += 0.05  # pushed 5 cm across the table: on it, 5 cm from the reference's
    lifted = rest.copy()
    lifted[[0, 2]] += 0.05, 0.03  # 3 cm above where it starts, 5.4 cm from the reference's
    assert planner.fingers_touching(at(on_table)) <= 1  # (the hand at its zero configuration: lost)
    planner.theta[:] += 1.0  # committed control points other than the reference's own
    planner._carry[:] = 0.01  # and a carry's shift in them
    planner.pace(0.3, 0.3, at(on_table))  # before the first expected contact: never lost
    off.pace(0.3, 0.3, at(on_table))
    for t in (0.8, 0.9, 1.1):  # lost from 0.8 s, held (as without the option) until its 0.2 s are spent
        planner.pace(t, 0.8, at(on_table))
        off.pace(t, 0.8, at(on_table))
        assert planner.clock == off.clock and planner.reference_time(1.0) == 0.8
    planner.pace(1.4, 0.8, at(on_table))  # lost 0.3 s since the wait: back from 1.2 s to 0.3 s at 2x, on
    np.testing.assert_allclose(
        planner.reference_time(np.array([1.4, 1.5, 1.85, 2.0])), [1.2, 1.0, 0.3, 0.45], atol=1e-12
    )
    assert planner.retried_at == [1.4] and planner.rewinding(1.5) and not planner.waiting(1.5)
    reset = problem.spline.window_indices(0.3, problem.spline.domain[1] - 0.3)
    np.testing.assert_array_equal(planner.theta[reset], problem.theta0[reset])
    assert np.all(planner.theta[: reset[0]] == problem.theta0[: reset[0]] + 1.0)
    assert not planner._carry.any()  # (the carry's shift goes with the committed points)
    clock = planner.clock
    planner.pace(1.5, 1.0, at(on_table))  # a rewind runs its course
    assert planner.clock == clock
    planner.pace(2.0, 0.45, at(on_table))  # past the reference's lift again, still lost (its wait spent) ...
    planner.pace(2.3, 0.75, at(on_table))  # ... 0.3 s: a second rewind would cost 0.675 s, 0.05 left
    assert planner.retried_at == [1.4] and planner.reference_time(2.4) == pytest.approx(0.85)
    wide = bound(**retry, pace_retry_budget=2.1)  # 2.025 s for both fits
    for t, s in ((0.8, 0.8), (1.1, 0.8), (1.4, 0.8), (2.0, 0.45), (2.3, 0.75)):
        wide.pace(t, s, at(on_table))
    assert wide.retried_at == [1.4, 2.3]
    patient = bound(**retry, pace_budget=1.0)  # the reference's own wait first, and not counted
    for t in (0.8, 1.1, 1.5):
        patient.pace(t, 0.8, at(on_table))
    assert patient.retried_at == [] and patient.waiting(1.5)
    patient.pace(1.9, 0.8, at(on_table))  # its 1 s spent at 1.8 s: lost since, not long enough
    assert patient.retried_at == []
    patient.pace(2.2, 0.8, at(on_table))  # lost 0.3 s since the wait
    assert patient.retried_at == [2.2]
    waiter, held = bound(**retry), bound(**retry)  # lifted, or in a grasp of two fingers: never rewound
    held.fingers_touching = lambda state: 2
    for t in (0.8, 1.1, 1.4, 1.7):
        waiter.pace(t, 0.8, at(lifted))
        held.pace(t, 0.8, at(on_table))
    assert waiter.retried_at == [] == held.retried_at
    track.object_qpos[track.index(0.42) :, 2] -= 0.05  # a reference that never lifts it: not left behind
    down = bound(**retry)
    for t in (0.8, 1.1, 1.4, 1.7):
        down.pace(t, 0.8, at(on_table))
    assert down.retried_at == []
    track.object_qpos[track.index(0.42) :, 2] += 0.05
    follow = bound(**retry, pace_retry_follow=(0.2, 0.4))  # the wrist to where the object lies
    for t in (0.8, 1.1, 1.4):
        follow.pace(t, 0.8, at(on_table))
    assert follow.retried_at == [1.4]
    weight = np.clip((first + 0.4 - problem.spline.greville(reset)) / 0.2, 0.0, 1.0)
    moved = follow.theta[reset] - problem.theta0[reset]
    np.testing.assert_allclose(moved[:, 0], 0.05 * weight, atol=1e-12)  # the object's offset, faded out
    assert weight[0] == 1.0 and weight[-1] == 0.0 and not moved[:, 1:].any()
    tipped = on_table.copy()
    tipped[3:7] = np.cos(0.3), np.sin(0.3), 0.0, 0.0  # on its side (tilted 0.6 rad): not tried again
    upright = bound(**retry, pace_retry_tilt=0.5)
    for t in (0.8, 1.1, 1.4):
        upright.pace(t, 0.8, at(tipped))
    assert upright.retried_at == []
    upright.pace(1.7, 0.8, at(on_table))
    upright.pace(2.0, 0.8, at(on_table))
    assert upright.retried_at == [2.0]
    waiter.bind(problem)  # a new trial's: no rewind made
    assert waiter.retried_at == [] and waiter.reference_time(2.0) == 2.0
    with pytest.raises(ConfigError, match="pace_retry"):
        PredictiveSampling(pace_retry=1.0)
    with pytest.raises(ConfigError, match="pace_retry"):
        PredictiveSampling(pace_lag=0.02, pace_window=(-0.4, 0.0), pace_retry=1.0)
    with pytest.raises(ConfigError, match="pace_retry_follow"):
        PredictiveSampling(pace_lag=0.02, pace_retry=1.0, pace_retry_follow=(0.4, 0.2))
    for p in (planner, off, wide, patient, waiter, held, down, follow, upright):
        p.close()


def _paced_problem(scene_for, release=None):
    """The apple's problem on a static reference expecting contact from 0.2 to 0.7 s of its demonstration
    (letting go on the ``release`` schedule), and a function that puts an object configuration into a
    full-physics state of the planning model."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)
    ref.contact_active[:2] = False
    ref.contact_active[8:] = False
    problem = Problem.build(scene, ref, PCASplineSpace(0.2, release=release), TrackingCost(), 0.2, 12)
    state = np.zeros(mujoco.mj_stateSize(scene.planner_model, mujoco.mjtState.mjSTATE_FULLPHYSICS))

    def at(qo):
        state[1 + scene.index.object_qpos] = qo
        return state

    return scene, problem, at


def test_a_paced_release_waits_only_in_its_window_for_the_object_placed_and_upright(scene_for):
    """planner.pace_window / pace_angle (pacing=release): the reference's clock holds only while its time
    lies in the window before the last expected contact, and there also while the object is turned more
    than pace_angle from the reference's (its position where the reference has it); a window that is not
    (start < end) is refused in one line."""
    scene, problem, at = _paced_problem(scene_for)
    first, last = problem.first_contact, problem.last_contact
    assert first is not None and last is not None and first < last - 0.5
    planner = PredictiveSampling(
        num_samples=2, horizon=0.2, nthread=1, pace_lag=0.02, pace_angle=0.3, pace_window=(-0.4, 0.0)
    )
    planner.bind(problem)
    placed = problem.track.object_qpos[0]
    lagging, turned = placed.copy(), placed.copy()
    lagging[2] -= 0.05
    q = scene.task.layout.quat_index
    turned[q : q + 4] = [np.cos(0.25), np.sin(0.25), 0.0, 0.0]  # 0.5 rad about x, in place
    s = first + 0.1  # in the span, before the window: runs on however far the object lags
    planner.pace(s, s, at(lagging))
    assert planner.reference_time(s + 0.1) == pytest.approx(s + 0.1)
    s = last - 0.3  # in the window, placed and upright: runs on
    planner.pace(s, s, at(placed))
    assert planner.reference_time(s + 0.1) == pytest.approx(s + 0.1)
    planner.pace(s, s, at(turned))  # turned 0.5 rad > 0.3, in place: held
    assert planner.reference_time(s + 0.1) == pytest.approx(s)
    planner.pace(s + 0.1, s, at(placed))  # set right: runs on, 0.1 s behind
    assert planner.reference_time(s + 0.2) == pytest.approx(s + 0.1)
    upright_only = PredictiveSampling(
        num_samples=2, horizon=0.2, nthread=1, pace_lag=0.02, pace_window=(-0.4, 0.0)
    )
    upright_only.bind(problem)
    upright_only.pace(s, s, at(turned))  # without pace_angle the position alone: runs on
    assert upright_only.reference_time(s + 0.1) == pytest.approx(s + 0.1)
    s = last + 0.05  # past the last contact: runs on
    upright_only.pace(s, s, at(lagging))
    assert upright_only.reference_time(s + 0.1) == pytest.approx(s + 0.1)
    with pytest.raises(ConfigError, match="pace_window"):
        PredictiveSampling(pace_lag=0.02, pace_window=(0.0, -0.5))
    planner.close()
    upright_only.close()


def test_pace_grasp_holds_the_grasp_for_a_lagging_object_on_a_budget_of_its_own(scene_for):
    """planner.pace_grasp (pacing=hold_release_turn): before the release's window the reference's clock holds
    from the first expected contact while the object is more than pace_grasp from the reference's, up to
    pace_budget; the window's wait then has its whole budget again; pace_turn turns the wrist only in the
    window's wait; refused without a window."""
    scene, problem, at = _paced_problem(scene_for)
    first, last = problem.first_contact, problem.last_contact
    kwargs = dict(num_samples=2, horizon=0.2, nthread=1, pace_lag=0.02, pace_window=(-0.2, 0.0))
    planner = PredictiveSampling(**kwargs, pace_grasp=0.01, pace_budget=0.3, pace_turn=1.0)
    planner.bind(problem)
    placed = problem.track.object_qpos[0]
    lagging, slipped = placed.copy(), placed.copy()
    lagging[2] -= 0.05
    slipped[2] -= 0.015  # past pace_grasp (1 cm), within pace_lag (2 cm), and turned
    q = scene.task.layout.quat_index
    slipped[q : q + 4] = [np.cos(0.1), np.sin(0.1), 0.0, 0.0]  # 0.2 rad about x

    planner.pace(first - 0.1, first - 0.1, at(lagging))  # before the first contact: runs on
    assert planner.reference_time(first) == pytest.approx(first)
    s = first + 0.05  # in the grasp, 1.5 cm off: held
    planner.pace(s, s, at(slipped))
    assert planner.waiting(s + 0.1) and planner.reference_time(s + 0.1) == pytest.approx(s)
    assert not planner.carry(s + 0.1, s, at(slipped)).any()  # set down and waiting, but not the window's wait
    planner.pace(s + 0.5, s, at(slipped))  # the grasp's budget (0.3 s) spent: runs on, 0.3 s behind
    assert not planner.waiting(s + 0.6) and planner.reference_time(s + 0.6) == pytest.approx(s + 0.3)
    w = last - 0.1  # in the window: its own budget, whole
    planner.pace(w + 0.3, w, at(lagging))
    assert planner.waiting(w + 0.4) and planner.reference_time(w + 0.5) == pytest.approx(w)
    planner.pace(w + 0.5, w, at(lagging))  # held until its own 0.3 s are spent: 0.6 s behind in all
    assert planner.reference_time(w + 0.6) == pytest.approx(w)
    assert planner.reference_time(w + 0.8) == pytest.approx(w + 0.2)
    alone = PredictiveSampling(**kwargs, pace_budget=0.3)  # without pace_grasp: the grasp runs on
    alone.bind(problem)
    alone.pace(s, s, at(lagging))
    assert alone.reference_time(s + 0.1) == pytest.approx(s + 0.1)
    with pytest.raises(ConfigError, match="pace_grasp"):
        PredictiveSampling(pace_lag=0.02, pace_grasp=0.01)
    planner.close()
    alone.close()


def assert_unpaced(base, paced) -> None:
    """The paced trial's series (beside the record ``paced``) is the unpaced one's (``base``) bit for bit (the
    plans' compute times aside), and logs the reference's time as the control time's."""
    a, b = np.load(base.parent / "timeseries.npz"), np.load(paced.parent / "timeseries.npz")
    assert set(b.files) - set(a.files) == {"reference_time"}
    np.testing.assert_array_equal(b["reference_time"], b["time"])
    for key in a.files:
        if key != "plan_seconds":
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_acquire_waiting_keeps_the_grasps_samples_while_the_paced_reference_waits(scene_for):
    """planner.acquire_waiting: after the acquire window, a plan that takes effect while the paced
    reference's clock is held draws acquire_samples; once the clock runs on, num_samples again. Off, the
    held plan draws num_samples; in the window both draw acquire_samples. Without a paced reference (or
    without acquire_samples) it is refused."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)
    ref.contact_active[:4] = False  # first expected contact at 0.8 s of control time
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 12)
    args = dict(num_samples=4, horizon=0.2, nthread=1, acquire_samples=9, acquire_until=0.1, pace_lag=0.02)
    on, off = PredictiveSampling(**args, acquire_waiting=True), PredictiveSampling(**args)
    m = scene.planner_model
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    state[1 : 1 + m.nq] = m.qpos0
    at_rest = problem.track.object_qpos[0]
    lagging = at_rest.copy()
    lagging[2] -= 0.05  # 5 cm below the reference's object: the clock holds

    def at(qo):
        state[1 + scene.index.object_qpos] = qo
        return state.copy()

    for planner in (on, off):
        planner.bind(problem)
    # (control time, the object, samples on, samples off): in the window, held after it, running after it
    for k, (t, qo, want_on, want_off) in enumerate(
        ((0.85, at_rest, 9, 9), (1.2, lagging, 9, 4), (1.3, lagging, 9, 4), (1.4, at_rest, 4, 4))
    ):
        got_on = on.plan(t, at(qo), np.random.default_rng(k))
        got_off = off.plan(t, at(qo), np.random.default_rng(k))
        assert (got_on.samples, got_off.samples) == (want_on, want_off), t
        assert on.waiting(t) == off.waiting(t) == (qo is lagging), t  # the same clock either way
    for planner in (on, off):
        planner.close()
    with pytest.raises(ConfigError, match="acquire_waiting.*pace_lag"):
        PredictiveSampling(acquire_samples=9, acquire_waiting=True)
    with pytest.raises(ConfigError, match="acquire_waiting.*acquire_samples"):
        PredictiveSampling(pace_lag=0.02, acquire_waiting=True)


def test_acquire_error_draws_the_grasps_samples_while_the_object_is_off_the_reference(scene_for):
    """planner.acquire_error: after the acquire window and before the last expected contact, a plan from a
    state whose free object is more than its position (or rotation) off the reference's draws
    acquire_samples and is counted; one whose object is back draws num_samples, as every plan does off.
    Past the last expected contact it does not act. Without acquire_samples, or with a bad pair, it is
    refused."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)
    ref.contact_active[:4] = False  # first expected contact at 0.8 s of control time
    ref.contact_active[9:] = False  # the last at 1.8 s
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 12)
    args = dict(num_samples=4, horizon=0.2, nthread=1, acquire_samples=9, acquire_until=0.1)
    on, off = PredictiveSampling(**args, acquire_error=(0.02, 0.3)), PredictiveSampling(**args)
    m = scene.planner_model
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    state[1 : 1 + m.nq] = m.qpos0
    at_rest = problem.track.object_qpos[0]
    c = scene.task.layout.free_columns[0]
    slipped = at_rest.copy()
    slipped[c + 2] -= 0.03  # 3 cm off the reference's object
    turned = at_rest.copy()
    turned[c + 3 : c + 7] = [np.cos(0.25), np.sin(0.25), 0.0, 0.0]  # turned 0.5 rad about x

    def at(qo):
        state[1 + scene.index.object_qpos] = qo
        return state.copy()

    for planner in (on, off):
        planner.bind(problem)
    # (control time, the object, samples on): in the window, off after it, back, turned, past the span
    cases = ((0.85, at_rest, 9), (1.2, slipped, 9), (1.4, at_rest, 4), (1.6, turned, 9), (1.9, slipped, 4))
    for k, (t, qo, want_on) in enumerate(cases):
        got_on = on.plan(t, at(qo), np.random.default_rng(k))
        got_off = off.plan(t, at(qo), np.random.default_rng(k))
        assert (got_on.samples, got_off.samples) == (want_on, 9 if t < 0.9 else 4), t
    assert on.error_plans == 2 and off.error_plans == 0
    on.bind(problem)
    assert on.error_plans == 0  # counted per trial
    for planner in (on, off):
        planner.close()
    with pytest.raises(ConfigError, match="acquire_error.*acquire_samples"):
        PredictiveSampling(acquire_error=(0.02, 0.3))
    with pytest.raises(ConfigError, match="acquire_error must be"):
        PredictiveSampling(acquire_samples=9, acquire_error=(0.02, 0.0))


def test_a_paced_trial_waits_for_the_object_and_off_is_the_trial_of_before(tmp_path, late_contact_reference):
    """pacing=hold on a reference whose object rises while the tiny planner cannot lift it: the reference's
    clock falls behind only after the first expected contact, by at most the budget, the trial runs the
    budget longer, and the log reads the reference at the reference's time; planner.pace_turn and
    effort=acquire_waiting run with it. With no budget it never waits: the trial of pacing=none, bit for
    bit."""
    overrides = late_apple(late_contact_reference)
    base = run_job(overrides, tmp_path / "off")
    paced = run_job(
        overrides + ["pacing=hold", "planner.pace_lag=0.01", "planner.pace_budget=0.3"], tmp_path / "on"
    )
    record = json.loads(paced.read_text())
    assert record["status"] == "ok" and record["config"]["planner"]["pace_lag"] == 0.01
    assert record["simulated_seconds"] == pytest.approx(
        json.loads(base.read_text())["simulated_seconds"] + 0.3
    )
    series = np.load(paced.parent / "timeseries.npz")
    behind = series["time"] - series["reference_time"]
    assert (np.diff(series["reference_time"]) >= -1e-12).all() and (np.diff(behind) >= -1e-12).all()
    assert behind.max() == pytest.approx(0.3, abs=1e-9)  # the object never rises: the whole budget
    first = record["contact_span_start"]
    assert not behind[series["time"] < first].any() and behind[series["time"] > first + 0.3].all()
    held = np.flatnonzero(np.diff(series["reference_time"]) == 0)
    np.testing.assert_array_equal(
        series["expected_object_qpos"][held], series["expected_object_qpos"][held + 1]
    )
    turn = ["pacing=hold", "planner.pace_lag=0.01", "planner.pace_budget=0.3", "planner.pace_turn=1.0"]
    turned = json.loads(run_job(overrides + turn, tmp_path / "turn").read_text())  # (turns while it waits)
    assert turned["status"] == "ok" and turned["config"]["planner"]["pace_turn"] == 1.0
    never = run_job(overrides + ["pacing=hold", "planner.pace_budget=0"], tmp_path / "never")
    assert_unpaced(base, never)
    # the grasp's 6 samples until 0.05 s after the first expected contact, and (on) while the reference waits
    # (2.5 cm behind, from 0.2 s after it: past the window); off, effort=acquire's trial bit for bit
    hold = ["pacing=hold", "planner.pace_lag=0.025", "planner.pace_budget=0.3", "planner.acquire_samples=6"]
    hold += ["planner.acquire_until=0.05"]
    waiting = run_job(overrides + hold + ["effort=acquire_waiting"], tmp_path / "waiting")
    record = json.loads(waiting.read_text())
    assert record["status"] == "ok" and record["config"]["planner"]["acquire_waiting"] is True
    acquire = run_job(overrides + hold + ["effort=acquire"], tmp_path / "acquire")
    off = ["effort=acquire_waiting", "planner.acquire_waiting=false"]
    assert_same_series(acquire, run_job(overrides + hold + off, tmp_path / "off_waiting"))  # bit for bit


def test_pacing_an_object_on_joints_is_the_unpaced_trial(tmp_path, reference_files, scene_for):
    """pacing=release_turn on the doorknob, whose object has no free body to wait for: the reference never
    waits and the trial runs no longer: pacing=none's trial bit for bit (its log adds the reference's time,
    the control time's); so is pacing=lift with effort=acquire_waiting effort=acquire's, and pacing=lift_retry
    with effort=acquire_error (nothing tried again, no plan given more samples)."""
    assert not scene_for("doorknob").task.layout.free_columns
    overrides = ["task=doorknob", f"task.reference_path={reference_files['doorknob']}", *TINY]
    overrides += ["job.progress=false"]
    base = run_job(overrides, tmp_path / "off")
    paced = run_job(overrides + ["pacing=release_turn"], tmp_path / "on")
    off, on = json.loads(base.read_text()), json.loads(paced.read_text())
    assert on["status"] == "ok" and on["config"]["planner"]["pace_turn"] == 1.0
    assert on["simulated_seconds"] == off["simulated_seconds"] and on["num_plans"] == off["num_plans"]
    assert_unpaced(base, paced)
    few = "planner.acquire_samples=4"  # (the grasp's samples kept while it waits)
    base = run_job(overrides + ["effort=acquire", few], tmp_path / "acquire")
    waiting = run_job(overrides + ["pacing=lift", "effort=acquire_waiting", few], tmp_path / "waiting")
    assert json.loads(waiting.read_text())["config"]["planner"]["acquire_waiting"] is True
    assert_unpaced(base, waiting)
    retry = run_job(overrides + ["pacing=lift_retry", "effort=acquire_error", few], tmp_path / "retry")
    record = json.loads(retry.read_text())
    assert record["retry_times"] == [] and record["error_plans"] == 0
    assert record["simulated_seconds"] == off["simulated_seconds"]  # (no retry budget: nothing to retry)
    assert_unpaced(base, retry)


def test_a_paced_release_waits_before_the_last_contact_only(tmp_path, scene_for):
    """pacing=release on a reference whose object rises while the tiny planner cannot lift it, and which lets
    go: the reference's clock falls behind only where its time lies in the 0.5 s before the last expected
    contact, by at most the budget, and the trial runs the budget longer; with the grasp paced too
    (pacing=hold_release_turn) it falls behind there as well, by a budget of its own, and the trial runs
    twice the budget longer."""
    ref = static_reference(scene_for("apple"), duration=1.0, frames=11)
    ref.object_qpos[:, 2] += np.linspace(0.0, 0.05, 11)
    ref.contact_active[:2] = False
    ref.contact_active[8:] = False
    path = str(ref.save(tmp_path / "apple.npz"))
    overrides = ["task=apple", f"task.reference_path={path}", *TINY, "job.progress=false"]
    paced = run_job(overrides + ["pacing=release", "planner.pace_budget=0.3"], tmp_path / "on")
    record = json.loads(paced.read_text())
    assert record["status"] == "ok" and record["config"]["planner"]["pace_window"] == [-0.5, 0.0]
    series = np.load(paced.parent / "timeseries.npz")
    t, s = series["time"], series["reference_time"]
    behind = t - s
    assert behind.max() == pytest.approx(0.3, abs=1e-9)  # the object never rises: the whole budget
    # the last expected contact on the reference's clock (the record's span end is in control time, after
    # the wait; within one of the reference's frames, 0.2 s of control time here)
    last = record["contact_span_end"] - behind.max()
    held = np.flatnonzero(np.diff(s) == 0)
    assert held.size and (s[held] >= last - 0.5 - 0.2).all() and (s[held] < last).all()
    assert not behind[s < last - 0.7].any()
    both = ["pacing=hold_release_turn", "planner.pace_budget=0.3", "planner.pace_grasp=0.005"]
    both = run_job(overrides + both + ["planner.pace_lag=0.01"], tmp_path / "both")
    record, base = json.loads(both.read_text()), record  # the grasp waits too, on a budget of its own
    assert record["status"] == "ok" and record["config"]["planner"]["pace_grasp"] == 0.005
    assert record["simulated_seconds"] == pytest.approx(base["simulated_seconds"] + 0.3)
    series = np.load(both.parent / "timeseries.npz")
    behind = series["time"] - series["reference_time"]
    assert behind.max() == pytest.approx(0.6, abs=1e-9)  # 0.3 s in the grasp, 0.3 s in the window
    assert behind[series["reference_time"] < last - 0.7].max() == pytest.approx(0.3, abs=1e-9)


def test_carry_shifts_the_wrist_by_the_carried_objects_slip_and_keeps_the_shift(scene_for):
    """planner.carry_gain: a plan shifts the committed wrist translation from its window on by gain x the time
    since the last plan x (the reference's object position - the object's), only while both are lifted
    more than carry_lift; at most carry_limit in all. Off: no shift."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)
    ref.object_qpos[:, 2] += np.linspace(0.0, 0.1, 11)  # lifted 10 cm over the demonstration
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 12)
    m = scene.planner_model
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    track = problem.track

    def at(s, offset):
        state[1 + scene.index.object_qpos] = track.object_qpos[track.index(s)]
        state[1 + scene.index.object_qpos[:3]] += offset
        return state

    planner = PredictiveSampling(num_samples=2, horizon=0.2, nthread=1, replan_period=0.1, carry_gain=2.0)
    planner.bind(problem)
    theta = planner.theta.copy()
    slip = np.array([0.01, -0.02, 0.0])  # the object 1 cm along x and -2 cm along y off the reference's
    assert not planner.carry(0.1, 0.1, at(0.1, slip)).any()  # not yet 2 cm up: no shift
    np.testing.assert_array_equal(planner.theta, theta)
    step = planner.carry(1.6, 1.6, at(1.6, slip))  # carried: 2/s x 1.5 s (capped at 0.5 s) x -slip
    np.testing.assert_allclose(step[:3], -2.0 * 0.5 * slip)
    assert not step[3:].any()  # (carry_turn 0: the hinges stay)
    first = problem.spline.window_indices(1.6, 0.2)[0]
    shifted = planner.theta[first:, :3] - theta[first:, :3]
    np.testing.assert_allclose(shifted, np.tile(step[:3], (12 - first, 1)))
    np.testing.assert_array_equal(planner.theta[:first], theta[:first])
    np.testing.assert_array_equal(planner.theta[:, 3:], theta[:, 3:])
    planner.carry_limit = 0.03
    planner.carry(1.7, 1.7, at(1.7, 10 * slip))  # a big slip: the shift stops at the limit
    assert np.linalg.norm(planner._carry) == pytest.approx(0.03)
    planner.close()
    off = PredictiveSampling(num_samples=2, horizon=0.2, nthread=1)
    off.bind(problem)
    assert off.carry_gain == 0.0 and not off._carry.any()
    off.close()


def test_carry_waits_until_the_object_has_been_carried_for_carry_hold(scene_for):
    """planner.carry_hold: no shift until the object (and the reference's) have been lifted more than
    carry_lift for carry_hold seconds without a break; a break (the object back down) starts the wait
    again. At 0, the same shift as without it."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    ref = static_reference(scene, duration=3.0, frames=31)
    ref.object_qpos[1:, 2] += 0.1  # the reference's object 10 cm up from 0.1 s on
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 20)
    m = scene.planner_model
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    track, slip = problem.track, np.array([0.01, -0.02, 0.0])

    def at(s, lifted=True):
        state[1 + scene.index.object_qpos] = track.object_qpos[track.index(s)]
        state[1 + scene.index.object_qpos[:3]] += slip
        if not lifted:
            state[1 + scene.index.object_qpos[2]] -= 0.1
        return state

    held = PredictiveSampling(
        num_samples=2, horizon=0.2, nthread=1, replan_period=0.1, carry_gain=1.0, carry_hold=0.5
    )
    held.bind(problem)
    assert not held.carry(0.2, 0.2, at(0.2)).any()  # carried from 0.2 s on
    assert not held.carry(0.6, 0.6, at(0.6)).any()  # 0.4 s: not yet
    assert held.carry(0.7, 0.7, at(0.7)).any()  # 0.5 s: the grasp has held
    shift = held._carry.copy()
    assert not held.carry(0.8, 0.8, at(0.8, lifted=False)).any()  # set down: the wait starts again
    assert not held.carry(0.9, 0.9, at(0.9)).any()
    assert not held.carry(1.3, 1.3, at(1.3)).any()
    assert held.carry(1.4, 1.4, at(1.4)).any()
    np.testing.assert_allclose(held._carry[:3], 2 * shift[:3])  # (the shift kept through the break)
    held.close()
    for hold in (0.0, None):
        kwargs = {} if hold is None else {"carry_hold": hold}
        planner = PredictiveSampling(
            num_samples=2, horizon=0.2, nthread=1, replan_period=0.1, carry_gain=1.0, **kwargs
        )
        planner.bind(problem)
        np.testing.assert_allclose(planner.carry(0.2, 0.2, at(0.2))[:3], -0.1 * slip)
        planner.close()


def test_switch_back_held_plans_on_the_scene_s_model_again_once_the_grasp_has_held(scene_for):
    """planner.switch_back_held: a switched planner goes back to its own problem on the scene's planning
    model at the plan at which the carry's hold is reached, once (a later break does not switch again); one
    that has not switched by then never does. It needs a model to leave and the carry's signal."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    ref = static_reference(scene, duration=3.0, frames=31)
    ref.object_qpos[1:, 2] += 0.1  # the reference's object 10 cm up from 0.1 s on
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 20)
    assert problem.first_contact == 0.0
    state = np.zeros(mujoco.mj_stateSize(scene.planner_model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    track = problem.track

    def at(s, lifted=True):
        state[1 + scene.index.object_qpos] = track.object_qpos[track.index(s)]
        if not lifted:
            state[1 + scene.index.object_qpos[2]] -= 0.1
        return state

    def planner(switch_after):
        p = PredictiveSampling(
            num_samples=2, horizon=0.2, nthread=1, replan_period=0.1, carry_gain=1.0, carry_hold=0.5,
            switch_timestep=0.005, switch_after=switch_after, switch_back_held=True,
        )  # fmt: skip
        p.bind(problem)
        return p

    def plan(p, s, lifted=True):
        p.carry(s, s, at(s, lifted))
        return p.phase(s)

    early = planner(0.0)
    assert early.switches_back  # the record says when
    assert plan(early, 0.1, lifted=False) and early.dt == 0.005  # switched from the first expected contact
    assert not plan(early, 0.2) and not plan(early, 0.6) and early.dt == 0.005  # carried 0.4 s: not yet
    assert plan(early, 0.7) and early.dt == 0.01  # 0.5 s: the grasp has held
    assert early.problem is problem and early.switched_back_at == 0.7 and early.switched_at == 0.1
    assert early.engine.model.opt.timestep == 0.01
    assert not plan(early, 0.8, lifted=False) and not plan(early, 1.5) and early.dt == 0.01  # once
    late = planner(1.0)
    for s in (0.1, 0.2, 0.6, 0.7, 1.0, 1.5):
        assert (
            not plan(late, s, lifted=s > 0.1) and late.dt == 0.01
        )  # held before its switch: it never switches
    assert late.switched_at is None and late.switched_back_at is None
    for p in (early, late):
        p.close()
    with pytest.raises(ConfigError, match="switch_back_held needs planner.switch_timestep"):
        PredictiveSampling(switch_back_held=True, carry_gain=1.0)
    with pytest.raises(ConfigError, match="switch_back_held needs planner.carry_gain"):
        PredictiveSampling(switch_back_held=True, switch_timestep=0.005)


def test_carry_leaves_an_object_without_a_free_body_alone(scene_for):
    """planner.carry_gain on the doorknob (no free body): no shift at any time, so carry=wrist|held|pose is
    the method itself there."""
    from contactmpc.control.problem import Problem

    scene = scene_for("doorknob")
    ref = static_reference(scene, duration=1.0, frames=11)
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 12)
    state = np.zeros(mujoco.mj_stateSize(scene.planner_model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    state[1 + scene.index.object_qpos] = 1.0  # far from the reference's articulation
    planner = PredictiveSampling(num_samples=2, horizon=0.2, nthread=1, carry_gain=1.0, carry_turn=1.0)
    planner.bind(problem)
    theta = planner.theta.copy()
    for t in (0.1, 0.5, 0.9):
        assert not planner.carry(t, t, state).any()
    np.testing.assert_array_equal(planner.theta, theta)
    planner.close()


def _turned_object(scene, problem, t: float, about: np.ndarray):
    """The hand at home and the object at the reference's pose at ``t`` turned by the quaternion ``about``
    (world frame): ``(the object's qpos, the full-physics state, turn)``, ``turn(step)`` the angular
    velocity a carry step's hinge part gives the wrist (its rotational Jacobian at that state) and the
    swing of the object about the wrist under it."""
    m = scene.planner_model
    d = mujoco.MjData(m)
    d.qpos[scene.index.hand_qpos] = scene.task.hand_home
    qo = problem.track.object_qpos[problem.track.index(t)].copy()
    turned = np.zeros(4)
    mujoco.mju_mulQuat(turned, about, qo[3:7].copy())
    qo[3:7] = turned
    d.qpos[scene.index.object_qpos] = qo
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    jacr = np.zeros((3, m.nv))
    mujoco.mj_jacBody(m, d, None, jacr, scene.index.root_body)

    def turn(step):
        omega = jacr[:, scene.index.hand_dof[3:6]] @ step[3:]
        return omega, np.cross(omega, qo[:3] - d.xpos[scene.index.root_body])

    return qo, state, turn


def test_carry_turns_the_wrist_toward_the_references_orientation_and_keeps_the_object_in_place(scene_for):
    """planner.carry_turn: the hinge step turns the wrist (through its rotational Jacobian) by gain x dt x
    the rotation from the object's orientation to the reference's, and the translation step cancels the
    object's swing about the wrist to first order."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)
    ref.object_qpos[:, 2] += np.linspace(0.0, 0.1, 11)
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 12)
    about_z = np.array([np.cos(0.1), 0.0, 0.0, np.sin(0.1)])  # 0.2 rad about world z
    qo, state, turn = _turned_object(scene, problem, 1.6, about_z)
    planner = PredictiveSampling(num_samples=2, horizon=0.2, nthread=1, carry_gain=1.0, carry_turn=1.0)
    planner.bind(problem)
    planner.carry(1.1, 1.1, state)  # (the first plan: dt = replan_period)
    step = planner.carry(1.6, 1.6, state)
    omega, swing = turn(step)
    np.testing.assert_allclose(omega, [0.0, 0.0, -0.2 * 0.5], atol=1e-6)  # back toward the reference's
    np.testing.assert_allclose(step[:3], -swing, atol=1e-9)  # (the object's position is the reference's)
    planner.close()


def test_pace_turn_turns_a_set_down_object_toward_the_references_orientation_while_the_reference_waits(
    scene_for,
):
    """planner.pace_turn: a plan that finds the paced reference's clock held and the object set down (not
    carried) turns the wrist by gain x dt x the rotation from the object's orientation to the reference's
    (the carry's turn, the object kept in place); nothing while the reference runs on, nor with pace_turn 0;
    refused without pace_lag."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)  # contact expected throughout, the object still
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 12)
    about_x = np.array([np.cos(0.25), np.sin(0.25), 0.0, 0.0])  # 0.5 rad about world x
    _, state, turn = _turned_object(scene, problem, 0.6, about_x)  # on the table, where it starts

    def planner_at(turn):
        planner = PredictiveSampling(
            num_samples=2,
            horizon=0.2,
            nthread=1,
            carry_gain=1.0,
            pace_lag=0.05,
            pace_angle=0.35,
            pace_turn=turn,
        )
        planner.bind(problem)
        planner.carry(0.5, 0.5, state)  # the plan before (dt = 0.1 s from it)
        return planner

    planner = planner_at(1.0)
    assert not planner.waiting(0.6)
    np.testing.assert_array_equal(planner.carry(0.6, 0.6, state), np.zeros(6))  # the reference runs on
    planner.pace(0.7, 0.7, state)  # turned 0.5 rad > pace_angle: the clock holds from 0.7 on
    assert planner.waiting(0.7) and planner.waiting(0.8)
    step = planner.carry(0.7, 0.7, state)
    omega, swing = turn(step)
    np.testing.assert_allclose(omega, [-0.5 * 0.1, 0.0, 0.0], atol=1e-6)  # back upright: 0.1 s x 0.5 rad
    np.testing.assert_allclose(step[:3], -swing, atol=1e-9)  # the object kept where it is
    planner.close()
    planner = planner_at(0.0)
    planner.pace(0.7, 0.7, state)
    np.testing.assert_array_equal(planner.carry(0.7, 0.7, state), np.zeros(6))
    planner.close()
    with pytest.raises(ConfigError, match="pace_turn.*pace_lag"):
        PredictiveSampling(pace_turn=1.0)


def test_pace_turn_fade_winds_the_wrists_turn_back_after_the_release(scene_for):
    """planner.pace_turn_fade: the release's control points keep the wrist's translation shift in full, and
    its hinge shift (the turn) in full at the last expected contact, none from pace_turn_fade after it,
    linearly between by each point's Greville abscissa; without it they keep both in full."""
    _, problem, _ = _paced_problem(scene_for, ReleaseSchedule(reset=True))
    shift = np.array([0.01, -0.02, 0.005, 0.3, -0.2, 0.1])
    kwargs = dict(num_samples=2, horizon=0.2, nthread=1, pace_lag=0.05, pace_turn=1.0)
    planners = [PredictiveSampling(**kwargs), PredictiveSampling(**kwargs, pace_turn_fade=0.2)]
    for planner in planners:
        planner.bind(problem)
        planner._carry = shift.copy()  # (as the waits' turns left it)
        reset = planner.release()
        assert len(reset) >= 3
    kept, faded = (planner.theta[reset, :6] - problem.release_theta[reset, :6] for planner in planners)
    np.testing.assert_allclose(kept, np.tile(shift, (len(reset), 1)), atol=1e-12)
    np.testing.assert_allclose(faded[:, :3], kept[:, :3], atol=1e-12)
    late = (problem.spline.greville(reset) - problem.last_contact)[:, None]
    np.testing.assert_allclose(faded[:, 3:], np.clip(1.0 - late / 0.2, 0.0, 1.0) * shift[3:], atol=1e-12)
    assert (late >= 0.2).any() and not faded[late[:, 0] >= 0.2, 3:].any()  # wound back in full
    for planner in planners:
        planner.close()


def test_a_carried_trial_runs_and_says_so(tmp_path, late_contact_reference):
    overrides = ["task=apple", f"task.reference_path={late_contact_reference[1]}", *TINY]
    record = json.loads(run_job(overrides + ["job.progress=false", "carry=pose"], tmp_path).read_text())
    planner = record["config"]["planner"]
    assert record["status"] == "ok" and planner["carry_gain"] == 1.0 and planner["carry_turn"] == 1.0


def test_carry_held_composes_the_wrist_carry_with_a_hold(tmp_path, late_contact_reference):
    overrides = ["task=apple", f"task.reference_path={late_contact_reference[1]}", *TINY]
    record = json.loads(run_job(overrides + ["job.progress=false", "carry=held"], tmp_path).read_text())
    planner = record["config"]["planner"]
    assert record["status"] == "ok" and planner["carry_gain"] == 1.0 and planner["carry_hold"] == 1.0
    assert planner["carry_turn"] == 0.0


def test_a_paced_reference_runs_online_each_plan_read_at_its_own_clock(scene_for):
    """job=online with a paced reference: the reference waits for the object as in a trial (the log's
    reference time falls behind control time, by no more than pace_budget), and the targets the plant used
    are each the plan in use's, read at the clock that plan set (not the planner's, which moves on)."""
    from contactmpc.online import OnlineLoop

    scene = scene_for("apple")
    planner = PredictiveSampling(num_samples=2, horizon=0.1, nthread=1, pace_lag=1e-9, pace_budget=0.1)
    ref = static_reference(scene, duration=0.3, frames=7)  # contact expected throughout: it may wait
    trial = Trial(scene, ref, PCASplineSpace(0.2), TrackingCost(), planner, 0, progress=False)
    loop = OnlineLoop(trial, slowdown=4.0)
    try:
        series = loop.run().arrays()
    finally:
        planner.close()
    behind = series["time"] - series["reference_time"]
    assert behind.max() > 0.02 and (behind <= 0.1 + 1e-6).all()
    plans = loop.plans
    assert all(p.clock is not None for p in plans) and len({p.clock for p in plans}) > 1
    for t, version, target in zip(series["time"], series["plan_version"], series["hand_target"], strict=True):
        plan = plans[version]
        np.testing.assert_allclose(
            target, planner.targets(np.array([t]), plan.theta, plan.clock)[0], atol=1e-12
        )
        assert planner.reference_time(t, plan.clock) == pytest.approx(t - behind[series["time"] == t][0])


def test_trapezoids_ramp_in_and_out_of_each_run_and_bridge_short_gaps():
    active = np.array([0, 1, 1, 1, 1, 1, 1, 0, 0, 1, 1, 0, 0, 0, 1, 1, 1, 1], bool)
    w = trapezoids(active, ramp=2, bridge=2)
    assert not w[~active & (np.arange(18) < 1)].any() and not w[11:14].any()
    np.testing.assert_allclose(w[1:11], [0.5, 1, 1, 1, 1, 1, 1, 1, 1, 0.5])  # the 2-step gap bridged
    np.testing.assert_allclose(w[14:], [0.5, 1, 1, 0.5])  # (a 3-step gap is not)
    assert trapezoids(np.zeros(5, bool), 3, 1).sum() == 0
    np.testing.assert_allclose(trapezoids(np.ones(3, bool), 4, 0), [0.25, 0.5, 0.25])  # short: below 1


def _bound(scene, ref, grip):
    from contactmpc.control.problem import Problem

    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 12)
    planner = PredictiveSampling(num_samples=2, horizon=0.2, nthread=1, grip=grip)
    planner.bind(problem)
    return problem, planner


def test_grip_squeezes_the_flexion_joints_of_the_fingers_in_contact_in_plant_and_rollouts(scene_for):
    """static_reference's first 8 links expect contact (the palm, the index finger's five, the middle
    finger's first two): the index and middle fingers' flexion joints get the squeeze, ramped in and out;
    their abduction, the ring finger, the thumb and the wrist get nothing. The plant's targets and a
    planned grip's rollout controls are the policy's plus the offsets, clipped; planned=False leaves the
    rollouts alone."""
    scene = scene_for("apple")
    hand = scene.hand
    ref = static_reference(scene, duration=1.0, frames=11)
    _, plain = _bound(scene, ref, None)
    problem, gripped = _bound(scene, ref, Grip(squeeze=0.2, ramp=0.1))
    offsets = gripped._grip
    columns = {name: hand.num_root + hand.finger_joints.index(name) for name in hand.finger_joints}
    squeezed = [columns[j] for j in ("ffj1", "ffj2", "ffj3", "mfj1", "mfj2", "mfj3")]
    middle = problem.track.index(0.5)
    np.testing.assert_allclose(offsets[middle, squeezed], 0.2)
    others = np.setdiff1d(np.arange(offsets.shape[1]), squeezed)
    assert not offsets[:, others].any()
    ramp = offsets[: problem.track.index(0.1) + 1, squeezed[0]]
    assert ramp[0] < 0.2 and (np.diff(ramp) >= 0).all() and ramp[-1] == pytest.approx(0.2)
    np.testing.assert_allclose(offsets[problem.track.index(1.0), squeezed], 0.2)  # (it ends held)

    times = np.linspace(0.0, 1.0, 21)
    ranges = problem.space.ranges
    expected = np.clip(plain.targets(times) + gripped.grip_at(times), ranges[:, 0], ranges[:, 1])
    np.testing.assert_array_equal(gripped.targets(times), expected)
    assert (gripped.targets(times) != plain.targets(times)).any()

    t = 0.5
    rollout = gripped.controls(gripped.theta[None], gripped.basis(t), gripped.basis_times(t))
    unplanned = Grip(squeeze=0.2, ramp=0.1, planned=False)
    _, plant_only = _bound(scene, ref, unplanned)
    base = plain.controls(plain.theta[None], plain.basis(t), plain.basis_times(t))
    act = scene.index.actuators
    offset = np.zeros_like(base)
    offset[..., act] = gripped.grip_at(gripped.basis_times(t))
    np.testing.assert_allclose(rollout, np.clip(base + offset, *scene.planner_model.actuator_ctrlrange.T))
    np.testing.assert_array_equal(
        plant_only.controls(plant_only.theta[None], plant_only.basis(t), plant_only.basis_times(t)), base
    )
    np.testing.assert_array_equal(plant_only.targets(times), gripped.targets(times))  # the plant: gripped
    for p in (plain, gripped, plant_only):
        p.close()


def test_grip_while_carried_waits_for_the_reference_to_lift_the_object(scene_for):
    """during=carried: no squeeze until the reference's object is more than ``lift`` above where it
    starts; an object without a free body (the doorknob) is never squeezed."""
    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)
    ref.object_qpos[:, 2] += np.r_[np.zeros(5), np.linspace(0.02, 0.1, 6)]  # lifted from 0.5 s
    problem, planner = _bound(scene, ref, Grip(squeeze=0.2, ramp=0.1, during="carried", lift=0.01))
    lifted = problem.track.object_qpos[:, 2] - problem.track.object_qpos[0, 2] > 0.01
    first = int(np.argmax(lifted))
    assert 0 < first and not planner._grip[:first].any() and planner._grip[first:].any()
    planner.close()

    knob = scene_for("doorknob")
    _, planner = _bound(knob, static_reference(knob, 1.0, 11), Grip(during="carried"))
    assert not planner._grip.any()
    planner.close()


def test_grip_refuses_a_hand_whose_fingers_have_no_contact_links_and_contacts_over_other_links():
    from contactmpc.hands import AllegroHand, ParallelGripper

    gripper = ParallelGripper()
    with pytest.raises(ConfigError, match="no contact link"):
        Grip().tables(gripper, np.ones((5, len(gripper.link_names)), bool), 0.01)
    with pytest.raises(ConfigError, match="over 3 links"):
        Grip().tables(AllegroHand(), np.ones((5, 3), bool), 0.01)


def test_a_gripped_trial_runs_and_no_squeeze_is_the_trial_of_before(tmp_path, late_contact_reference):
    """grip=squeeze composes (its record says so); at squeeze 0 the trial is grip=none's bit for bit."""
    overrides = late_apple(late_contact_reference)
    base = run_job(overrides, tmp_path / "off")
    record = json.loads(run_job(overrides + ["grip=carried"], tmp_path / "on").read_text())
    grip = record["config"]["planner"]["grip"]
    assert record["status"] == "ok" and grip["squeeze"] == 0.1 and grip["during"] == "carried"
    zero = run_job(overrides + ["grip=squeeze", "planner.grip.squeeze=0"], tmp_path / "zero")
    assert_same_series(base, zero)


def test_grip_touched_squeezes_a_finger_only_from_the_plan_that_finds_it_touching(scene_for):
    """during=touched: no squeeze until a plan's state has the finger on the object; from that plan's
    time the finger's squeeze ramps in; fingers the reference does not expect in contact are never
    marked, and a finger stays marked from its first touch."""
    scene = scene_for("apple")
    ref = static_reference(scene, duration=1.0, frames=11)  # expected: palm, index, middle (2 links)
    problem, planner = _bound(scene, ref, Grip(squeeze=0.2, ramp=0.1, during="touched"))
    times = np.linspace(0.0, 1.0, 101)
    assert not planner.grip_at(times).any()  # nothing touched yet

    m, index = scene.planner_model, scene.index
    d = mujoco.MjData(m)
    d.qpos[index.hand_qpos] = scene.task.hand_home
    d.qpos[index.object_qpos] = scene.task.initial_object_qpos(scene.plant_model)
    mujoco.mj_kinematics(m, d)
    tip = m.body("ff_tip").id
    d.qpos[index.object_qpos[:3]] = d.xpos[tip]  # the object on the index fingertip
    mujoco.mj_forward(m, d)
    assert scene.link_contacts(d)[list(scene.hand.link_names).index("ff_tip")]
    state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)

    marked = planner.touch(0.5, state)
    fingers = [scene.hand.link_names[links[0]].split("_")[0] for links, _ in planner._grip_fingers]
    assert marked[fingers.index("ff")] and not marked[fingers.index("rf")] and not marked[fingers.index("th")]
    offsets = planner.grip_at(times)
    for f, (_, columns) in enumerate(planner._grip_fingers):
        if not marked[f]:
            assert not offsets[:, columns].any()
            continue
        assert not offsets[times <= 0.5][:, columns].any()
        np.testing.assert_allclose(offsets[(times >= 0.6) & (times <= 1.0)][:, columns], 0.2)
    assert not planner.touch(0.8, state).any()  # already marked: the time stays 0.5
    np.testing.assert_array_equal(planner.grip_at(times), offsets)
    planner.close()


def test_root_span_samples_the_wrist_from_before_the_first_contact_to_the_last():
    """sampler.root_span: wrist noise on the control points whose support meets [first + start, last + end]
    (to the domain's end where the reference ends held), a union with root_window; none without contact."""
    from contactmpc.control.samplers import JointSplineSpace
    from contactmpc.reference.bspline import UniformBSpline

    times = np.linspace(0, 10, 50)
    qpos = np.random.default_rng(0).normal(size=(50, 8))
    spline = UniformBSpline(20, (0.0, 10.0))
    ranges = np.tile([-10.0, 10.0], (8, 1))

    def sampled(first, last, **kwargs):
        space = JointSplineSpace(0.2, root_sigma2=1e-4, **kwargs)
        space.fit(spline, times, qpos, ranges, 6)
        std = space.point_noise_std(spline, first, last)
        np.testing.assert_allclose(std[:, 6:], np.sqrt(0.2))  # the fingers everywhere
        return np.flatnonzero(std[:, :6].any(axis=1))

    span = sampled(3.0, 7.0, root_span=(-1.0, 0.0))
    np.testing.assert_array_equal(span, spline.window_indices(2.0, 5.0))
    held = sampled(3.0, None, root_span=(-1.0, 0.0))
    np.testing.assert_array_equal(held, spline.window_indices(2.0, 8.0))
    assert held[-1] == 19 and span[-1] < 19
    union = sampled(3.0, 7.0, root_span=(1.0, -2.0), root_window=(-1.0, 0.5))
    np.testing.assert_array_equal(
        union, np.union1d(spline.window_indices(2.0, 1.5), spline.window_indices(4.0, 1.0))
    )
    assert sampled(None, None, root_span=(-1.0, 0.0)).size == 0
    assert sampled(3.0, 3.5, root_span=(1.0, 0.0)).size == 0  # an empty span samples nothing
    with pytest.raises(ConfigError, match="root_span"):
        JointSplineSpace(0.2, root_span=(1.0, 2.0, 3.0))


def test_wrist_carry_composes_a_span_and_no_window(tmp_path, late_contact_reference):
    overrides = ["task=apple", f"task.reference_path={late_contact_reference[1]}", *TINY]
    record = json.loads(run_job(overrides + ["job.progress=false", "wrist=carry"], tmp_path).read_text())
    sampler = record["config"]["sampler"]
    assert record["status"] == "ok" and sampler["root_span"] == [-1.0, 0.0] and sampler["root_window"] is None
    assert sampler["root_sigma2"] == 1.0e-4


def _evaluated(planner) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each of ``planner``'s evaluations as it plans: the control-point sets and their total costs."""
    seen = []
    real = planner.evaluate

    def evaluate(state, t, thetas):
        out = real(state, t, thetas)
        seen.append((thetas.copy(), out[0].copy()))
        return out

    planner.evaluate = evaluate
    return seen


def test_reuse_carries_the_last_plans_runners_up_into_the_next_plan():
    """planner.reuse: the first plan is reuse=0's bit for bit (nothing is kept yet); the next plan's last
    rows are the last plan's cheapest finite candidates other than the committed one, each as its
    difference from the committed points added to the new nominal where both windows meet (the nominal
    elsewhere), its other rows reuse=0's draws; the same rollouts a plan."""
    problem = PointMassProblem(sigma=0.4)
    on = PredictiveSampling(num_samples=12, horizon=0.5, reuse=3)
    off = PredictiveSampling(num_samples=12, horizon=0.5)
    problem.bind(on)
    problem.bind(off)
    seen_on, seen_off = _evaluated(on), _evaluated(off)
    on.plan(0.0, problem.state, np.random.default_rng(1))
    off.plan(0.0, problem.state, np.random.default_rng(1))
    np.testing.assert_array_equal(on.theta, off.theta)
    thetas, total = seen_on[0]
    committed = on.theta.copy()
    order = [i for i in np.argsort(total, kind="stable") if not np.array_equal(thetas[i], committed)][:3]
    assert len(order) == 3 and np.isfinite(total[order]).all()
    # the same window and nominal: the runners-up themselves come back, the fresh draws are reuse=0's
    on.plan(0.0, problem.state, np.random.default_rng(2))
    off.plan(0.0, problem.state, np.random.default_rng(2))
    again, again_off = seen_on[1][0], seen_off[1][0]
    np.testing.assert_allclose(again[-3:], thetas[order], rtol=0, atol=1e-12)  # (nominal + difference)
    np.testing.assert_array_equal(again[:-3], again_off[:-3])
    assert on.plan(0.0, problem.state, np.random.default_rng(3)).best_cost <= seen_on[2][1][0]
    # a later window: the kept differences on the control points both windows cover, the nominal elsewhere
    old_window = problem.spline.window_indices(0.0, 0.5)
    kept_window, differences = on._kept
    np.testing.assert_array_equal(kept_window, old_window)
    nominal = on.theta.copy()
    on.plan(0.4, problem.state, np.random.default_rng(4))
    window = problem.spline.window_indices(0.4, 0.5)
    late = seen_on[3][0][-3:, window]
    shared = np.isin(window, old_window)
    assert 0 < shared.sum() < len(window)
    expected = np.broadcast_to(nominal[window], late.shape).copy()
    expected[:, shared] += differences[:, np.isin(old_window, window)]
    np.testing.assert_allclose(late, expected, rtol=0, atol=1e-12)
    assert on.rollouts_per_plan() == off.rollouts_per_plan() == 12
    problem.engine.close()


def test_reuse_scaled_keeps_the_same_share_of_runners_up_in_a_larger_plan():
    """planner.reuse_scaled: a plan of acquire_samples keeps reuse per num_samples of its samples (20 of
    a 3-in-12 share: 5) and the next plan of that size takes them all in; a plan of num_samples takes in
    reuse of them; off, every plan keeps reuse (the trial of before, bit for bit)."""
    problem = PointMassProblem(sigma=0.4)
    args = {"num_samples": 12, "horizon": 0.5, "reuse": 3, "acquire_samples": 20, "acquire_until": 0.3}
    on = PredictiveSampling(**args, reuse_scaled=True)
    off = PredictiveSampling(**args)
    same = PredictiveSampling(**args, reuse_scaled=False)
    for planner in (on, off, same):
        problem.bind(planner)
        planner.problem.first_contact = 0.0  # the acquire window: [0, 0.3)
    seen_on, seen_off, seen_same = _evaluated(on), _evaluated(off), _evaluated(same)
    assert (on.reuse_count(20), on.reuse_count(12), off.reuse_count(20)) == (5, 3, 3)
    for k, t in enumerate((0.0, 0.1, 0.4)):  # two plans of 20 samples, then one of 12
        for planner in (on, off, same):
            planner.plan(t, problem.state, np.random.default_rng(k))
        np.testing.assert_array_equal(seen_same[k][0], seen_off[k][0])  # off is the trial of before
        np.testing.assert_array_equal(same.theta, off.theta)
        kept = {id(p): len(p._kept[1]) for p in (on, off)}
        assert kept == {id(on): 5 if t < 0.3 else 3, id(off): 3}
    first_on, first_off = seen_on[0][0], seen_off[0][0]
    np.testing.assert_array_equal(first_on, first_off)  # nothing kept yet: the same first plan
    assert len(seen_on[1][0]) == 20 and len(seen_on[2][0]) == 12
    # the second plan of 20: the last 5 rows are runners-up (off: 3), the rows before them fresh draws
    np.testing.assert_array_equal(seen_on[1][0][:-5], seen_off[1][0][:-5])
    assert not np.array_equal(seen_on[1][0][-5:-3], seen_off[1][0][-5:-3])
    problem.engine.close()


def test_reuse_after_carries_the_runners_up_only_from_then_on():
    """planner.reuse_after: before that long after the first expected contact a plan is reuse=0's bit for
    bit (its runners-up kept but not carried in); from then on its last rows are the kept runners-up."""
    problem = PointMassProblem(sigma=0.4)
    on = PredictiveSampling(num_samples=12, horizon=0.5, reuse=3, reuse_after=0.3)
    off = PredictiveSampling(num_samples=12, horizon=0.5)
    problem.bind(on)
    problem.bind(off)
    on.problem.first_contact = off.problem.first_contact = 0.2
    seen_on, seen_off = _evaluated(on), _evaluated(off)
    for k, t in enumerate((0.0, 0.1, 0.4)):  # the gate opens at 0.2 + 0.3 = 0.5
        on.plan(t, problem.state, np.random.default_rng(k))
        off.plan(t, problem.state, np.random.default_rng(k))
        np.testing.assert_array_equal(seen_on[k][0], seen_off[k][0])
        np.testing.assert_array_equal(on.theta, off.theta)
    assert not on.reusing(0.49) and on.reusing(0.5) and on._kept is not None
    on.plan(0.5, problem.state, np.random.default_rng(5))
    off.plan(0.5, problem.state, np.random.default_rng(5))
    np.testing.assert_array_equal(seen_on[3][0][:-3], seen_off[3][0][:-3])  # the fresh draws
    assert not np.array_equal(seen_on[3][0][-3:], seen_off[3][0][-3:])  # the runners-up
    on.problem.first_contact = None  # without an expected contact: into every plan, as reuse_after=None
    assert on.reusing(0.0)
    problem.engine.close()


def fake_touch(planner, monkeypatch, names, touching) -> None:
    """Give ``planner``'s scene the hand links ``names`` and make ``touching()`` (a list of booleans, one per
    link) the links on the object in any state: a stand-in for contact on the point-mass problem."""
    from types import SimpleNamespace

    planner.problem.scene = SimpleNamespace(
        **vars(planner.problem.scene),
        hand=SimpleNamespace(link_names=names),
        link_contacts=lambda data: np.asarray(touching()),
    )
    monkeypatch.setattr(planner, "_forwarded", lambda state: None)


def test_reuse_fingers_carries_the_runners_up_only_where_enough_fingers_touch(monkeypatch):
    """planner.reuse_fingers: a plan whose state has fewer fingers on the object (the distinct
    ``<finger>_*`` of the touching links; the palm is none) is reuse=0's bit for bit; one with enough takes
    the last plan's runners-up in."""
    problem = PointMassProblem(sigma=0.4)
    on = PredictiveSampling(num_samples=12, horizon=0.5, reuse=3, reuse_fingers=2)
    off = PredictiveSampling(num_samples=12, horizon=0.5)
    problem.bind(on)
    problem.bind(off)
    touching = {"now": np.array([True, True, True, False])}  # the palm and two links of one finger
    fake_touch(on, monkeypatch, ["palm", "ff_tip", "ff_distal", "th_tip"], lambda: touching["now"])
    assert on.fingers_touching(problem.state) == 1
    seen_on, seen_off = _evaluated(on), _evaluated(off)
    for k in range(2):  # the second plan has runners-up kept, but one finger: fresh samples alone
        on.plan(0.0, problem.state, np.random.default_rng(k))
        off.plan(0.0, problem.state, np.random.default_rng(k))
        np.testing.assert_array_equal(seen_on[k][0], seen_off[k][0])
    touching["now"] = np.array([False, True, False, True])  # the index and the thumb
    assert on.fingers_touching(problem.state) == 2
    on.plan(0.0, problem.state, np.random.default_rng(2))
    off.plan(0.0, problem.state, np.random.default_rng(2))
    np.testing.assert_array_equal(seen_on[2][0][:-3], seen_off[2][0][:-3])
    assert not np.array_equal(seen_on[2][0][-3:], seen_off[2][0][-3:])
    problem.engine.close()


def test_reuse_alone_false_carries_the_runners_up_except_where_one_finger_is_alone(monkeypatch):
    """planner.reuse_alone=False: a plan whose state has exactly one finger on the object is reuse=0's bit
    for bit; one with none (the approach) or with two takes the last plan's runners-up in."""
    problem = PointMassProblem(sigma=0.4)
    on = PredictiveSampling(num_samples=12, horizon=0.5, reuse=3, reuse_alone=False)
    off = PredictiveSampling(num_samples=12, horizon=0.5)
    problem.bind(on)
    problem.bind(off)
    touching = {"now": np.array([False, False, False, False])}
    fake_touch(on, monkeypatch, ["palm", "ff_tip", "ff_distal", "th_tip"], lambda: touching["now"])
    seen_on, seen_off = _evaluated(on), _evaluated(off)
    for k, now in enumerate(
        ([False] * 4, [False] * 4, [True, True, True, False], [False, True, False, True])
    ):  # none (nothing kept yet), none, the palm and one finger, the index and the thumb
        touching["now"] = np.array(now)
        on.plan(0.0, problem.state, np.random.default_rng(k))
        off.plan(0.0, problem.state, np.random.default_rng(k))
        np.testing.assert_array_equal(seen_on[k][0][:-3], seen_off[k][0][:-3])  # the fresh draws
        carried = not np.array_equal(seen_on[k][0][-3:], seen_off[k][0][-3:])
        assert carried == (k in (1, 3)), (k, on.fingers_touching(problem.state))
    problem.engine.close()


def test_reuse_until_carries_the_runners_up_before_then_whatever_the_fingers(monkeypatch):
    """planner.reuse_until with reuse_fingers: a plan before first contact + reuse_until takes the runners-up
    in with no finger on the object; from then on a plan with fewer fingers than reuse_fingers is reuse=0's
    bit for bit."""

    def pair(until):
        problem = PointMassProblem(sigma=0.4)
        on = PredictiveSampling(num_samples=12, horizon=0.5, reuse=3, reuse_fingers=2, reuse_until=until)
        off = PredictiveSampling(num_samples=12, horizon=0.5)
        problem.bind(on)
        problem.bind(off)
        on.problem.first_contact = off.problem.first_contact = 0.3
        fake_touch(on, monkeypatch, ["palm", "ff_tip"], lambda: [False] * 2)
        return problem, on, off, _evaluated(on), _evaluated(off)

    problem, on, off, seen_on, seen_off = pair(-0.1)  # the gate shuts at 0.3 - 0.1 = 0.2
    for k, t in enumerate((0.0, 0.2, 0.25)):  # runners-up kept, but none carried: reuse=0 bit for bit
        on.plan(t, problem.state, np.random.default_rng(k))
        off.plan(t, problem.state, np.random.default_rng(k))
        np.testing.assert_array_equal(seen_on[k][0], seen_off[k][0])
        np.testing.assert_array_equal(on.theta, off.theta)
    problem.engine.close()
    problem, on, off, seen_on, seen_off = pair(-0.1)
    for k, t in enumerate((0.0, 0.1)):  # before it: carried with no finger on the object
        on.plan(t, problem.state, np.random.default_rng(k))
        off.plan(t, problem.state, np.random.default_rng(k))
    np.testing.assert_array_equal(seen_on[1][0][:-3], seen_off[1][0][:-3])
    assert not np.array_equal(seen_on[1][0][-3:], seen_off[1][0][-3:])
    problem.engine.close()


def test_expected_fingers_counts_the_fingers_of_the_expected_links():
    """expected_fingers: per step, the distinct ``<finger>`` of the links the reference expects on the object
    (two links of one finger are one finger; the palm is none)."""
    names = ["palm", "ff_tip", "ff_distal", "mf_tip", "th_tip"]
    active = np.array(
        [[0, 0, 0, 0, 0], [1, 0, 0, 0, 0], [0, 1, 1, 0, 0], [1, 1, 0, 1, 0], [0, 1, 1, 1, 1]], bool
    )
    np.testing.assert_array_equal(expected_fingers(active, names), [0, 0, 1, 2, 3])


def index_then_grasp(scene):
    """A 1 s static reference of ``scene`` that expects the index alone on the object from frame 2 and
    the grasp of three fingers (index, middle, thumb tips) from frame 6."""
    names = scene.hand.link_names
    ref = static_reference(scene, duration=1.0, frames=11)
    ref.contact_active[:] = False
    ref.contact_active[2:, [i for i, n in enumerate(names) if n.startswith("ff_")]] = True
    ref.contact_active[6:, [names.index(n) for n in ("ff_tip", "mf_tip", "th_tip")]] = True
    return ref


def test_reuse_grasp_carries_the_runners_up_only_from_the_references_grasp(scene_for):
    """planner.reuse_grasp (reuse=elites_expected): the plans before the reference first expects that many
    fingers on the object are reuse=0's bit for bit; from there on a plan takes the last plan's runners-up
    in. A reference that never expects that many fingers carries them into no plan."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    names = scene.hand.link_names
    ref = index_then_grasp(scene)
    space = PCASplineSpace(0.2)

    def pair(fingers):
        problem = Problem.build(scene, ref, space, TrackingCost(), 0.2, 12)
        on = PredictiveSampling(num_samples=8, horizon=0.2, reuse=3, reuse_grasp=fingers)
        off = PredictiveSampling(num_samples=8, horizon=0.2)
        on.bind(problem)
        off.bind(problem)
        return problem, on, off

    problem, on, off = pair(3)
    track = problem.track
    counts = expected_fingers(track.contact_active, names)
    assert counts.max() == 3 and (counts == 1).any()  # the index alone, then the grasp
    grasp_at = float(np.flatnonzero(counts >= 3)[0] * track.dt)
    assert on._reuse_from == pytest.approx(grasp_at) and grasp_at > problem.first_contact
    state = np.zeros(mujoco.mj_stateSize(scene.planner_model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    state[1 : 1 + scene.planner_model.nq] = scene.planner_model.qpos0
    seen_on, seen_off = _evaluated(on), _evaluated(off)
    times = (0.0, problem.first_contact, grasp_at - 0.02, grasp_at, grasp_at + 0.05)
    for k, t in enumerate(times):
        on.plan(t, state, np.random.default_rng(k))
        off.plan(t, state, np.random.default_rng(k))
        np.testing.assert_array_equal(seen_on[k][0][:-3], seen_off[k][0][:-3])  # the fresh draws
        carried = not np.array_equal(seen_on[k][0][-3:], seen_off[k][0][-3:])
        assert carried == (t >= grasp_at), (k, t, grasp_at)
    problem, never, other = pair(4)
    assert never._reuse_from == float("inf") and not never.reusing(1e6)
    for planner in (on, off, never, other):
        planner.engine.close()


def test_acquire_grasp_keeps_the_grasps_samples_until_after_the_references_grasp(scene_for):
    """planner.acquire_grasp: the acquire window ends acquire_until after the reference's first instant
    with that many fingers on the object, not after its first expected contact; off (0), and where the
    reference never expects that many, it ends after the first expected contact as before."""
    from contactmpc.control.problem import Problem

    scene = scene_for("apple")
    names = scene.hand.link_names
    ref = index_then_grasp(scene)
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), 0.2, 12)
    args = {"num_samples": 8, "horizon": 0.2, "acquire_samples": 20, "acquire_until": 0.1}
    planners = {k: PredictiveSampling(**args, acquire_grasp=k) for k in (0, 3, 4)}
    for planner in planners.values():
        planner.bind(problem)
    first = problem.first_contact
    grasp_at = float(np.flatnonzero(expected_fingers(problem.track.contact_active, names) >= 3)[0])
    grasp_at *= problem.track.dt
    assert grasp_at > first + 0.1 and planners[3]._acquire_from == pytest.approx(grasp_at)
    for t in (0.0, first + 0.05, first + 0.15, grasp_at + 0.05, grasp_at + 0.15):
        assert planners[0].samples_at(t) == (20 if t < first + 0.1 else 8)  # off: from the first contact
        assert planners[3].samples_at(t) == (20 if t < grasp_at + 0.1 else 8), t
        assert planners[4].samples_at(t) == planners[0].samples_at(t)  # never 4 fingers: as off
    for planner in planners.values():
        planner.engine.close()


def test_a_reused_trial_runs_and_reuse_zero_is_the_trial_of_before(tmp_path, late_contact_reference):
    """reuse=elites composes (planner.reuse 8); at planner.reuse=0 the trial is reuse=none's bit for bit;
    reuse=elites_after_grasp composes (8, from 2 s after the first expected contact), and
    reuse=elites_grasped (8, while two fingers touch the object), reuse=elites_unless_alone (8, except
    while one finger is alone on it), reuse=elites_early_grasped (8, until 1 s before the first
    expected contact, then while two fingers touch it) and reuse=elites_expected (8, from the reference's
    grasp of three fingers) run."""
    overrides = late_apple(late_contact_reference)
    base = run_job(overrides, tmp_path / "off")
    record = json.loads(run_job(overrides + ["reuse=elites"], tmp_path / "on").read_text())
    assert record["status"] == "ok" and record["config"]["planner"]["reuse"] == 8
    zero = run_job(overrides + ["reuse=elites", "planner.reuse=0"], tmp_path / "zero")
    assert_same_series(base, zero)
    after = json.loads(run_job(overrides + ["reuse=elites_after_grasp"], tmp_path / "after").read_text())
    assert after["status"] == "ok" and after["config"]["planner"]["reuse"] == 8
    assert after["config"]["planner"]["reuse_after"] == 2.0
    grasped = json.loads(run_job(overrides + ["reuse=elites_grasped"], tmp_path / "grasped").read_text())
    assert grasped["status"] == "ok" and grasped["config"]["planner"]["reuse_fingers"] == 2
    alone = json.loads(run_job(overrides + ["reuse=elites_unless_alone"], tmp_path / "alone").read_text())
    assert alone["status"] == "ok" and alone["config"]["planner"]["reuse_alone"] is False
    early = json.loads(run_job(overrides + ["reuse=elites_early_grasped"], tmp_path / "early").read_text())
    assert early["status"] == "ok" and early["config"]["planner"]["reuse_until"] == -1.0
    expected = json.loads(run_job(overrides + ["reuse=elites_expected"], tmp_path / "expected").read_text())
    assert expected["status"] == "ok" and expected["config"]["planner"]["reuse_grasp"] == 3
