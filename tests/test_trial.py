"""The closed loop and the trial job: determinism, every task x planner, records, failures, resume."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from omegaconf import OmegaConf

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners import PredictiveSampling
from contactmpc.control.samplers import PCASplineSpace
from contactmpc.reference import source
from contactmpc.trial import PlantDiverged, Trial
from launch import build_job
from tests.conftest import REPO_ROOT, TASKS, build_scene, compose_config
from tests.helpers import static_reference

PLANNERS = ("predictive_sampling", "mppi", "cem", "replay")
TINY = ["planner.num_samples=10", "planner.horizon=0.1", "planner.replan_period=0.05", "planner.nthread=1"]


def run_job(overrides, out_dir):
    """Compose, instantiate and call the job exactly as launch.py does (without Hydra's runtime)."""
    cfg = compose_config(overrides)
    job = build_job(cfg.job)
    return job(
        make_scene=lambda: build_scene(tuple(overrides)),
        output_dir=out_dir,
        seed=cfg.seed,
        config=OmegaConf.to_container(cfg, resolve=False),
        labels={"task": cfg.task._target_},
    )


@pytest.mark.parametrize("planner", PLANNERS)
@pytest.mark.parametrize("task", TASKS)
def test_every_task_and_planner_runs_a_few_steps(task, planner, reference_files, tmp_path):
    overrides = [f"task={task}", f"planner={planner}", f"task.reference_path={reference_files[task]}", *TINY]
    path = run_job(overrides + ["duration=0.15", "job.progress=false"], tmp_path)
    record = json.loads(path.read_text())
    assert record["status"] == "ok", record.get("error")
    assert record["num_plans"] == 3
    assert record["concurrent_trials"] >= 1 and record["host"]["cpu"].startswith(record["cpu"])
    series = np.load(tmp_path / "timeseries.npz")
    assert series["time"].shape == (3,)
    assert np.isfinite(series["object_qpos"]).all()
    if planner != "replay":
        assert np.isfinite(series["best_cost"]).all()


def test_trial_video_is_written_next_to_the_record(reference_files, tmp_path):
    overrides = ["task=doorknob", f"task.reference_path={reference_files['doorknob']}", *TINY]
    path = run_job(overrides + ["duration=0.2", "job.progress=false", "job.video=gif"], tmp_path)
    record = json.loads(path.read_text())
    assert record["status"] == "ok", record.get("error")
    assert (tmp_path / "trial.gif").stat().st_size > 1000
    assert record["video"].endswith("trial.gif")


def test_write_reference_uses_the_reference_cache(tmp_path, monkeypatch):
    """``job=write_reference`` reads the trial job's reference cache instead of synthesising again."""
    assert compose_config(["job=write_reference"]).job.reference_cache == compose_config().job.reference_cache
    scene = build_scene(("task=apple",))
    cached = static_reference(scene, duration=0.2, frames=6)  # not what synthesis would give
    cache = tmp_path / "cache"
    cache.mkdir()
    cached.save(cache / f"apple_{source._fingerprint(scene)}.npz")

    def no_synthesis(*args, **kwargs):
        raise AssertionError("synthesised although the reference is cached")

    monkeypatch.setattr(type(scene.task.demonstration), "build", no_synthesis)
    out = tmp_path / "apple.npz"
    path = run_job(
        ["task=apple", "job=write_reference", f"job.path={out}", f"job.reference_cache={cache}"], tmp_path
    )
    assert path == out
    np.testing.assert_array_equal(np.load(out)["hand_qpos"], cached.hand_qpos)


def _trial(scene, ref, seed, nthread=2):
    planner = PredictiveSampling(num_samples=8, horizon=0.2, replan_period=0.05, nthread=nthread)
    cost = TrackingCost(lambda_v=0.0)  # without the velocity term some perturbations always win
    trial = Trial(scene, ref, PCASplineSpace(0.2), cost, planner, seed, duration=0.4, progress=False)
    try:
        return trial.run().arrays()
    finally:
        planner.close()


def test_same_seed_same_log_and_different_seeds_differ(scene_for):
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.5, frames=11)
    a, b, c = _trial(scene, ref, 7), _trial(scene, ref, 7), _trial(scene, ref, 8)
    for key in a:
        if key != "plan_seconds":
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    # another seed draws other candidates: the best of them (its cost, or what it commits) differs
    same = all(np.array_equal(a[k], c[k]) for k in ("best_cost", "hand_target"))
    assert not same
    # the thread count does not enter: a record is the same on a laptop and on a cluster node
    one = _trial(scene, ref, 7, nthread=1)
    for key in a:
        if key != "plan_seconds":
            np.testing.assert_array_equal(a[key], one[key], err_msg=key)


def test_a_bad_reference_file_writes_an_error_record(tmp_path):
    bad = tmp_path / "bad.npz"
    np.savez(bad, time=np.array([0.0, 1.0]))
    with pytest.raises(ValueError, match="hand_qpos"):
        run_job(["task=apple", f"task.reference_path={bad}", *TINY], tmp_path / "run")
    record = json.loads((tmp_path / "run" / "trial.json").read_text())
    assert record["status"] == "error"
    assert "hand_qpos" in record["error"] and "\n" not in record["error"]


def launch(*args, cwd=REPO_ROOT):
    return subprocess.run(
        [sys.executable, str(REPO_ROOT / "launch.py"), *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.mark.slow
def test_launch_single_run_failure_is_one_line_and_nonzero(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_text("not a zip")
    r = launch("task=apple", f"task.reference_path={bad}", f"hydra.run.dir={tmp_path / 'run'}", *TINY)
    assert r.returncode == 1
    errors = [line for line in r.stderr.splitlines() if line.startswith("contactmpc: error:")]
    assert len(errors) == 1 and "bad.npz" in errors[0]
    assert json.loads((tmp_path / "run" / "trial.json").read_text())["status"] == "error"


@pytest.mark.slow
def test_multirun_goes_on_after_a_failure_and_resumes(tmp_path, reference_files):
    bad = tmp_path / "bad.npz"
    bad.write_text("not a zip")
    sweep = tmp_path / "sweep"
    args = (
        "-m",
        "task=apple",
        f"task.reference_path={bad},{reference_files['apple']}",
        "duration=0.1",
        "job.progress=false",
        f"hydra.sweep.dir={sweep}",
        *TINY,
    )
    r = launch(*args)
    assert r.returncode == 1, r.stderr  # the sweep went on, and its exit status says a job failed
    records = {str(p): json.loads(p.read_text()) for p in sweep.rglob("trial.json")}
    assert len(records) == 2
    statuses = sorted(rec["status"] for rec in records.values())
    assert statuses == ["error", "ok"]
    # Resume: the finished job is skipped, the failed one is tried again.
    r2 = launch(*args)
    assert r2.stdout.count("skipped (record exists") == 1, r2.stdout


@pytest.mark.parametrize("visit", ["replay", "planner"])
def test_benchmark_times_states_a_trial_visits(reference_files, tmp_path, visit, capsys):
    """job=benchmark: approach and contact states, plan vs bare rollout interleaved, wall and CPU time,
    per thread count; JSON written."""
    overrides = ["task=apple", "job=benchmark", f"task.reference_path={reference_files['apple']}", *TINY]
    path = run_job(overrides + ["job.repeats=2", "job.physics_steps=20", f"job.visit={visit}"], tmp_path)
    result = json.loads(path.read_text())
    rows = result["rows"]
    assert [(r["state"], r["nthread"]) for r in rows] == [
        ("approach", 1), ("approach", 2), ("contact", 1), ("contact", 2)
    ]  # fmt: skip
    for r in rows:
        assert r["plan_seconds"] > 0 and r["rollout_cpu_seconds"] > 0 and r["plant_step_us"] > 0
        assert r["ncon"] >= 0 and r["nefc"] >= 0
    assert rows[0]["speedup"] == 1.0 and rows[2]["speedup"] == 1.0
    assert rows[0]["time"] <= rows[2]["time"]
    # the option sets of conf/job/benchmark.yaml, priced against the scene's planning model per state
    priced = result["planner_options"]
    assert priced["scene"] == {"ccd_iterations": 10, "ccd_tolerance": 1e-6}
    for state in ("approach", "contact"):
        sets = priced["states"][state]
        assert list(sets) == ["scene", "mujoco_ccd", "pyramidal", "solver_20"]
        assert sets["scene"]["saving"] == 0.0
        assert all(p["step_cpu_us"] > 0 and p["object_gap_mm"] >= 0 for p in sets.values())
    assert all((r["horizon_steps"], r["planning_timestep"]) == (10, 0.01) for r in rows)
    if (
        visit == "replay"
    ):  # planner.switch_timestep: each state benchmarked on the model a plan there rolls out
        switched = overrides + ["job.repeats=1", "job.physics_steps=2", "job.visit=replay", "job.threads=[1]"]
        # between the two states (the static reference expects contact from its first frame on)
        between = round((rows[0]["time"] + rows[2]["time"]) / 2, 3)
        switched += [
            "planner.switch_timestep=0.005",
            f"planner.switch_after={between}",
            "job.planner_options={}",
        ]
        rows = json.loads(run_job(switched, tmp_path / "switched").read_text())["rows"]
        assert [(r["state"], r["horizon_steps"], r["planning_timestep"]) for r in rows] == [
            ("approach", 10, 0.01), ("contact", 20, 0.005)
        ]  # fmt: skip
    if visit == "planner":  # the table and the quiet-vs-loaded comparison read it
        from analysis.benchmarks import main as benchmarks_main

        assert benchmarks_main([str(tmp_path), "--against", str(tmp_path)]) == 0
        out = capsys.readouterr().out
        assert "| apple | contact |" in out and "largest difference of a CPU-time ratio: 0.0 %" in out
        assert benchmarks_main([str(tmp_path / "nothing")]) == 2
        assert "no benchmark.json under" in capsys.readouterr().err


def test_a_plant_that_diverges_inside_the_span_fails_there(tmp_path):
    """A real divergence (a 1e7 N s push on the apple): the record keeps what the trial logged until then,
    its TTF against the whole trial's span, failed no later than the divergence, never settled."""
    scene = build_scene(("task=apple",))
    path = static_reference(scene, duration=1.0).save(tmp_path / "apple.npz")  # 8 links expected throughout
    overrides = ["task=apple", f"task.reference_path={path}", *TINY, "duration=1.0", "job.progress=false"]
    overrides += ["perturbation=pushes", "perturbation.pushes=1", "perturbation.push_impulse=1e7", "seed=0"]
    with pytest.raises(PlantDiverged):
        run_job(overrides, tmp_path / "run")
    record = json.loads((tmp_path / "run" / "trial.json").read_text())
    assert record["status"] == "diverged" and record["error"].startswith("PlantDiverged: plant diverged")
    assert "(mjWARN_BADQACC at DOF" in record["error"]  # the warning that stopped it, and where
    end, (first, last) = record["diverged_time"], (record["contact_span_start"], record["contact_span_end"])
    assert (first, last) == (0.0, pytest.approx(0.95))  # the whole trial's span, not the log's
    assert first < end < last and record["simulated_seconds"] == end
    assert record["failed"] and record["failure_time"] <= end + 1e-9
    assert record["ttf"] == pytest.approx((record["failure_time"] - first) / (last - first))
    assert record["settled"] is False and record["finished_cleanly"] is False
    series = np.load(tmp_path / "run" / "timeseries.npz")
    assert series["time"][-1] == pytest.approx(end) and len(series["time"]) == record["num_plans"]
