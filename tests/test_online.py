"""``job=online``: the loop in wall-clock time, its record, the atomic plan swap, and the viewer.

Timing on 2 busy cores is not for asserting exact values: the runs use a large ``slowdown`` (the plant
has 10-15 wall milliseconds per 1 ms physics step) and the assertions are about what cannot depend on
the machine's speed (plans were swapped in, ages are positive, the targets the plant used are one
published plan's), or bounds with a wide margin.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners import PlanInfo, PredictiveSampling, Replay
from contactmpc.control.samplers import PCASplineSpace
from contactmpc.online import OnlineLoop
from contactmpc.reference import Reference
from contactmpc.trial import Trial
from tests.conftest import REPO_ROOT, build_scene
from tests.helpers import static_reference
from tests.test_trial import run_job


@pytest.fixture(scope="module")
def apple_reference(tmp_path_factory) -> str:
    """A short static reference of the apple task (the fingers flex, the apple stays), as a file."""
    ref = static_reference(build_scene(("task=apple",)), duration=0.5, frames=11)
    return str(ref.save(tmp_path_factory.mktemp("online") / "apple.npz"))


@pytest.mark.slow
def test_an_online_run_swaps_plans_in_and_writes_its_record(apple_reference, tmp_path):
    """The lite planner live for 0.4 s of control at 15x slower than real time (6 s of wall time)."""
    overrides = [
        "job=online",
        "task=apple",
        f"task.reference_path={apple_reference}",
        "planner.nthread=1",
        "duration=0.4",
        "job.slowdown=15",
        "job.progress=false",
    ]
    record = json.loads(run_job(overrides, tmp_path).read_text())
    assert record["status"] == "ok", record.get("error")
    assert record["mode"] == "online" and record["slowdown"] == 15.0 and record["viewer"] is False
    # the trial's fields, from the trial's summary
    for key in ("ttf", "completed", "milestone_lifted", "object_position_error_mean", "contact_fraction"):
        assert key in record
    # plans were made and swapped in while the plant ran
    assert record["num_plans"] >= 3 and record["plans_applied"] >= 3
    assert record["plans_applied"] <= record["num_plans"]
    for key in (
        "replan_interval_median",
        "replan_interval_step_median",
        "plan_latency_median",
        "plan_age_median",
    ):
        assert record[key] is not None and record[key] > 0, key
    assert record["plan_age_p95"] >= record["plan_age_median"]
    assert record["replan_interval_p95"] >= record["replan_interval_median"]
    assert record["replan_interval"] == 0.05  # the configured one, as in a trial (the realised: _median)
    assert record["latency"] == 0.0  # configured (the realised: plan_latency_median)
    assert 0 <= record["stale_steps"] <= 400 and record["stale_threshold"] == 0.05
    # the plant is paced: never faster than asked (15x slower), and not far slower at that pace
    assert record["simulated_seconds"] == pytest.approx(0.4)
    assert record["real_time_factor"] <= 1.02 / 15
    assert record["real_time_factor"] > 0.5 / 15
    assert record["plant_wait_seconds"] > 0  # it had time to spare and slept
    series = np.load(tmp_path / "timeseries.npz")
    assert series["time"].shape == (8,)  # one row per 50 ms replan interval, as a trial
    assert np.all(np.diff(series["plan_version"]) >= 0)
    assert np.all(series["plan_age"] >= 0)
    assert len(series["plans_state_time"]) == record["num_plans"]
    for key in ("plan_seconds_grasp_median", "plan_seconds_after_grasp_median"):
        assert record[key] is None or record[key] > 0, key
    assert list(record["plan_seconds_by_samples"]) == ["32"]  # the lite preset's samples, every plan


def test_the_grasp_plans_are_those_planned_from_1_s_before_to_2_s_after_the_first_contact():
    """The record's grasp-window plan times split the plans by the control time they were planned from."""
    from types import SimpleNamespace as NS

    from contactmpc.online import OnlineLoop

    loop = OnlineLoop.__new__(OnlineLoop)
    times = [0.0, 0.4, 0.5, 2.0, 3.25, 3.5, 4.0]
    loop.plans = [NS(state_time=t, info=NS(seconds=10 + t)) for t in times]
    loop.trial = NS(planner=NS(problem=NS(first_contact=1.5)))
    grasp, after = loop._grasp_plans()
    assert grasp == [10.5, 12.0, 13.25] and after == [13.5, 14.0]
    loop.trial.planner.problem.first_contact = None
    assert loop._grasp_plans() == ([], [])
    for plan, samples in zip(loop.plans, (128, 128, 32, 128, 32, 32, 32), strict=True):
        plan.info.samples = samples  # by the samples each drew, whatever state it planned from
    assert loop._plans_by_samples() == {"128": 10.4, "32": 13.375}


def test_latency_by_samples_predicts_a_plan_as_far_ahead_as_plans_of_its_samples_took():
    """OnlineLoop(latency_by_samples=True): the next plan's expected latency is the median of the last
    plans that drew the samples it is expected to draw (the grasp's 128 in the acquire window), scaled by
    the samples where none has yet; without ``t``, the last plans' whatever they drew (the default)."""
    from types import SimpleNamespace as NS

    loop = OnlineLoop.__new__(OnlineLoop)
    loop.slowdown = 2.0
    window = 1.0  # the acquire window: reference time before 1 s

    def samples_at(s):
        return 128 if s < window else 32

    planner = NS(samples_at=samples_at, reference_time=lambda t: t - 0.5, acquire_error=None)
    loop.trial = NS(planner=planner)

    def plans(*drawn):  # (samples, wall seconds) of each plan, in order
        return [NS(start_wall=0.0, ready_wall=w, info=NS(samples=n)) for n, w in drawn]

    loop.plans = plans((32, 0.1), (32, 0.1), (32, 0.1))
    assert loop.expected_latency() == pytest.approx(0.05)  # wall / slowdown
    assert loop.expected_latency(t=2.0) == pytest.approx(0.05)  # reference time 1.5: 32 samples
    assert loop.expected_latency(t=1.0) == pytest.approx(0.2)  # 128: none yet, 4x the 32's
    loop.plans += plans((128, 0.8), (128, 0.6), (32, 0.1), (32, 0.1), (32, 0.1))
    assert loop.expected_latency() == pytest.approx(0.05)  # the last five: three of 32
    assert loop.expected_latency(t=1.0) == pytest.approx(0.35)  # the 128's median, 0.7 s wall
    # acquire_error: a plan past the window that drew the grasp's samples: the next most likely does too
    planner.acquire_error = (0.03, 0.35)
    assert loop.expected_latency(t=2.0) == pytest.approx(0.05)
    loop.plans += plans((128, 1.0))
    assert loop.expected_latency(t=2.0) == pytest.approx(0.4)  # 0.6, 0.8, 1.0: median 0.8 s wall


class SlowReplay(Replay):
    """A planner that takes 60 ms of wall time and writes its control points in two halves 30 ms apart,
    each plan the reference's own control points + 0.01 x its number: a plant that read
    ``planner.theta`` would see plans torn in half for 30 ms of every 60."""

    count = 0

    def plan(self, t, state, rng, ahead=0.0, reach=0.0) -> PlanInfo:
        self.count += 1
        half = len(self.theta) // 2
        time.sleep(0.03)
        self.theta[:half] = self.problem.theta0[:half] + 0.01 * self.count
        time.sleep(0.03)
        self.theta[half:] = self.problem.theta0[half:] + 0.01 * self.count
        return PlanInfo(time=t, terms={k: float("nan") for k in self.problem.cost.terms}, seconds=0.06)


def test_a_slow_plan_is_swapped_in_whole_and_the_plant_keeps_the_old_one(apple_reference):
    scene = build_scene(("task=apple",))
    reference = Reference.load(apple_reference)
    planner = SlowReplay(horizon=0.2, replan_period=0.01)
    trial = Trial(
        scene, reference, PCASplineSpace(0.2), TrackingCost(), planner, 0, duration=0.3, progress=False
    )
    loop = OnlineLoop(trial, slowdown=2.0)  # a plan (60 ms wall) lasts ~30 ms of control: ~3 log rows
    series = loop.run().arrays()
    plans = loop.plans
    assert len(plans) >= 3
    theta0 = trial.problem.theta0
    for plan in plans:  # each published plan is whole: one offset over all its control points
        assert not plan.theta.flags.writeable
        np.testing.assert_allclose(plan.theta - theta0, 0.01 * (plan.version + 1), rtol=0, atol=1e-12)
    # the targets the plant used (logged every 10 ms) are exactly one published plan's: the one in use
    for t, version, target in zip(series["time"], series["plan_version"], series["hand_target"], strict=True):
        np.testing.assert_allclose(
            target, planner.targets(np.array([t]), plans[version].theta)[0], atol=1e-12
        )
    # ... the newest one applied by then, and it stays in use until the next is ready (several rows)
    swaps = loop.swaps
    assert [v for v, _ in swaps] == sorted(v for v, _ in swaps)
    dt = scene.plant_model.opt.timestep
    for t, version in zip(series["time"], series["plan_version"], strict=True):
        k = int(round(t / dt))
        assert version == max(v for v, step in swaps if step <= k)
    rows_per_plan = np.bincount(series["plan_version"])
    assert rows_per_plan.max() >= 2  # a plan served two 10 ms rows or more: the plant kept the old plan
    # a plan takes effect after the state it was planned from
    summary = loop.summary()
    assert summary["plan_latency_median"] > 0.005
    assert summary["plans_applied"] == len(swaps) <= len(plans)


class _SlowSampling(PredictiveSampling):
    """Predictive sampling that takes at least 60 ms of wall time a plan."""

    def plan(self, t, state, rng, ahead=0.0, reach=0.0) -> PlanInfo:
        time.sleep(0.06)
        return super().plan(t, state, rng, ahead, reach)


@pytest.mark.parametrize("compensate", [False, True])
def test_online_compensation_plans_from_the_state_predicted_a_plans_compute_ahead(
    apple_reference, compensate
):
    """planner.compensate_latency online: every plan after the first starts (its window, its state) the
    recent plans' median compute time, in control seconds, after the state it was given; off: at it."""
    scene = build_scene(("task=apple",))
    reference = Reference.load(apple_reference)
    planner = _SlowSampling(num_samples=4, horizon=0.2, nthread=1, compensate_latency=compensate)
    trial = Trial(
        scene, reference, PCASplineSpace(0.2), TrackingCost(), planner, 0, duration=0.3, progress=False
    )
    loop = OnlineLoop(trial, slowdown=2.0)  # a plan (>= 60 ms wall) is >= 30 ms of control
    try:
        loop.run()
    finally:
        planner.close()
    ahead = np.array([p.info.time - p.state_time for p in loop.plans])
    assert len(ahead) >= 3 and ahead[0] == 0.0  # the first plan: nothing measured yet
    if not compensate:
        np.testing.assert_array_equal(ahead, 0.0)
        return
    steps = ahead[1:] / planner.dt  # whole planning steps, at least the 30 ms a plan takes
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    assert (ahead[1:] >= 0.03 - 1e-9).all() and (ahead[1:] < 0.3).all()
    # each plan checks where the last one predicted the object (planner.switch_error reads it), though
    # it starts when the last one is done, not on the planning step the last one predicted for: the
    # prediction's path runs as far again, interpolated between its steps
    checked = np.array([p.info.prediction[0] for p in loop.plans[2:]])
    assert len(checked) and np.isfinite(checked).mean() >= 0.5
    assert (checked[np.isfinite(checked)] < 0.01).all()  # the apple barely moves in this reference


def _small_online_run(scene, reference, **options) -> OnlineLoop:
    """A 0.45 s online run of a 4-sample planner at 4x slower than real time (a few ms a plan), with the
    loop's ``options``; the finished loop."""
    planner = PredictiveSampling(num_samples=4, horizon=0.2, nthread=1)
    trial = Trial(
        scene, reference, PCASplineSpace(0.2), TrackingCost(), planner, 0, duration=0.45, progress=False
    )
    loop = OnlineLoop(trial, slowdown=4.0, **options)
    try:
        loop.run()
    finally:
        planner.close()
    return loop


def test_an_online_planner_paced_to_a_minimum_interval_plans_no_more_often(apple_reference):
    """OnlineLoop(min_interval=0.1): the states two plans start from are at least 0.1 s of control apart,
    where the planner alone (a few ms a plan at 4x slower than real time) would replan every few ms."""
    scene = build_scene(("task=apple",))
    reference = Reference.load(apple_reference)
    gaps = {}
    for interval in (0.0, 0.1):
        loop = _small_online_run(scene, reference, min_interval=interval)
        gaps[interval] = np.diff([p.state_time for p in loop.plans])
    assert len(gaps[0.1]) >= 2 and (gaps[0.1] >= 0.1 - 1e-9).all()
    assert len(gaps[0.0]) > len(gaps[0.1]) and (gaps[0.0] < 0.1 - 1e-9).any()


def test_an_online_plan_held_to_a_fixed_latency_acts_no_sooner(apple_reference):
    """OnlineLoop(apply_after=0.1): every plan after the first takes effect at least 0.1 s of control
    after the state it was planned from (a plan of a few ms is held), where without it plans act within
    a few steps of their state; the record says so."""
    scene = build_scene(("task=apple",))
    reference = Reference.load(apple_reference)
    latency = {}
    for after in (0.0, 0.1):
        loop = _small_online_run(scene, reference, min_interval=0.1, apply_after=after)
        dt = scene.plant_model.opt.timestep
        latency[after] = np.array([k * dt - loop.plans[v].state_time for v, k in loop.swaps[1:]])
        assert loop.summary()["apply_after"] == after
    assert len(latency[0.1]) >= 2 and (latency[0.1] >= 0.1 - 1e-9).all()
    assert (latency[0.1] < 0.1 + 0.05).all()  # held to its time, not later: a plan takes a few ms here
    assert len(latency[0.0]) >= 2 and (latency[0.0] < 0.1 - 1e-9).all()


@pytest.mark.slow
def test_simulated_timing_runs_the_trials_replan_interval_and_latency_online(apple_reference, tmp_path):
    """job.simulated_timing=true: the run paces its plans to the trial's replan interval (max of
    planner.replan_period and planner.latency) and holds each to planner.latency, as the record says; with
    job.min_interval given too, or a latency per plan, it stops with one line naming the problem."""
    from contactmpc.validate import ConfigError

    base = ["job=online", "task=apple", f"task.reference_path={apple_reference}", "planner.nthread=1"]
    base += ["duration=0.5", "job.slowdown=15", "job.progress=false", "job.simulated_timing=true"]
    timing = ["planner.latency=0.1", "planner.replan_period=0.05"]
    record = json.loads(run_job(base + timing, tmp_path / "run").read_text())
    assert record["status"] == "ok", record.get("error")
    assert record["simulated_timing"] is True
    assert (record["min_interval"], record["apply_after"]) == (0.1, 0.1)
    assert record["num_plans"] >= 3
    # realised: plans start no more often than that, and act no sooner (a plan takes a few ms here)
    assert record["replan_interval_median"] >= 0.1 - 1e-9 and record["plan_latency_median"] >= 0.1 - 1e-9
    with pytest.raises(ConfigError, match="give either it or them"):
        run_job(base + timing + ["job.min_interval=0.2"], tmp_path / "both")
    with pytest.raises(ConfigError, match="its own latency"):
        run_job(base + ["loop=per_plan"], tmp_path / "per_plan")


class _InterruptingViewer:
    """Stands in for the viewer: Ctrl-C arrives in the plant's thread at its first sync from control time
    0.1 s on (``stopped_at``: that sync's time; a loaded machine syncs later, so it can be past 0.1 s)."""

    drags: list = []
    stopped_at: float | None = None

    def is_running(self) -> bool:
        return True

    def sync(self, data, t, lines) -> None:
        assert lines[0][0] == "time"  # the overlay's lines: (label, value)
        if t >= 0.1:
            self.stopped_at = t
            raise KeyboardInterrupt

    def close(self) -> None:
        pass


def test_ctrl_c_ends_an_online_run_with_a_record(apple_reference, tmp_path, monkeypatch):
    from contactmpc.jobs import online

    viewer = _InterruptingViewer()
    monkeypatch.setattr(online.LiveViewer, "open", lambda *args: viewer)
    overrides = ["job=online", "task=apple", f"task.reference_path={apple_reference}", "planner=replay"]
    overrides += ["job.viewer=true", "job.progress=false"]
    with pytest.raises(KeyboardInterrupt):
        run_job(overrides, tmp_path)
    record = json.loads((tmp_path / "trial.json").read_text())
    assert record["status"] == "interrupted" and record["error"] == "KeyboardInterrupt"
    assert viewer.stopped_at is not None and viewer.stopped_at >= 0.1
    assert record["simulated_seconds"] == pytest.approx(viewer.stopped_at, abs=0.01)  # how far it ran
    assert record["num_plans"] >= 1 and record["viewer"] is True
    assert np.load(tmp_path / "timeseries.npz")["time"][-1] <= viewer.stopped_at  # the series up to there


def test_the_viewer_is_optional_and_says_when_there_is_no_display(monkeypatch, capsys):
    from contactmpc import viewer

    monkeypatch.setattr(viewer, "display_problem", lambda: "X11: The DISPLAY environment variable is missing")
    assert viewer.LiveViewer.open(None, None, None, None) is None
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "contactmpc: no display (X11: The DISPLAY environment variable is missing): running headless"
    ]


def _display_command() -> list[str] | None:
    """How to run a command with a display: ``xvfb-run`` (Debian's ``xvfb``), or the one of ``DISPLAY``."""
    if shutil.which("xvfb-run"):
        return ["xvfb-run", "-a", "-s", "-screen 0 1024x640x24"]
    if os.environ.get("DISPLAY"):
        return []
    return None


@pytest.mark.slow
@pytest.mark.skipif(
    _display_command() is None, reason="no display: neither xvfb-run (apt install xvfb) nor DISPLAY"
)
def test_the_viewer_shows_the_plant_and_a_drag_moves_the_apple(apple_reference, tmp_path):
    """The viewer on a virtual display: a scripted mouse drag (the viewer's perturbation) lifts the plant's
    apple and is recorded with its time; the ghost is drawn."""
    script = REPO_ROOT / "tests" / "online_viewer_run.py"
    cmd = [*_display_command(), sys.executable, str(script), "--reference", apple_reference]
    cmd += ["--duration", "0.4", "--slowdown", "10", "--drag", "0.1", "0.3", "--pull", "0", "0", "0.2"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=REPO_ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out["viewer"] is True, done.stderr[-2000:]
    assert out["ghost_geoms"] > 10  # the reference hand and apple
    (drag,) = out["drags"]
    assert drag["body"] == out["object_body"] == "apple" and drag["kind"] == "translate"
    assert drag["start"] == pytest.approx(0.1, abs=0.01) and drag["end"] == pytest.approx(0.3, abs=0.01)
    assert drag["max_force"] > 0.5  # N: a 0.2 m pull on a ~0.2 kg apple; measured 4.0
    # the drag moved the plant's apple up (measured: 37 mm -> 100-116 mm), and only during the drag
    assert out["z_max"] > out["z_start"] + 0.03
    assert 0.1 < out["time_of_z_max"] <= 0.35
