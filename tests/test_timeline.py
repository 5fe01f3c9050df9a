"""analysis.timeline: the diagnosis on constructed series, and the command line on a synthetic record."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from analysis.timeline import diagnose, first_run, main, milestone_times, runs
from contactmpc.metrics import time_to_failure

T = np.round(np.arange(0.0, 10.0, 0.05), 10)  # (N,) a replan every 50 ms
L = 21  # the Allegro hand's contact links


def expected_grasp(n: int = 11, start: float = 2.0) -> np.ndarray:
    """(N, L): the first ``n`` links expected in contact from ``start`` on."""
    exp = np.zeros((len(T), L), bool)
    exp[T >= start - 1e-9, :n] = True
    return exp


def test_runs_and_first_run() -> None:
    mask = np.array([0, 1, 1, 0, 1, 1, 1, 1], bool)
    assert runs(mask) == [(1, 3), (4, 8)]
    t = np.arange(8) * 0.1
    assert first_run(mask, t, 0.1) == 1
    assert first_run(mask, t, 0.3) == 4
    assert first_run(mask, t, 0.5) is None


def test_never_reached_contact() -> None:
    exp = expected_grasp()
    lines = diagnose(T, np.zeros_like(exp), exp, np.zeros(len(T)), completed=False)
    assert lines[0] == "first: never reached contact (expected from t=2.00 s, up to 11 links)"
    assert lines[-1] == "not completed"


def test_lost_contact_at_a_known_time() -> None:
    exp = expected_grasp()
    touch = exp.copy()
    touch[T >= 6.0 - 1e-9] = False  # the hand lets go at 6 s; 11 > 6 links stay expected
    ttf = time_to_failure(T, touch, exp, 0.3, 6)
    assert ttf.failure_time == pytest.approx(6.0)
    lines = diagnose(T, touch, exp, np.zeros(len(T)), failure_time=ttf.failure_time, completed=False)
    assert lines[0] == "first: lost contact at t=6.00 s (expected 11 links, touching 0; 11 at t=5.95 s)"


def test_contact_gap_the_failure_rule_lets_pass() -> None:
    exp = expected_grasp(n=6)  # 6 links: not more than six, so the rule never fires
    touch = exp.copy()
    touch[T >= 5.0 - 1e-9] = False
    assert not time_to_failure(T, touch, exp, 0.3, 6).failed
    lines = diagnose(T, touch, exp, completed=False)
    gap = "first: no contact from t=5.00 s to the end while up to 6 links expected"
    assert lines[0] == gap + " (the failure rule needs > 6)"


def test_dropped_object() -> None:
    exp = expected_grasp()
    touch = exp.copy()
    ref_z = np.clip((T - 3.0) / 2.0, 0.0, 1.0) * 0.10  # the reference lifts 10 cm from 3 to 5 s
    z = np.where(T < 7.0, ref_z, 0.0)  # the plant follows, then drops the object at 7 s
    touch[T >= 7.0, 2:] = False  # two fingertips still brush it: no contact failure
    milestones = {"lifted": 3.5, "handed_off": False}
    lines = diagnose(
        T, touch, exp, np.abs(z - ref_z), heights=(z, ref_z), milestones=milestones, completed=False
    )
    assert lines[0].startswith("first: object dropped (100 mm below reference) at t=7.00 s: position error")
    assert lines[0].endswith("while touching 2 of 11 links expected")
    assert "milestones: lifted at t=3.50 s, handed_off not reached" in lines


def test_object_not_lifted_is_no_drop() -> None:
    exp = expected_grasp()
    ref_z = np.clip((T - 3.0) / 2.0, 0.0, 1.0) * 0.10
    lines = diagnose(T, exp, exp, ref_z, heights=(np.zeros(len(T)), ref_z))
    assert lines[0].startswith("first: object not lifted")


def test_completed() -> None:
    exp = expected_grasp()
    milestones = {"lifted": 1.0, "handed_off": 8.0}  # 1.0 is an instant, not the flag True
    lines = diagnose(T, exp, exp, np.full(len(T), 0.005), milestones=milestones, completed=True)
    assert lines == ["completed", "milestones: lifted at t=1.00 s, handed_off at t=8.00 s"]
    assert diagnose(T, exp, exp, milestones={"lifted": True})[-1] == "milestones: lifted reached"


def write_run(run: Path, status: str = "ok", series: bool = True, hand: bool = True) -> Path:
    """A synthetic apple trial with a real record's fields: the apple is lifted, then dropped at 7 s."""
    n = len(T)
    exp = expected_grasp()
    touch = exp & (T < 7.0)[:, None]
    ref = np.tile([0.0, 0.0, 0.037, 1.0, 0.0, 0.0, 0.0], (n, 1))
    ref[:, 2] += np.clip((T - 3.0) / 2.0, 0.0, 1.0) * 0.10  # lift 10 cm from 3 to 5 s ...
    ref[:, 0] += np.clip((T - 7.0) / 2.0, 0.0, 1.0) * 0.10  # ... carry 10 cm from 7 to 9 s
    obj = ref.copy()
    obj[T >= 7.0, :3] = [0.0, 0.0, 0.037]  # dropped at 7 s
    pos_err = np.linalg.norm(obj[:, :3] - ref[:, :3], axis=-1)
    ttf = time_to_failure(T, touch, exp, 0.3, 6)
    config = {
        "task": {
            "_target_": "contactmpc.tasks.AppleTask",
            **{"radius": 0.041, "height_ratio": 0.9, "mass": 0.2, "position": [0.0, 0.0], "friction": 1.0},
            **{"hand_home": [0.0] * 22, "time_scale": 2.0, "reference_path": None},
            "demonstration": {"_target_": "contactmpc.reference.synthetic.designs.AppleDemo"},
        },
        "hand": {"_target_": "contactmpc.hands.AllegroHand", "kp_finger": 10.0, "name": "allegro_right"},
        "job": {"failure_gap": 0.3, "failure_min_expected": 6, "milestone_hold": 0.3, "duration": 10.0},
    }
    if not hand:
        del config["hand"]
    record = {
        "schema": 1,
        "task": "apple",
        "hand": "allegro",
        "cost": "contact",
        "sampler": "pca_spline",
        "planner": "predictive_sampling",
        "variant": "full",
        "preset": "lite",
        "experiment": None,
        "seed": 0,
        "status": status,
        "git_revision": None,
        "ttf": ttf.ttf,
        "ttf_note": None,
        "completed": False,
        "milestone_lifted": True,
        "milestone_handed_off": False,
        "failed": ttf.failed,
        "failure_time": ttf.failure_time,
        "contact_span_start": ttf.span[0],
        "contact_span_end": ttf.span[1],
        "object_position_error_mean": float(pos_err.mean()),
        "config": config,
    }
    if status != "ok":
        record = {k: v for k, v in record.items() if k not in ("ttf", "failed", "failure_time", "completed")}
        record["error"] = "PlantDiverged: plant diverged between t=9.950s and t=10.000s"
    run.mkdir(parents=True)
    (run / "trial.json").write_text(json.dumps(record))
    if series:
        cost = {f"cost_{k}": np.linspace(1e-3, 1.0, n) * w for k, w in (("object", 1), ("contact", 2))}
        np.savez_compressed(
            run / "timeseries.npz",
            time=T,
            qpos=np.zeros((n, 29)),
            hand_qpos=np.zeros((n, 22)),
            hand_target=np.zeros((n, 22)),
            object_qpos=obj,
            expected_object_qpos=ref,
            contacts=touch,
            expected_contacts=exp,
            object_position_error=pos_err,
            object_rotation_error=np.zeros(n),
            object_articulation_error=np.zeros(n),
            cost_velocity=np.full(n, 0.1),
            **cost,
            best_cost=np.ones(n),
            nominal_cost=np.ones(n),
            plan_seconds=np.full(n, 0.05),
            num_diverged=np.zeros(n, int),
        )
    return run


def test_cli_end_to_end(tmp_path: Path, capsys) -> None:
    run = write_run(tmp_path / "apple0")
    assert main([str(run)]) == 0
    out = capsys.readouterr()
    assert (run / "timeline.png").stat().st_size > 20_000
    text = (run / "timeline.txt").read_text().splitlines()
    assert text[0].startswith("apple / full / seed 0: status ok, TTF ")
    assert text[1].startswith("first: lost contact at t=7.00 s (expected 11 links, touching 0")
    assert "milestones: lifted at t=4.05 s, handed_off not reached" in text  # from AppleTask.conditions
    assert "first: lost contact at t=7.00 s" in out.out and not out.err
    # a method named by its groups: the name the analysis gives it, not the variant label alone
    record = json.loads((run / "trial.json").read_text())
    (run / "trial.json").write_text(
        json.dumps(record | {"variant": "grasp_held_eased", "rollout": "fine_on_error"})
    )
    assert main([str(run)]) == 0
    assert (run / "timeline.txt").read_text().startswith("apple / grasp_held_eased_refined / seed 0: ")


def test_cli_errors_and_partial_runs(tmp_path: Path, capsys) -> None:
    (tmp_path / "empty").mkdir()
    failed = write_run(tmp_path / "failed", status="error", series=False)
    diverged = write_run(tmp_path / "diverged", status="diverged", hand=False)
    no_series = write_run(tmp_path / "no_series", series=False)
    runs = [tmp_path / "empty", failed, diverged, no_series, tmp_path / "missing"]
    assert main([*map(str, runs), "--out-dir", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert f"error: {tmp_path / 'empty'}: no trial.json here" in err
    reason = "PlantDiverged: plant diverged between t=9.950s and t=10.000s"
    assert (
        f"error: {failed}: trial status 'error' ({reason}); it left no timeseries.npz, nothing to draw" in err
    )
    assert f"error: {no_series}: no timeseries.npz" in err
    assert f"error: {tmp_path / 'missing'}: no such directory" in err
    assert any(line.startswith(f"warning: {diverged}: trial status 'diverged'") for line in err)
    assert any("link names unknown" in line and "rows labelled by index" in line for line in err)
    assert (tmp_path / "out" / "diverged.png").is_file()
    assert "completed" not in (tmp_path / "out" / "diverged.txt").read_text().splitlines()[-2:]


def test_milestone_flags_without_a_task() -> None:
    series = {"time": T, "contacts": expected_grasp()}
    milestones, note = milestone_times(
        {"milestone_lifted": True, "milestone_turned": False, "config": {}}, series
    )
    assert milestones == {"lifted": True, "turned": False}
    assert note == "milestone instants unknown (TypeError: not in the record's config)"


def test_a_link_touching_before_its_first_expected_contact() -> None:
    """An early touch (a finger on the object for 0.3 s or more before the reference first expects it)
    is a problem at its start, named by link, with the time it touched early in all; a shorter one is not."""
    exp = expected_grasp()  # links 0-10 expected from 2 s
    touch = exp.copy()
    touch[(T >= 1.0 - 1e-9) & (T < 1.5 - 1e-9), 4] = True  # link 4 for 0.5 s, 1 s before its contact
    touch[(T >= 1.2 - 1e-9) & (T < 1.35 - 1e-9), 7] = True  # link 7 for 0.15 s: too short to count
    names = [f"l{k}" for k in range(exp.shape[1])]
    lines = diagnose(T, touch, exp, np.zeros(len(T)), names=names, completed=True)
    assert lines == ["completed", "note: touched before expected: l4 from t=1.00 s (0.5 s)"]
    assert (
        diagnose(T, touch, exp, completed=False)[0]
        == "first: touched before expected: link 4 from t=1.00 s (0.5 s)"
    )
    assert diagnose(T, exp, exp, completed=True) == ["completed"]
