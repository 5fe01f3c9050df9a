"""The end of a trial on constructed time series (no MuJoCo): the final milestone (*settled*: the object
at rest where the reference leaves it, let go where the reference lets go), the errors over the contact
span and after it, the record fields ``summarize`` builds from them, and the analysis of records with
and without those fields."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from analysis.aggregate import load_records
from analysis.operating_point import load as load_points
from analysis.operating_point import markdown as point_markdown
from analysis.operating_point import summary as point_summary
from analysis.paper_fig3 import fidelities
from analysis.paper_fig3 import load as fig3_load
from analysis.paper_fig3 import markdown as fig3_markdown
from analysis.report import markdown_report, summary_table
from contactmpc.control.release import ReleaseSchedule
from contactmpc.jobs.trial import summarize
from contactmpc.metrics import errors_by_window
from contactmpc.tasks import AppleTask, DoorknobTask
from contactmpc.tasks.base import sustained_to_end
from contactmpc.validate import ConfigError

DT = 0.05  # s between logged rows (the lite preset's replan period)
HOLD = 0.3  # s, job.milestone_hold
START = np.array([0.0, 0.0, 0.037, 1.0, 0.0, 0.0, 0.0])  # the apple on the table
FINAL = np.array([0.10, 0.0, 0.037, 1.0, 0.0, 0.0, 0.0])  # where the reference sets it down


def apple_log(release: float = 2.5, duration: float = 4.0):
    """The apple carried (held) from START to FINAL by t = 2 s, resting there, let go at ``release``.

    Returns:
        task, time (N,), object configurations (N, 7), held (N,) bool.
    """
    task = AppleTask(hand_home=[0.0] * 22)
    t = np.arange(int(round(duration / DT)) + 1) * DT
    s = np.clip(t / 2.0, 0.0, 1.0)[:, None]
    qo = (1.0 - s) * START + s * FINAL
    qo[:, 2] += 0.1 * np.sin(np.pi * s[:, 0])  # lifted on the way
    return task, t, qo, t < release - 1e-9


def test_sustained_to_end_is_the_final_run():
    t = np.arange(10) * 0.1
    mask = np.array([1, 1, 1, 1, 0, 0, 1, 1, 1, 1], bool)  # the early run is longer; only the last counts
    assert sustained_to_end(mask, t, 0.3) == pytest.approx(0.6)
    assert sustained_to_end(mask, t, 0.31) is None
    assert sustained_to_end(np.r_[mask[:-1], False], t, 0.0) is None  # not so at the last row
    assert sustained_to_end(np.ones(10, bool), t, 0.9) == 0.0


def test_placed_at_rest_and_let_go():
    task, t, qo, held = apple_log(release=2.5)
    assert task.settled(qo, FINAL, held, t, HOLD, let_go=True) == pytest.approx(2.5)
    # a few millimetres off the pose, and the rest noise of a real table, still count
    qo[t >= 2.5, 0] += 0.004 + 1e-4 * np.sin(t[t >= 2.5] * 40)
    assert task.settled(qo, FINAL, held, t, HOLD, let_go=True) == pytest.approx(2.55)


def test_knocked_off_after_being_set_down():
    """Set down and let go for 0.5 s (longer than the hold), then knocked to the floor: not settled."""
    task, t, qo, held = apple_log(release=2.5)
    fall = t >= 3.0
    qo[fall, :3] = FINAL[:3] + np.minimum(t[fall] - 3.0, 0.4)[:, None] / 0.4 * [0.3, 0.2, -1.1]
    assert task.settled(qo, FINAL, held, t, HOLD, let_go=True) is None
    # at rest on the floor, far from the final pose, for a full second: still not
    assert np.all(task.at_rest(qo, t)[t >= 3.5])


def test_carried_away_or_still_touched():
    task, t, qo, held = apple_log(release=10.0)  # never let go
    assert task.settled(qo, FINAL, held, t, HOLD, let_go=True) is None  # at the pose, but still touched
    # carried off in the grip: 0.5 m over the last 1.5 s, touched throughout
    away = t > 2.5
    qo[away, 1] += 0.5 * (t[away] - 2.5) / 1.5
    assert task.settled(qo, FINAL, held, t, HOLD, let_go=True) is None
    # let go, within the tolerance, but still sliding at 4 cm/s: not at rest
    task, t, qo, held = apple_log(release=2.5)
    slide = t >= 3.5
    qo[slide, 0] += 0.04 * (t[slide] - 3.5)  # 2 cm in the last 0.5 s: inside the 3 cm tolerance
    assert np.all(task.near_final(qo, FINAL)[slide])
    assert task.settled(qo, FINAL, held, t, HOLD, let_go=True) is None


def test_let_go_too_briefly_before_the_end():
    task, t, qo, held = apple_log(release=3.8)  # 0.2 s without contact before the trial ends at 4 s
    assert task.settled(qo, FINAL, held, t, HOLD, let_go=True) is None
    assert task.settled(qo, FINAL, held, t, hold=0.2, let_go=True) == pytest.approx(3.8)


def test_a_reference_that_ends_held_asks_for_the_object_held_at_its_final_pose():
    """The synthetic apple, bottle and stapler demonstrations end with the object held in the air."""
    task, t, qo, _ = apple_log()
    touching = np.ones(len(t), bool)
    # at rest from the first row whose step from the previous one is still (2.0 s ends the carry)
    assert task.settled(qo, FINAL, touching, t, HOLD, let_go=False) == pytest.approx(2.05)
    assert task.settled(qo, FINAL, ~touching, t, HOLD, let_go=False) is None  # dropped at the pose


def test_doorknob_left_where_the_reference_leaves_it():
    """The door's articulations (door, knob): the door stays open at -0.6 rad, the knob springs back."""
    task = DoorknobTask(hand_home=[0.0] * 22)
    t = np.arange(81) * DT
    qo = np.stack([-0.6 * np.clip(t / 2.0, 0, 1), 0.9 * (t < 2.5)], axis=1)  # knob released at 2.5 s
    held = t < 2.5
    final = np.array([-0.6, 0.0])
    assert task.settled(qo, final, held, t, HOLD, let_go=True) == pytest.approx(2.55)
    swung = qo.copy()
    swung[t >= 3.0, 0] = -0.6 + 0.3 * np.clip((t[t >= 3.0] - 3.0) / 0.5, 0, 1)  # swung back to -0.3
    assert task.settled(swung, final, held, t, HOLD, let_go=True) is None


# ------------------------------------------------------------------------------ errors by window
def test_errors_over_the_span_and_after_it():
    t = np.arange(11) * 0.5  # 0 .. 5 s
    err = np.array([9.0, 1.0, 1.0, 2.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0])
    out = errors_by_window(t, {"object_position_error": err}, (0.5, 2.5))
    assert out["object_position_error_span_mean"] == pytest.approx(9.0 / 5)  # rows 1..5, ends included
    assert out["object_position_error_span_final"] == 3.0
    assert out["object_position_error_after_mean"] == pytest.approx(6.0)  # rows 6..10
    assert out["object_position_error_after_final"] == 8.0
    last = errors_by_window(t, {"e": err}, (0.5, 5.0))  # the span reaches the end: nothing after it
    assert last["e_after_mean"] is None and last["e_after_final"] is None
    none = errors_by_window(t, {"e": err}, None)  # no contact expected during the trial
    assert set(none.values()) == {None}


def _trial_and_series(release: float, knocked: bool):
    """A fake finished trial of the apple and its log: expected contact from 0.5 s to 2.5 s, the
    reference at FINAL from 2 s on and let go at its end."""
    task, t, qo, held = apple_log(release=release)
    if knocked:
        qo[t >= 3.0, :3] = [0.4, 0.3, -0.7]
    n, links = len(t), 16
    expected = np.zeros((n, links), bool)
    expected[(t >= 0.5) & (t <= 2.5), :8] = True
    contacts = np.zeros((n, links), bool)
    contacts[held, 0] = True
    ref = apple_log()[2]
    err = task.layout.error(qo, ref)
    series = {
        "time": t,
        "contacts": contacts,
        "expected_contacts": expected,
        "object_qpos": qo,
        "expected_object_qpos": ref,
        "object_position_error": err.position,
        "object_rotation_error": err.rotation,
        "object_articulation_error": err.articulation,
        "plan_seconds": np.full(n, 0.01),
        "num_diverged": np.zeros(n, int),
    }
    track = SimpleNamespace(object_qpos=np.vstack([ref, ref[-1:]]), contact_active=expected[[-1]])
    trial = SimpleNamespace(
        duration=float(t[-1]),
        start_time=0.0,
        scene=SimpleNamespace(task=task),
        track=track,
        spline=SimpleNamespace(num_control_points=10),
        replan_interval=DT,
        latency=0.0,
        planner=SimpleNamespace(
            switch_timestep=None,
            switched_at=None,
            switches_back=False,
            latency_per_plan=False,
            pace_retry=None,
            acquire_error=None,
        ),
    )
    return series, trial


def test_summarize_records_the_end_of_the_trial():
    series, trial = _trial_and_series(release=2.5, knocked=False)
    rec = summarize(series, trial, wall=1.0, gap=0.3, min_expected=6, hold=HOLD)
    assert (rec["completed"], rec["milestone_lifted"], rec["milestone_handed_off"]) == (False, True, False)
    assert rec["settled"] and rec["settled_time"] == pytest.approx(2.5) and rec["reference_lets_go"]
    assert rec["finished_cleanly"] is False  # settled, but not completed: the hand-off pose is the apple's
    assert not any(k.startswith("milestone_") and "settle" in k for k in rec)  # not one of `completed`'s
    assert (rec["contact_span_start"], rec["contact_span_end"]) == (0.5, 2.5)
    assert rec["first_contact_time"] == series["time"][np.argmax(series["contacts"][:, 0])]
    touching = np.flatnonzero(series["contacts"].any(axis=-1))
    assert rec["last_contact_time"] == series["time"][touching[-1]] >= rec["first_contact_time"]
    untouched = {**series, "contacts": np.zeros_like(series["contacts"])}
    none = summarize(untouched, trial, wall=1.0, gap=0.3, min_expected=6, hold=HOLD)
    assert none["first_contact_time"] is None and none["last_contact_time"] is None
    assert rec["object_position_error_span_mean"] == pytest.approx(0.0)
    assert rec["object_position_error_after_mean"] == pytest.approx(0.0)
    assert "switch_time" not in rec  # only with planner.switch_timestep
    assert "retry_times" not in rec  # only with planner.pace_retry
    assert "error_plans" not in rec  # only with planner.acquire_error
    trial.planner = SimpleNamespace(
        switch_timestep=0.005,
        switched_at=None,
        switches_back=False,
        latency_per_plan=False,
        pace_retry=1.5,
        retried_at=[],
        acquire_error=(0.03, 0.35),
        error_plans=7,
    )
    rec = summarize(series, trial, wall=1.0, gap=0.3, min_expected=6, hold=HOLD)
    assert rec["switch_time"] is None and "switch_back_time" not in rec  # it never switched
    assert rec["retry_times"] == []  # it never tried the grasp again
    assert rec["error_plans"] == 7
    trial.planner.retried_at = [16.2]
    assert summarize(series, trial, wall=1.0, gap=0.3, min_expected=6, hold=HOLD)["retry_times"] == [16.2]
    trial.planner.switched_at = 1.25
    assert summarize(series, trial, wall=1.0, gap=0.3, min_expected=6, hold=HOLD)["switch_time"] == 1.25
    trial.planner.switches_back, trial.planner.switched_back_at = True, 2.5  # and back
    assert summarize(series, trial, wall=1.0, gap=0.3, min_expected=6, hold=HOLD)["switch_back_time"] == 2.5

    knocked, trial = _trial_and_series(release=2.5, knocked=True)
    rec = summarize(knocked, trial, wall=1.0, gap=0.3, min_expected=6, hold=HOLD)
    assert rec["settled"] is False and rec["settled_time"] is None and rec["finished_cleanly"] is False
    far = float(np.linalg.norm(np.subtract([0.4, 0.3, -0.7], FINAL[:3])))
    assert rec["object_position_error_span_mean"] == pytest.approx(0.0)  # the task itself was tracked
    assert rec["object_position_error_after_final"] == pytest.approx(far)
    rows_after = np.sum(knocked["time"] > 2.5 + 1e-9)
    rows_knocked = np.sum(knocked["time"] >= 3.0 - 1e-9)
    assert rec["object_position_error_after_mean"] == pytest.approx(far * rows_knocked / rows_after)
    assert rec["object_position_error_mean"] < rec["object_position_error_after_mean"]
    json.dumps(rec)  # a record: plain JSON

    # a task whose milestones a set-down can complete: completed, settled, finished cleanly
    series, trial = _trial_and_series(release=2.5, knocked=False)
    task = trial.scene.task
    task.conditions = lambda qo, expected: {"lifted": task.lift(qo) > task.LIFT}
    rec = summarize(series, trial, wall=1.0, gap=0.3, min_expected=6, hold=HOLD)
    assert rec["completed"] and rec["settled"] and rec["finished_cleanly"] is True


# ------------------------------------------------------------------------ analysis, old and new records
def _write(directory, name, record):
    run = directory / name
    run.mkdir(parents=True)
    (run / "trial.json").write_text(json.dumps(record))


def _record(seed, new: bool, **extra):
    config = {
        "planner": {"num_samples": 32, "horizon": 1.0, "replan_period": 0.05, "latency": 0.0},
        "fidelity": fidelities()["paper"],
        "seed": seed,
    }
    record = {
        "task": "paper_apple", "cost": "contact", "sampler": "pca_spline", "planner": "predictive_sampling",
        "seed": seed, "status": "ok", "ttf": 1.0, "completed": True, "milestone_lifted": True,
        "milestone_handed_off": True, "object_position_error_mean": 0.2, "final_object_position_error": 1.2,
        "replan_interval": 0.05, "latency": 0.0, "wall_seconds": 10.0, "config": config,
    }  # fmt: skip
    if new:
        record.update(
            settled=False, settled_time=None, reference_lets_go=True, finished_cleanly=False,
            object_position_error_span_mean=0.02, object_position_error_span_final=0.03,
            object_position_error_after_mean=0.9, object_position_error_after_final=1.2,
        )  # fmt: skip
    record.update(extra)
    return record


def test_analysis_reads_records_with_and_without_the_new_fields(tmp_path):
    old, new = tmp_path / "old", tmp_path / "new"
    for seed in range(2):
        _write(old, f"s{seed}", _record(seed, new=False))
        _write(new, f"s{seed + 2}", _record(seed + 2, new=True, finished_cleanly=bool(seed)))
    before = summary_table(load_records(old)).iloc[0]
    assert math.isnan(before["object_position_error_span_mean"])
    assert math.isnan(before["finished_cleanly_rate"])
    assert before["object_position_error_mean"] == pytest.approx(0.2)
    after = summary_table(load_records(new)).iloc[0]
    assert after["object_position_error_span_mean"] == pytest.approx(0.02)
    assert after["object_position_error_after_mean"] == pytest.approx(0.9)
    assert after["finished_cleanly_rate"] == pytest.approx(0.5)
    md = markdown_report(load_records(old, new))  # old and new in one table
    assert "mean obj. pos. err. in span (mm)" in md and "mean whole trial (mm)" in md
    assert "| 20.0 | 900.0 | 200.0 |" in markdown_report(load_records(new))
    assert "| — | — | 200.0 |" in markdown_report(load_records(old))
    df = load_records(new)
    df["fidelity"] = df["condition"] = "paper"
    assert "| 1/2 | 100.0 (100.0–100.0) | 20 / 900 / 200 |" in fig3_markdown(df)
    table = point_summary(load_points(old, new))
    assert table["trials"].tolist() == [4] and table["finished_cleanly"].tolist() == [1]
    assert table["error_span_mm"].iloc[0] == pytest.approx(20.0)  # the median of the records that have it
    assert "| 1/2 (2 unrecorded) |" in point_markdown(table, table.iloc[:0])  # old records: not 0


# ------------------------------------------------------------------ the release phase (release=open)
def _letting_go(scene, let_go_frame: int = 13):
    """tests.helpers.static_reference with every contact ended at ``let_go_frame`` (of 26, 1 s)."""
    from tests.helpers import static_reference

    ref = static_reference(scene, duration=1.0, frames=26)
    ref.contact_active[let_go_frame:] = False
    return ref


def test_the_release_term_counts_hand_object_contacts_once_the_reference_has_let_go(scene_for):
    """The scene's hand-object contact sensor counts real MuJoCo contacts (the apple moved onto a finger
    link: > 0; 1 m away: 0); the cost's release term is lambda_o * release_weight * that count on
    the steps after the reference's last expected contact, 0 before them and 0 with release_weight 0."""
    import mujoco

    from contactmpc.control.cost import TrackingCost
    from contactmpc.control.problem import Problem
    from contactmpc.control.samplers import PCASplineSpace

    scene = scene_for("apple")
    m, d = scene.plant_model, mujoco.MjData(scene.plant_model)
    found = scene.index.hand_object_contact
    assert len(found) == 1
    d.qpos[scene.index.object_qpos[:3]] += [1.0, 0.0, 0.0]  # the apple 1 m away from the hand
    mujoco.mj_forward(m, d)
    apart = d.sensordata.copy()
    assert apart[found].sum() == 0
    link = scene.index.link_bodies[5]
    d.qpos[scene.index.object_qpos[:3]] = d.xpos[link]  # the apple's centre at a finger link's origin
    mujoco.mj_forward(m, d)
    touching = d.sensordata.copy()
    assert touching[found].sum() >= 1

    ref = _letting_go(scene)
    cost = TrackingCost(lambda_o=2.0, release_weight=1e-3)
    problem = Problem.build(scene, ref, PCASplineSpace(0.2), cost, horizon=0.2)
    track = problem.track
    last = np.flatnonzero(track.contact_active.any(axis=1))[-1]
    before, after = slice(last - 5, last + 1), slice(last + 1, last + 7)
    for window, expected in ((before, 0.0), (after, 2.0 * 1e-3 * touching[found].sum())):
        sd = np.stack([np.tile(touching, (6, 1)), np.tile(apart, (6, 1))])  # (2 samples, 6 steps, nsd)
        terms = cost(sd, window)
        np.testing.assert_allclose(terms["release"][0], expected)
        np.testing.assert_array_equal(terms["release"][1], 0.0)
    plain = TrackingCost(lambda_o=2.0)
    Problem.build(scene, ref, PCASplineSpace(0.2), plain, horizon=0.2)
    assert not plain(np.tile(touching, (1, 6, 1)), after)["release"].any()


def test_the_wrist_is_sampled_around_the_last_contact_only_where_the_reference_lets_go(scene_for):
    """sampler.release.window: wrist noise on the control points around the reference's last expected
    contact (and, with root_window too, around the first); none where the reference ends held."""
    from contactmpc.control.cost import TrackingCost
    from contactmpc.control.problem import Problem
    from contactmpc.control.samplers import JointSplineSpace
    from tests.helpers import static_reference

    scene = scene_for("apple")
    num_root = scene.hand.num_root

    def wrist_sampled(ref, root_window=None, release_window=None):
        release = ReleaseSchedule(window=release_window)
        space = JointSplineSpace(0.2, root_sigma2=1e-4, root_window=root_window, release=release)
        problem = Problem.build(scene, ref, space, TrackingCost(), horizon=0.2, num_control_points=12)
        std = np.broadcast_to(problem.noise_std, (12, problem.theta0.shape[1]))
        assert np.all(std[:, num_root:] > 0)  # the fingers everywhere
        return std[:, :num_root].any(axis=1), problem

    ref = _letting_go(scene)  # last contact at frame 12 of 26 (0.48 s), slowed by the task's time_scale
    sampled, problem = wrist_sampled(ref, release_window=(-0.1, 0.1))
    last = np.flatnonzero(problem.track.contact_active.any(axis=1))[-1] * problem.track.dt
    expect = np.zeros(12, bool)
    expect[problem.spline.window_indices(last - 0.1, 0.2)] = True
    assert 0 < sampled.sum() < 12 and np.array_equal(sampled, expect)
    both, _ = wrist_sampled(ref, root_window=(0.0, 0.1), release_window=(-0.1, 0.1))
    assert both[problem.spline.window_indices(0.0, 0.1)].all() and (both >= sampled).all()
    held, _ = wrist_sampled(static_reference(scene, duration=1.0, frames=26), release_window=(-0.1, 0.1))
    assert not held.any()  # the reference never lets go: no release to sample the wrist for
    with pytest.raises(ValueError, match="sampler.release.window"):
        ReleaseSchedule(window=(1.0, 1.0))


def test_release_table_counts_the_end_of_each_variant(tmp_path):
    """analysis.release: per task x variant x fidelity the counts of completed, settled and finished
    cleanly, and the median errors over the span, after it and at the end."""
    from analysis.release import main, markdown, release_table

    for seed in range(3):
        settled = seed > 0
        _write(tmp_path, f"full{seed}", _record(seed, new=True))
        after = _record(seed, new=True, variant="release", settled=settled, finished_cleanly=settled)
        after.update(object_position_error_after_mean=0.01 * (seed + 1), final_object_position_error=0.02)
        after["config"]["cost"] = {"release_weight": 1e-3}
        _write(tmp_path, f"release{seed}", after)
    table = release_table(fig3_load(tmp_path)).set_index("variant")
    assert table.loc["full", "finished_cleanly"] == 0 and table.loc["release", "finished_cleanly"] == 2
    assert table.loc["release", "error_after"] == pytest.approx(0.02)
    assert table.loc["full", "error_after"] == pytest.approx(0.9)
    row = "| apple | release | paper | 3 | 3/3 | 2/3 | 2/3 | 20 / 20 / 20 mm |"
    assert row in markdown(table.reset_index())
    assert main([str(tmp_path)]) == 0 and main([str(tmp_path / "missing")]) == 2
    assert (
        main([str(tmp_path), "--variant", "release", "--task", "apple", "--out", str(tmp_path / "t.md")]) == 0
    )
    assert "| apple | full |" not in (tmp_path / "t.md").read_text()
    assert "| apple | release | paper | 3 |" in (tmp_path / "t.md").read_text()
    assert main([str(tmp_path), "--variant", "relase"]) == 2  # a misspelt filter is an error, not no rows
    from analysis.release import paired_markdown, release_figure

    paired = paired_markdown(fig3_load(tmp_path)).splitlines()
    assert paired[0] == "| task | seed | full | release |" and len(paired) == 2 + 3  # a row per seed
    assert paired[3].startswith("| apple | 1 | ") and paired[3].endswith(" 20 clean |")  # release, seed 1
    assert " done | " in paired[3] or " failed | " in paired[3]  # the full method's trial of that seed

    fig = release_figure(fig3_load(tmp_path), tmp_path / "release.png")
    assert (tmp_path / "release.png").stat().st_size > 1000
    (ax,) = fig.axes  # one task
    assert [t.get_text() for t in ax.get_xticklabels()] == ["full", "release"]
    dots = sum(len(c.get_offsets()) for c in ax.collections)
    assert dots == 6  # every trial, whatever its end
    # the final error instead, the variants in a given order, and a seed only one variant has
    _write(tmp_path, "release3", _record(3, new=True, variant="release", settled=True, finished_cleanly=True))
    loaded = fig3_load(tmp_path)
    final = paired_markdown(loaded, error="final", order=("release", "full"), unpaired=True).splitlines()
    assert final[0] == "| task | seed | release | full |" and len(final) == 2 + 4
    assert final[3].startswith("| apple | 1 | 20 clean | ") and final[-1].endswith(" clean |  |")
    assert len(paired_markdown(loaded).splitlines()) == 2 + 3  # paired only, by default
    with pytest.raises(ValueError, match="error must be"):
        paired_markdown(loaded, error="span")


def test_the_nominal_wrist_waits_at_the_last_contact_and_then_retreats_late():
    """sampler.release.pause: the root curves stop at the last contact for the pause and go on that much
    later; the fingers keep the reference's schedule; no pause where the reference ends held."""
    from contactmpc.control.release import paused
    from contactmpc.control.samplers import JointSplineSpace
    from contactmpc.reference.bspline import UniformBSpline

    t = np.linspace(0.0, 10.0, 101)
    x = np.stack([t, t**2], axis=-1)
    y = paused(t, x, at=4.0, pause=1.5)
    np.testing.assert_array_equal(y[t <= 4.0], x[t <= 4.0])
    np.testing.assert_allclose(y[(t >= 4.0) & (t <= 5.5)], np.tile(x[40], (16, 1)))
    np.testing.assert_allclose(y[t >= 5.5], np.stack([t - 1.5, (t - 1.5) ** 2], -1)[t >= 5.5], atol=0.01)
    qpos = np.concatenate([np.tile(x[:, :1], (1, 6)), np.sin(t)[:, None] * np.ones((1, 4))], axis=1)
    spline = UniformBSpline(40, (0.0, 10.0))
    ranges = np.tile([-100.0, 100.0], (10, 1))
    space = JointSplineSpace(0.2, release=ReleaseSchedule(pause=1.5))
    held = space.fit(spline, t, qpos, ranges, 6)  # no last contact: the reference as it is
    np.testing.assert_allclose(held, JointSplineSpace(0.2).fit(spline, t, qpos, ranges, 6))
    theta = space.fit(spline, t, qpos, ranges, 6, last_contact=4.0)
    curve = spline.basis(t) @ theta
    np.testing.assert_allclose(curve[:, 6:], spline.basis(t) @ held[:, 6:])  # the fingers unchanged
    mid = (t > 4.3) & (t < 5.2)
    np.testing.assert_allclose(curve[mid, 0], 4.0, atol=0.05)  # the wrist waits at its pose at 4 s
    late = t > 6.0
    np.testing.assert_allclose(curve[late, 0], t[late] - 1.5, atol=0.05)


def test_the_nominal_wrist_holds_still_from_before_the_last_contact():
    """sampler.release.hold: the root curves stop ``hold`` before the last contact, wait there for the hold
    and the pause, and go on that much later; hold 0 is the pause alone, bit for bit; a hold needs the
    reset that puts the committed wrist on it."""
    from contactmpc.control.samplers import JointSplineSpace
    from contactmpc.reference.bspline import UniformBSpline

    t = np.linspace(0.0, 10.0, 101)
    qpos = np.concatenate([np.tile(t[:, None], (1, 6)), np.sin(t)[:, None] * np.ones((1, 4))], axis=1)
    spline = UniformBSpline(40, (0.0, 10.0))
    ranges = np.tile([-100.0, 100.0], (10, 1))

    def fit(**release):
        return JointSplineSpace(0.2, release=ReleaseSchedule(**release)).fit(
            spline, t, qpos, ranges, 6, last_contact=4.0
        )

    np.testing.assert_array_equal(fit(reset=True, pause=1.5, hold=0.0), fit(pause=1.5))
    curve = spline.basis(t) @ fit(reset=True, pause=1.5, hold=1.0)
    np.testing.assert_allclose(curve[:, 6:], spline.basis(t) @ fit()[:, 6:])  # the fingers unchanged
    np.testing.assert_allclose(curve[t < 2.7, 0], t[t < 2.7], atol=0.05)  # the reference's until then
    mid = (t > 3.3) & (t < 5.2)
    np.testing.assert_allclose(curve[mid, 0], 3.0, atol=0.05)  # still from 1 s before the last contact
    late = t > 6.0
    np.testing.assert_allclose(curve[late, 0], t[late] - 2.5, atol=0.05)  # then on, 2.5 s late
    with pytest.raises(ConfigError, match="sampler.release.hold needs sampler.release.reset"):
        ReleaseSchedule(hold=1.0)


def test_release_hold_resets_the_committed_wrist_before_the_fingers(scene_for):
    """sampler.release.hold: at the first plan ``hold`` before the reference's last expected contact, the
    committed wrist control points whose support meets the rest of the trial go to the release nominal's
    (the fingers' stay as the plans left them); at the last contact the whole reset, as without it.
    Real rollouts (one sample: the nominal, so what is committed is what the plan started from)."""
    from contactmpc.control.cost import TrackingCost
    from contactmpc.control.planners.predictive_sampling import PredictiveSampling
    from contactmpc.control.problem import Problem
    from contactmpc.control.samplers import PCASplineSpace
    from tests.helpers import rest_state

    scene = scene_for("apple")
    state = rest_state(scene.plant_model)
    rng = np.random.default_rng(0)
    ref = _letting_go(scene)
    plain = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), horizon=0.2, num_control_points=12)
    hold = 0.5 * plain.last_contact
    space = PCASplineSpace(0.2, release=ReleaseSchedule(reset=True, open=0.1, pause=0.1, hold=hold))
    problem = Problem.build(scene, ref, space, TrackingCost(), horizon=0.2, num_control_points=12)
    np.testing.assert_array_equal(problem.theta0, plain.theta0)  # the reference's own until the reset
    planner = PredictiveSampling(num_samples=1, horizon=0.2, nthread=1)
    planner.bind(problem)
    planner.theta = problem.theta0 + 0.3
    walked = planner.theta.copy()
    at, root = problem.last_contact - hold, scene.hand.num_root
    planner.plan(at - 0.05, state, rng)  # before the hold: nothing reset
    np.testing.assert_array_equal(planner.theta, walked)
    planner.plan(at + 0.005, state, rng)
    points = problem.spline.window_indices(at, problem.spline.domain[1] - at)
    np.testing.assert_array_equal(planner.theta[points, :root], problem.release_theta[points, :root])
    np.testing.assert_array_equal(planner.theta[:, root:], walked[:, root:])  # the fingers as they were
    others = np.setdiff1d(np.arange(problem.spline.num_control_points), points)
    np.testing.assert_array_equal(planner.theta[others], walked[others])
    planner.plan(problem.last_contact + 0.005, state, rng)  # the last contact: the whole reset
    last = problem.spline.window_indices(
        problem.last_contact, problem.spline.domain[1] - problem.last_contact
    )
    np.testing.assert_array_equal(planner.theta[last], problem.release_theta[last])
    planner.close()


def test_the_nominal_fingers_open_to_the_first_pose_after_the_last_contact():
    """sampler.release.open: from the last contact the fingers go linearly back to the reference's first
    pose within the given time and stay there; before it, the reference's fingers."""
    from contactmpc.control.release import opened

    t = np.linspace(0.0, 10.0, 101)
    x = np.stack([1.0 + t, np.cos(t)], axis=-1)
    y = opened(t, x, at=4.0, duration=1.0)
    np.testing.assert_array_equal(y[t <= 4.0], x[t <= 4.0])
    np.testing.assert_allclose(y[t >= 5.0], np.tile(x[0], ((t >= 5.0).sum(), 1)))
    np.testing.assert_allclose(y[45], 0.5 * x[40] + 0.5 * x[0])  # half way at 4.5 s


def test_opening_the_nominal_fingers_keeps_the_reference_s_pca():
    """With release.open the PC space is still fitted to the reference's own finger curves (a PCA that
    also saw the opened nominal would change the sampling directions over the whole trial); only the
    nominal's control points after the last contact move."""
    from contactmpc.control.samplers import PCASplineSpace
    from contactmpc.reference.bspline import UniformBSpline

    t = np.linspace(0.0, 10.0, 201)
    rng = np.random.default_rng(0)
    fingers = np.sin(np.outer(t, rng.uniform(0.2, 1.0, 16)) + rng.uniform(0, 3, 16))
    qpos = np.concatenate([np.zeros((len(t), 6)), fingers], axis=1)
    spline, ranges = UniformBSpline(30, (0.0, 10.0)), np.tile([-10.0, 10.0], (22, 1))
    plain, opening = PCASplineSpace(0.2), PCASplineSpace(0.2, release=ReleaseSchedule(open=1.0))
    a = plain.fit(spline, t, qpos, ranges, 6)
    b = opening.fit(spline, t, qpos, ranges, 6, last_contact=6.0)
    np.testing.assert_allclose(opening.pca.components, plain.pca.components)
    early = spline.basis(t[t < 4.0])
    # the nominal before the release: moved only by the least-squares fit's coupling of control points
    np.testing.assert_allclose(early @ b, early @ a, atol=0.01)
    late = opening.finger_joints((spline.basis(t[t > 7.5]) @ b)[:, 6:])
    np.testing.assert_allclose(late, np.tile(fingers[0], (len(late), 1)), atol=0.05)  # opened to frame 0


def test_release_reset_puts_the_committed_control_points_back_to_the_nominal_when_the_reference_lets_go(
    scene_for,
):
    """sampler.release.reset: at the first plan at or after the reference's last expected contact, the
    committed control points whose support meets the rest of the trial go back to the release nominal
    (theta0, or the opened one with release.open), once; a plan before it, a space without it, or a
    reference that ends held leave them as they are.
    Real rollouts (one sample: the nominal, so what is committed is what the plan started from)."""
    from contactmpc.control.cost import TrackingCost
    from contactmpc.control.planners.predictive_sampling import PredictiveSampling
    from contactmpc.control.problem import Problem
    from contactmpc.control.samplers import PCASplineSpace
    from tests.helpers import assert_resets_once_at, rest_state, static_reference

    scene = scene_for("apple")
    state = rest_state(scene.plant_model)
    rng = np.random.default_rng(0)

    def walked(reference, reset: bool):
        """A planner bound to the reference whose committed points walked 0.3 from the nominal."""
        space = PCASplineSpace(0.2, release=ReleaseSchedule(reset=reset))
        problem = Problem.build(scene, reference, space, TrackingCost(), horizon=0.2, num_control_points=12)
        planner = PredictiveSampling(num_samples=1, horizon=0.2, nthread=1)
        planner.bind(problem)
        planner.theta = problem.theta0 + 0.3
        return planner, problem

    ref = _letting_go(scene)  # last expected contact at frame 12 of 26, slowed by the task's time_scale
    planner, problem = walked(ref, reset=True)
    last = problem.last_contact
    expected = np.flatnonzero(problem.track.contact_active.any(axis=1))
    assert last == pytest.approx(expected[-1] * problem.track.dt)
    reset = assert_resets_once_at(planner, problem, last, state, rng, problem.theta0)
    planner.close()
    # with an opening nominal: the reference's own until the last contact (bit for bit: the trial is the
    # full method's until then), the opened one from the reset on
    opening = PCASplineSpace(0.2, release=ReleaseSchedule(reset=True, open=0.1))
    problem = Problem.build(scene, ref, opening, TrackingCost(), horizon=0.2, num_control_points=12)
    plain = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), horizon=0.2, num_control_points=12)
    np.testing.assert_array_equal(problem.theta0, plain.theta0)
    assert np.abs(problem.release_theta[reset] - plain.theta0[reset]).max() > 1e-3
    planner = PredictiveSampling(num_samples=1, horizon=0.2, nthread=1)
    planner.bind(problem)
    planner.plan(last + 0.005, state, rng)
    np.testing.assert_array_equal(planner.theta[reset], problem.release_theta[reset])
    planner.close()
    for reference, reset_on in ((ref, False), (static_reference(scene, duration=1.0, frames=26), True)):
        planner, problem = walked(reference, reset_on)  # without the option; a reference that ends held
        planner.plan(0.9, state, rng)
        np.testing.assert_array_equal(planner.theta, problem.theta0 + 0.3)
        planner.close()


def test_release_blend_eases_the_committed_points_into_the_nominal(scene_for):
    """sampler.release.blend: the reset moves each control point from where the plans left it toward the
    release nominal by its Greville abscissa's share of the blend after the last contact: none at or before
    it, all of the way from ``blend`` after it on, a convex combination between; blend 0: the nominal."""
    from contactmpc.control.cost import TrackingCost
    from contactmpc.control.planners.predictive_sampling import PredictiveSampling
    from contactmpc.control.problem import Problem
    from contactmpc.control.samplers import PCASplineSpace

    scene = scene_for("apple")
    ref = _letting_go(scene)

    def reset(blend: float):
        space = PCASplineSpace(0.2, release=ReleaseSchedule(reset=True, open=0.1, blend=blend))
        problem = Problem.build(scene, ref, space, TrackingCost(), horizon=0.2, num_control_points=24)
        planner = PredictiveSampling(num_samples=1, horizon=0.2, nthread=1)
        planner.bind(problem)
        planner.theta = problem.theta0 + 0.3
        committed = planner.theta.copy()
        points = planner.release()
        planner.close()
        return problem, points, committed, planner.theta

    problem, points, committed, at_once = reset(0.0)
    np.testing.assert_array_equal(at_once[points], problem.release_theta[points])
    blend = 0.5
    problem, same, committed, eased = reset(blend)
    np.testing.assert_array_equal(same, points)
    spline, last = problem.spline, problem.last_contact
    k, knots = spline.degree, spline.knots
    greville = np.array([knots[j + 1 : j + k + 1].mean() for j in points])
    weight = np.clip((greville - last) / blend, 0.0, 1.0)
    assert (weight == 0).any() and (weight == 1).any() and ((weight > 0) & (weight < 1)).any()
    nominal = problem.release_theta[points]
    np.testing.assert_array_equal(eased[points][weight == 0], committed[points][weight == 0])
    np.testing.assert_allclose(eased[points][weight == 1], nominal[weight == 1], atol=1e-12)
    mid = (weight > 0) & (weight < 1)
    np.testing.assert_allclose(
        eased[points][mid],
        committed[points][mid] + weight[mid, None] * (nominal[mid] - committed[points][mid]),
    )
    untouched = np.setdiff1d(np.arange(spline.num_control_points), points)
    np.testing.assert_array_equal(eased[untouched], committed[untouched])


def test_release_noise_scales_the_sampling_after_the_last_contact_only():
    """sampler.release.noise: the rows of the control points whose support lies after the last expected
    contact get that fraction of the noise; the others keep theirs; no change where the reference ends
    held (no last contact), and the root-window masking still applies."""
    from contactmpc.control.samplers import JointSplineSpace
    from contactmpc.reference.bspline import UniformBSpline

    spline = UniformBSpline(20, (0.0, 10.0))
    t = np.linspace(0.0, 10.0, 101)
    qpos = np.concatenate([np.zeros((101, 6)), np.sin(t)[:, None] * np.ones((1, 4))], axis=1)
    ranges = np.tile([-10.0, 10.0], (10, 1))
    space = JointSplineSpace(0.04, root_sigma2=1e-4, release=ReleaseSchedule(noise=0.0))
    space.fit(spline, t, qpos, ranges, 6, last_contact=6.0)
    std = space.point_noise_std(spline, first_contact=1.0, last_contact=6.0)
    after = spline.knots[:20] >= 6.0
    assert 0 < after.sum() < 20
    np.testing.assert_array_equal(std[after], 0.0)
    np.testing.assert_allclose(std[~after, 6:], 0.2)
    np.testing.assert_allclose(std[~after, :6], 0.01)
    np.testing.assert_array_equal(space.point_noise_std(spline, 1.0, None), space.noise_std)  # ends held
    half = JointSplineSpace(0.04, root_window=(0.0, 1.0), release=ReleaseSchedule(noise=0.5))
    half.fit(spline, t, qpos, ranges, 6, last_contact=6.0)
    std = half.point_noise_std(spline, first_contact=1.0, last_contact=6.0)
    np.testing.assert_allclose(std[after, 6:], 0.1)
    assert not std[after, :6].any()  # the wrist, outside its window, stays unsampled
    with pytest.raises(ValueError, match="ReleaseSchedule.noise"):
        ReleaseSchedule(noise=-1.0)


def test_the_nominal_wrist_backs_off_and_the_fingers_open_to_the_flat_hand():
    """sampler.release.backoff: the wrist slides shift by ``backoff`` x the release direction,
    growing over ``backoff_window`` after the last contact and kept; its hinges and everything
    before the window are the reference's. sampler.release.open_to=flat: the fingers open to 0 within
    their ranges. No change where the reference ends held; a back-off without a direction is refused."""
    from contactmpc.control.release import backed_off
    from contactmpc.control.samplers import JointSplineSpace
    from contactmpc.reference.bspline import UniformBSpline

    t = np.linspace(0.0, 10.0, 101)
    x = np.stack([t, np.sin(t)], axis=-1)
    y = backed_off(t, x, np.array([1.0, -2.0]), start=4.0, end=6.0)
    np.testing.assert_array_equal(y[t <= 4.0], x[t <= 4.0])
    np.testing.assert_allclose(y[t >= 6.0], x[t >= 6.0] + [1.0, -2.0])
    np.testing.assert_allclose(y[50], x[50] + [0.5, -1.0])  # half way at 5 s

    qpos = np.concatenate([np.stack([np.cos(t)] * 6, -1), np.stack([0.5 + 0.3 * np.sin(t)] * 4, -1)], axis=1)
    spline = UniformBSpline(40, (0.0, 10.0))
    ranges = np.tile([-3.0, 3.0], (10, 1))
    ranges[6] = [0.2, 1.0]  # a joint whose range excludes 0 (the Allegro thumb's first): opens to 0.2
    direction = np.array([0.0, 0.6, 0.8])
    space = JointSplineSpace(
        0.2, release=ReleaseSchedule(open=1.0, open_to="flat", backoff=0.1, backoff_window=(0.5, 1.5))
    )
    plain = JointSplineSpace(0.2).fit(spline, t, qpos, ranges, 6)
    np.testing.assert_allclose(space.fit(spline, t, qpos, ranges, 6), plain)  # ends held: as it is
    theta = space.fit(spline, t, qpos, ranges, 6, last_contact=4.0, release_direction=direction)
    curve, base = spline.basis(t) @ theta, spline.basis(t) @ plain
    early, late = t < 3.5, t > 6.0
    np.testing.assert_allclose(curve[early], base[early], atol=0.01)
    np.testing.assert_allclose(curve[late, :3], base[late, :3] + 0.1 * direction, atol=0.01)
    np.testing.assert_allclose(curve[late, 3:6], base[late, 3:6], atol=0.01)  # the hinges: not moved
    np.testing.assert_allclose(curve[late, 6:], np.tile([0.2, 0.0, 0.0, 0.0], (late.sum(), 1)), atol=0.01)
    with pytest.raises(ValueError, match="release direction"):
        space.fit(spline, t, qpos, ranges, 6, last_contact=4.0)
    with pytest.raises(ValueError, match="ReleaseSchedule.open_to"):
        ReleaseSchedule(open_to="closed")


def test_the_release_direction_points_from_the_expected_contacts_to_the_palm(scene_for):
    """Problem.build gives the space the release direction: with the hand and the object posed as the
    reference has them at its last expected contact (checked here on the plant model, posed again),
    the unit vector from the centroid of the expected contacts' object points, in the world, to the
    palm; the release nominal's wrist ends that far along it and no earlier nominal moves."""
    import mujoco

    from contactmpc.control.cost import TrackingCost
    from contactmpc.control.problem import Problem, release_direction
    from contactmpc.control.samplers import PCASplineSpace

    scene = scene_for("apple")
    ref = _letting_go(scene)
    space = PCASplineSpace(0.2, release=ReleaseSchedule(reset=True, backoff=0.05, backoff_window=(0.0, 0.1)))
    problem = Problem.build(scene, ref, space, TrackingCost(), horizon=0.2, num_control_points=12)
    plain = Problem.build(scene, ref, PCASplineSpace(0.2), TrackingCost(), horizon=0.2, num_control_points=12)
    np.testing.assert_array_equal(problem.theta0, plain.theta0)
    track, idx = problem.track, scene.index
    step = int(np.flatnonzero(track.contact_active.any(axis=1))[-1])
    m, d = scene.plant_model, mujoco.MjData(scene.plant_model)
    d.qpos[idx.hand_qpos] = ref.hand_qpos[track.frame[step]]
    d.qpos[idx.object_qpos] = track.object_qpos[step]
    mujoco.mj_forward(m, d)
    points = [
        d.xpos[idx.object_bodies[track.contact_object_body[step, k]]]
        + d.xmat[idx.object_bodies[track.contact_object_body[step, k]]].reshape(3, 3)
        @ track.contact_object_point[step, k]
        for k in np.flatnonzero(track.contact_active[step])
    ]
    away = d.xpos[idx.link_bodies[0]] - np.mean(points, axis=0)
    direction = release_direction(scene, track, step)
    np.testing.assert_allclose(np.linalg.norm(direction), 1.0)
    np.testing.assert_allclose(direction, away / np.linalg.norm(away), atol=1e-9)
    end = problem.spline.basis(np.array([problem.spline.domain[1]]))
    shift = (end @ problem.release_theta - end @ plain.theta0)[0]
    np.testing.assert_allclose(shift[:3], 0.05 * direction, atol=2e-3)
    np.testing.assert_allclose(shift[3:6], 0.0, atol=2e-3)


def test_plan_latencies_count_the_plans_a_trial_ran_not_its_whole_schedule():
    """With planner.latency_per_plan the record's plan_latencies count the schedule's plans up to the last
    logged one: a trial cut short (diverged) lists only the plans it made, as many as its log's rows."""
    series, trial = _trial_and_series(release=2.5, knocked=False)
    step = 0.001
    trial.scene.plant_model = SimpleNamespace(opt=SimpleNamespace(timestep=step))
    trial.planner.latency_per_plan = True
    every = int(round(DT / step))  # a plan each logged row, 150 ms until 1 s, 50 ms after
    trial.schedule = lambda: [(k, 150 if k < 1000 else 50, every) for k in range(0, 4000 + 1, every)]
    whole = summarize(series, trial, wall=1.0, gap=0.3, min_expected=6, hold=HOLD)["plan_latencies"]
    assert whole == {"0.050": len(series["time"]) - 20, "0.150": 20}
    cut = {k: v[:30] for k, v in series.items()}  # the log of a trial that stopped at 1.45 s
    short = summarize(cut, trial, wall=1.0, gap=0.3, min_expected=6, hold=HOLD)["plan_latencies"]
    assert short == {"0.050": 10, "0.150": 20} and sum(short.values()) == len(cut["time"])


PINCH = """
<mujoco>
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="root" pos="0 0 0.2">
      <joint name="x" type="slide" axis="1 0 0"/><joint name="y" type="slide" axis="0 1 0"/>
      <joint name="z" type="slide" axis="0 0 1"/><joint name="rx" axis="1 0 0"/>
      <joint name="ry" axis="0 1 0"/><joint name="rz" axis="0 0 1"/>
      <geom type="box" size="0.05 0.02 0.01"/>
      <body name="left" pos="-0.04 0 -0.02">
        <joint name="l" axis="0 1 0"/><geom name="l" type="capsule" fromto="0 0 0 0 0 -0.08" size="0.01"/>
      </body>
      <body name="right" pos="0.04 0 -0.02">
        <joint name="r" axis="0 1 0"/><geom name="r" type="capsule" fromto="0 0 0 0 0 -0.08" size="0.01"/>
      </body>
    </body>
    <body name="box" pos="0 0 0.13">
      <joint name="knob" {joint}/><geom name="b" type="box" size="0.031 0.02 0.02"/>
    </body>
  </worldbody>
</mujoco>
"""


def _pinch(joint: str):
    """A two-finger hand (6 wrist joints, 2 fingers) pinching a box 1 mm deep on each side along x, the
    box on ``joint``; its model, data (forwarded) and a scene index of the fields the retraction reads."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(PINCH.format(joint=joint))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    box = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "box")
    index = SimpleNamespace(
        hand_qpos=np.arange(8),
        hand_dof=np.arange(8),
        object_body_mask=np.arange(model.nbody) == box,
        object_bodies=np.array([box]),
        root_body=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "root"),
        object_dof=np.arange(8, model.nv),
    )
    return model, data, index


def test_the_retraction_moves_each_contact_point_off_along_its_normal():
    """sampler.release.retract: the fingers' change moves the hand-object contact points ``distance`` off
    the object along their normals (through the contact Jacobians; the wrist still), so the hand at it
    touches nothing; the wrist leaves across the slide the object moves on (a free object: straight off)."""
    import mujoco

    from contactmpc.control.release import retraction

    model, data, index = _pinch('type="slide" axis="1 0 0"')
    assert data.ncon >= 2
    q, dq, away = retraction(model, data, index, 0.005)
    np.testing.assert_array_equal(q, data.qpos[:8])
    np.testing.assert_array_equal(dq[:6], 0.0)  # the wrist is held
    off = []
    for i in range(data.ncon):
        c = data.contact[i]
        box_second = model.geom_bodyid[c.geom2] == index.object_bodies[0]  # the frame: geom1 to geom2
        hand = model.geom_bodyid[c.geom1] if box_second else model.geom_bodyid[c.geom2]
        into_box = np.array(c.frame[:3]) * (1.0 if box_second else -1.0)
        jacp = np.zeros((3, model.nv))
        mujoco.mj_jac(model, data, jacp, None, c.pos, hand)
        off.append(-(jacp[:, :8] @ dq) @ into_box)
    # every contact point moves off along its normal, by the distance in the least-squares sense (a hinged
    # finger touching at two points moves the one further from its hinge more)
    assert min(off) > 0.0 and 0.8 * 0.005 < np.mean(off) < 1.25 * 0.005, off
    data.qpos[:8] = q + dq
    mujoco.mj_forward(model, data)
    assert data.ncon == 0  # retracted 5 mm from a 1 mm pinch: off the box
    np.testing.assert_allclose(away, [0.0, 0.0, 1.0], atol=1e-9)  # across the slide (x), toward the palm

    model, data, index = _pinch('type="free"')
    *_, away = retraction(model, data, index, 0.005)
    np.testing.assert_allclose(away, [0.0, 0.0, 1.0], atol=1e-9)  # straight off a free object


def test_the_retraction_margin_moves_off_a_finger_resting_just_apart():
    """sampler.release.retract_margin: with the box shifted so that one finger pinches it and the other
    is half a millimetre off, the retraction leaves the one apart where it is; with a 1 mm margin that one
    counts as touching and moves off too, along the line to the box, and the other retracts as before."""
    import mujoco

    from contactmpc.control.release import retraction

    model, data, index = _pinch('type="slide" axis="1 0 0"')
    data.qpos[8] = 0.0015  # the box 1.5 mm toward the right finger: 2.5 mm into it, 0.5 mm off the left
    mujoco.mj_forward(model, data)
    left, right, box = (mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, n) for n in ("l", "r", "b"))

    def gap(q, geom):
        data.qpos[:8] = q
        mujoco.mj_forward(model, data)
        return mujoco.mj_geomDistance(model, data, geom, box, 0.1, None)

    q0 = data.qpos[:8].copy()
    assert 0.0 < gap(q0, left) < 0.001 and gap(q0, right) < 0.0
    _, dq, _ = retraction(model, data, index, 0.005)
    assert dq[6] == 0.0 and dq[7] != 0.0  # only the finger in contact moves
    _, dq_margin, _ = retraction(model, data, index, 0.005, margin=0.001)
    assert gap(q0 + dq_margin, left) > gap(q0, left) + 0.0015  # the resting finger moved off
    np.testing.assert_allclose(dq_margin[7], dq[7], rtol=1e-3)  # the pinching one retracts as before
    _, dq_far, _ = retraction(model, data, index, 0.005, margin=0.0004)
    np.testing.assert_array_equal(dq_far, dq)  # 0.5 mm off is beyond a 0.4 mm margin


def test_retracted_targets_drop_the_squeeze_then_retract_and_move_off():
    schedule = ReleaseSchedule(reset=True, retract=0.02, retract_time=1.0, retract_away=0.08)
    q, dq, away = np.arange(8.0), np.r_[np.zeros(6), 0.4, -0.2], np.array([0.0, 0.6, 0.8])
    u = schedule.retracted(np.array([2.0, 2.5, 3.0, 3.5, 10.0]), 2.0, q, dq, away)
    np.testing.assert_allclose(u[0], q)  # at the start: where the hand was measured, no squeeze
    np.testing.assert_allclose(u[1], q + 0.5 * dq)
    np.testing.assert_allclose(u[2], q + dq)
    np.testing.assert_allclose(u[3], q + dq)  # the wait before the wrist moves off
    np.testing.assert_allclose(u[4, :3], q[:3] + 0.08 * away)
    np.testing.assert_allclose(u[4, 3:], (q + dq)[3:])
    with pytest.raises(ConfigError, match=r"^sampler.release.retract needs sampler.release.reset"):
        ReleaseSchedule(retract=0.02)


def test_a_retracting_planner_stops_following_its_plans_at_the_release(scene_for):
    """From the first plan at or after the reference's last expected contact the targets are the
    retraction from that plan's state; before it, and without ``retract``, the committed policy's, bit
    for bit. Real rollouts."""
    import mujoco

    from contactmpc.control.cost import TrackingCost
    from contactmpc.control.planners.predictive_sampling import PredictiveSampling
    from contactmpc.control.problem import Problem
    from contactmpc.control.release import retraction
    from contactmpc.control.samplers import PCASplineSpace
    from tests.helpers import rest_state

    scene = scene_for("apple")
    state = rest_state(scene.plant_model)
    ref = _letting_go(scene)
    out = {}
    for retract in (0.0, 0.02):
        space = PCASplineSpace(0.2, release=ReleaseSchedule(reset=True, open=0.1, retract=retract))
        problem = Problem.build(scene, ref, space, TrackingCost(), horizon=0.2, num_control_points=12)
        planner = PredictiveSampling(num_samples=4, horizon=0.2, nthread=1)
        planner.bind(problem)
        rng = np.random.default_rng(0)
        start = problem.last_contact + 0.005
        times = np.array([problem.last_contact - 0.3, start, start + 0.5, start + 3.0])
        before = planner.plan(problem.last_contact - 0.3, state, rng)
        early = planner.targets(times)
        planner.plan(start, state, rng)
        out[retract] = (before.best_cost, early, planner.targets(times))
        planner.close()
    (cost0, early0, late0), (cost1, early1, late1) = out[0.0], out[0.02]
    assert cost0 == cost1  # the same plans until the release
    np.testing.assert_array_equal(early0, early1)
    np.testing.assert_array_equal(late0[0], late1[0])  # before the retraction's start: the policy's
    m = scene.planner_model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_forward(m, d)
    q, dq, _ = retraction(m, d, scene.index, 0.02)
    np.testing.assert_array_equal(late1[1], state[1 + scene.index.hand_qpos])  # as measured: no squeeze
    np.testing.assert_allclose(late1[2], q + 0.5 * dq)
    np.testing.assert_allclose(late1[3], q + dq)  # retracted, the wrist where it was
    assert not np.allclose(late0[2:], late1[2:])


def _retracting_planner(scene, **release):
    """A bound two-sample planner of the letting-go reference whose release retracts 2 cm (``release``:
    more of the schedule's options); ``(planner, problem)``."""
    from contactmpc.control.cost import TrackingCost
    from contactmpc.control.planners.predictive_sampling import PredictiveSampling
    from contactmpc.control.problem import Problem
    from contactmpc.control.samplers import PCASplineSpace

    schedule = ReleaseSchedule(reset=True, open=0.1, retract=0.02, **release)
    space = PCASplineSpace(0.2, release=schedule)
    problem = Problem.build(
        scene, _letting_go(scene), space, TrackingCost(), horizon=0.2, num_control_points=12
    )
    planner = PredictiveSampling(num_samples=2, horizon=0.2, nthread=1)
    planner.bind(problem)
    return planner, problem


def test_retract_again_moves_off_the_contacts_each_later_plan_finds(scene_for):
    """sampler.release.retract_again: a later plan whose state still has the hand on the object starts a
    new retraction from the targets then; without it the first retraction goes on. Real rollouts (the
    apple's rest state, where the hand at its zero pose touches the apple)."""
    import mujoco

    from contactmpc.control.release import retraction
    from tests.helpers import rest_state

    scene = scene_for("apple")
    state = rest_state(scene.plant_model)
    m = scene.planner_model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_forward(m, d)
    q, dq, _ = retraction(m, d, scene.index, 0.02)
    assert np.any(dq)  # the state has hand-object contacts
    out = {}
    for again in (False, True):
        planner, problem = _retracting_planner(scene, retract_again=again)
        rng = np.random.default_rng(0)
        start = problem.last_contact + 0.005
        planner.plan(start, state, rng)
        planner.plan(start + 0.3, state, rng)  # the same state: the hand still on the apple
        out[again] = planner.targets(start + np.array([0.3, 0.8, 1.3, 5.0]))
        planner.close()
    np.testing.assert_allclose(out[False][3], q + dq)  # once: retracted, then held
    now = q + 0.3 * dq  # the targets when the second plan found the hand still there
    np.testing.assert_allclose(out[True][0], now)
    np.testing.assert_allclose(out[True][1], now + 0.5 * dq)
    np.testing.assert_allclose(out[True][3], now + dq)


def test_articulated_only_lets_a_free_object_go_as_without_the_hold_and_the_retraction(scene_for):
    """sampler.release.articulated_only: on the apple (a free body) the problem's schedule drops the wrist's
    hold and the retraction, and its nominals, plans and targets are those of the same schedule without
    them, bit for bit (real rollouts); the space it was given is left as it was. On the doorknob (a knob on
    joints) the schedule is kept."""
    from contactmpc.control.cost import TrackingCost
    from contactmpc.control.planners.predictive_sampling import PredictiveSampling
    from contactmpc.control.problem import Problem
    from contactmpc.control.release import has_free_body
    from contactmpc.control.samplers import PCASplineSpace
    from tests.helpers import rest_state

    base = dict(reset=True, open=0.1, blend=0.1)
    rule = dict(hold=0.2, retract=0.02, retract_again=True, retract_margin=0.001)
    doorknob = scene_for("doorknob")
    assert not has_free_body(doorknob.planner_model, doorknob.index)
    space = PCASplineSpace(0.2, release=ReleaseSchedule(**base, **rule, articulated_only=True))
    problem = Problem.build(doorknob, _letting_go(doorknob), space, TrackingCost(), horizon=0.2)
    assert problem.space is space and problem.space.release.retract == 0.02

    scene = scene_for("apple")
    assert has_free_body(scene.planner_model, scene.index)
    state = rest_state(scene.plant_model)
    out = []
    for schedule in (ReleaseSchedule(**base, **rule, articulated_only=True), ReleaseSchedule(**base)):
        space = PCASplineSpace(0.2, release=schedule)
        problem = Problem.build(
            scene, _letting_go(scene), space, TrackingCost(), horizon=0.2, num_control_points=12
        )
        assert space.release is schedule  # the given space keeps its schedule
        assert problem.space.release.hold == 0.0 and problem.space.release.retract == 0.0
        planner = PredictiveSampling(num_samples=4, horizon=0.2, nthread=1)
        planner.bind(problem)
        rng = np.random.default_rng(3)
        for t in (problem.last_contact - 0.25, problem.last_contact + 0.005, problem.last_contact + 0.3):
            planner.plan(t, state, rng)
        out.append(
            (problem.theta0, problem.release_theta, planner.theta, planner.targets(np.linspace(0, 1, 9)))
        )
        planner.close()
    for a, b in zip(*out, strict=True):
        np.testing.assert_array_equal(a, b)


def test_the_prediction_follows_the_retraction_not_the_plans(scene_for):
    """With compensation=predict the plan's start is the planning model rolled forward under what the
    plant will be given: after the retraction began, its targets, not the committed policy's."""
    from tests.helpers import rest_state

    scene = scene_for("apple")
    state = rest_state(scene.plant_model)
    planner, problem = _retracting_planner(scene)
    start = problem.last_contact + 0.005
    planner.plan(start, state, np.random.default_rng(0))
    seen = []
    run = planner.engine.run
    planner.engine.run = lambda s, ctrl: (seen.append(ctrl.copy()), run(s, ctrl))[1]
    t = start + 0.2
    planner.predict(t, state, 0.1)
    clock = t + np.arange(seen[0].shape[1]) * planner.dt
    np.testing.assert_array_equal(seen[0][0][:, scene.index.actuators], planner.targets(clock))
    planner.close()
