"""launch.py: resume only the same trial, a record whatever fails, Ctrl-C, sweep summary, flat and locked
job directories, and a --help without schemas."""

from __future__ import annotations

import fcntl
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from omegaconf import OmegaConf

import launch
import sweep_summary
from contactmpc import runs
from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners import PredictiveSampling
from contactmpc.control.samplers import PCASplineSpace
from contactmpc.jobs.trial import TrialInputs, run_trial
from contactmpc.records import write_json
from tests.conftest import REPO_ROOT, build_scene, compose_config
from tests.helpers import static_reference

TINY = ["planner.num_samples=10", "planner.horizon=0.1", "planner.replan_period=0.05", "planner.nthread=1"]
QUIET = ["job.progress=false", "hydra/job_logging=disabled", "hydra/hydra_logging=disabled"]


def launch_py(*args, timeout=300):
    return subprocess.run(
        [sys.executable, str(REPO_ROOT / "launch.py"), *args],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def _as_from_a_terminal() -> None:
    """In the child: Ctrl-C's default disposition. A shell that starts the tests in the background
    (``nohup … &``) has them ignore SIGINT, which its children inherit, and Python then installs no
    KeyboardInterrupt handler: the test would see the harness, not launch.py."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start(*args):
    """``launch.py`` in its own process group, as a terminal runs it (Ctrl-C reaches the whole group)."""
    return subprocess.Popen(
        [sys.executable, str(REPO_ROOT / "launch.py"), *args],
        cwd=REPO_ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=_as_from_a_terminal,
    )


def locked(directory: Path) -> bool:
    """Whether another process holds ``directory/.lock``."""
    try:
        with open(directory / runs.LOCK_NAME) as f:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except FileNotFoundError:
        return False
    except BlockingIOError:
        return True
    return False


def wait_for(predicate, timeout=120.0):
    t0 = time.monotonic()
    while not predicate():
        assert time.monotonic() - t0 < timeout, "timed out"
        time.sleep(0.2)


def records(root: Path) -> dict[str, dict]:
    return {str(p.parent.relative_to(root)): json.loads(p.read_text()) for p in root.rglob("trial.json")}


def summary(stdout: str) -> str:
    lines = [line for line in stdout.splitlines() if line.startswith("[contactmpc] sweep ")]
    assert len(lines) == 1, stdout
    return lines[0]


@pytest.fixture(scope="module")
def refs(tmp_path_factory):
    """Short static references (apple, bottle) used through ``task.reference_path``."""
    root = tmp_path_factory.mktemp("refs")
    return {
        task: str(
            static_reference(build_scene((f"task={task}",)), duration=0.2, frames=6).save(
                root / f"{task}.npz"
            )
        )
        for task in ("apple", "bottle")
    }


# ------------------------------------------------------------------------------------- unit tests


def test_safe_dirname_is_flat_short_and_keeps_overrides_apart():
    assert runs.safe_dirname("seed=0,task=apple,variant=full") == "seed=0,task=apple,variant=full"
    assert runs.safe_dirname("") == ""
    a = runs.safe_dirname("task.reference_path=/data/refs/x.npz,task=apple")
    b = runs.safe_dirname("task.reference_path=/other/x.npz,task=apple")
    assert a.startswith("task.reference_path=x.npz,task=apple-") and len(a) == len(b) == 45
    assert a != b  # the hash of the original tells them apart
    assert runs.safe_dirname("group/sub=a/b") == "group_sub=b-" + runs.safe_dirname("group/sub=a/b")[-8:]
    long = runs.safe_dirname("x=" + "a" * 500)
    assert len(long) == 200 and long != runs.safe_dirname("x=" + "a" * 501)
    assert runs.safe_dirname("scene.hand_root=[0,0,0.1] 'q'").startswith("scene.hand_root=_0,0,0.1___q_-")
    # the resolver is what the sweep's subdir uses
    cfg = OmegaConf.create({"name": "a=/b/c", "dir": "${safe_dirname:${name}}"})
    assert cfg.dir == runs.safe_dirname("a=/b/c")


def _config(*overrides):
    cfg = compose_config(list(overrides))
    cfg.output_dir = "/somewhere"  # ${hydra:runtime.output_dir} needs a running Hydra job
    return OmegaConf.to_container(cfg, resolve=True)


def test_config_differences_name_the_keys_that_change_the_trial():
    apple = _config("task=apple")
    stored = json.loads(json.dumps(apple))  # as a record holds it
    assert runs.config_differences(stored, apple) == []
    moved = _config("task=apple", "job.progress=false", "resume=false", "job.reference_cache=/tmp/c")
    assert runs.config_differences(stored, moved) == []  # settings that do not change the trial
    diffs = runs.config_differences(stored, _config("task=bottle", "seed=3"))
    assert diffs[0] == "task._target_: contactmpc.tasks.BottleTask != contactmpc.tasks.AppleTask"
    assert "seed: 3 != 0" in diffs and "task.radius: 0.0325 != 0.041" in diffs
    assert runs.config_differences({**stored, "extra": 1}, apple) == ["extra: <absent> != 1"]
    assert runs.config_differences({"a": None}, {"a": float("inf")}) == []  # JSON keeps no infinity
    assert runs.config_differences(None, apple) == ["config: not in the record"]


def test_a_record_made_before_an_option_existed_is_the_same_trial_at_the_option_s_default(tmp_path):
    """A stored config that lacks a keyword option of a member's target (the record predates it) reads
    as that option's default: the same trial where the new config has the default, a different one
    where it does not (resume, and the analysis's condition columns)."""
    from analysis.aggregate import RecordWarning, load_records

    new = _config("task=apple", "release=reset")
    old = json.loads(json.dumps(new))
    for name in ("backoff", "backoff_window", "open_to"):
        del old["sampler"]["release"][name], old["job"]["sampler"]["release"][name]  # the job's copy too
    assert new["sampler"]["release"]["backoff_window"] == [0.5, 1.5]  # a tuple default, as JSON holds it
    assert runs.config_differences(old, new) == []
    backed = _config("task=apple", "release=reset", "sampler.release.backoff=0.08")
    assert runs.config_differences(old, backed) == [
        "job.sampler.release.backoff: 0.08 != 0.0",
        "sampler.release.backoff: 0.08 != 0.0",
    ]
    # a key that is no option of the target at its parent still differs
    assert runs.config_differences({**old, "extra": 1}, new) == ["extra: <absent> != 1"]
    for i, (name, config) in enumerate((("old", old), ("new", new), ("backed", backed))):
        record = {"task": "apple", "variant": "full", "seed": 0, "status": "ok", "config": config}
        write_json(tmp_path / name / "trial.json", record)
        os.utime(tmp_path / name / "trial.json", (1000 + i, 1000 + i))
    with pytest.warns(RecordWarning, match="recorded 2 times: keeping the newest, .*new"):
        df = load_records(tmp_path)  # old and new are one trial: the newer kept
    assert sorted(df["condition"]) == ["sampler.release.backoff=0.0", "sampler.release.backoff=0.08"]


def test_resume_decision(tmp_path):
    apple, bottle = _config("task=apple"), _config("task=bottle")
    assert runs.resume_decision(tmp_path, apple, True) == ("run", None)
    write_json(tmp_path / "trial.json", {"status": "ok", "config": apple})
    action, line = runs.resume_decision(tmp_path, apple, True)
    assert action == "skip" and "skipped (record exists, status ok)" in line
    assert runs.resume_decision(tmp_path, apple, False) == ("run", None)
    action, line = runs.resume_decision(tmp_path, bottle, True)
    assert action == "refuse"
    assert line.startswith(
        f"contactmpc: error: {tmp_path / 'trial.json'} holds a different trial (task._target_: "
    )
    assert line.endswith("; re-run with resume=overwrite or use another directory") and "\n" not in line
    assert runs.resume_decision(tmp_path, bottle, False)[0] == "refuse"
    assert runs.resume_decision(tmp_path, bottle, "overwrite") == ("run", None)
    write_json(tmp_path / "trial.json", {"status": "error", "config": apple})  # not a result: run again
    assert runs.resume_decision(tmp_path, bottle, True) == ("run", None)


def test_a_record_without_the_newer_machine_fields_resumes(tmp_path):
    """Records made before ``host``, ``concurrent_trials`` and the ``fidelity`` label (and with
    ``variant: null``) are the same trial as now: a resume skips them."""
    apple = _config("task=apple")
    old = {"task": "apple", "variant": None, "seed": 0, "status": "ok", "cpu": "AMD EPYC", "config": apple}
    write_json(tmp_path / "trial.json", old)
    assert runs.resume_decision(tmp_path, apple, True)[0] == "skip"


def test_labels_name_an_unset_variant_by_what_it_composes_to():
    paper = {"planner": "predictive_sampling", "cost": "contact", "sampler": "pca_spline"}
    labels = launch.labels_of({"task": "apple", "variant": None, "fidelity": "authors_code", **paper})
    assert (labels["variant"], labels["fidelity"], labels["task"]) == ("full", "authors_code", "apple")
    assert launch.labels_of({**paper, "variant": "replay"})["variant"] == "replay"
    # other choices than the full method's: no name is guessed (the analysis names it from them)
    assert launch.labels_of({**paper, "cost": "object_only", "variant": None})["variant"] is None
    assert launch.labels_of({**paper})["preset"] is None  # other groups left unset stay null


def test_job_lock_is_exclusive(tmp_path):
    with runs.job_lock(tmp_path / "job") as first:
        assert first and locked(tmp_path / "job")
        with runs.job_lock(tmp_path / "job") as second:
            assert not second
    assert not locked(tmp_path / "job")
    with runs.job_lock(tmp_path / "job") as again:
        assert again


def test_trial_records_ctrl_c_and_a_job_that_could_not_be_built(tmp_path):
    def interrupted_scene():
        raise KeyboardInterrupt

    planner = PredictiveSampling(num_samples=4, horizon=0.1, replan_period=0.05, nthread=1)
    with pytest.raises(KeyboardInterrupt):
        inputs = TrialInputs(PCASplineSpace(0.2), TrackingCost(), planner)
        run_trial(interrupted_scene, tmp_path / "a", 1, inputs)
    record = json.loads((tmp_path / "a" / "trial.json").read_text())
    assert (record["status"], record["error"], record["seed"]) == ("interrupted", "KeyboardInterrupt", 1)

    path = run_trial.record_failure(
        tmp_path / "b", 2, ValueError("no\nplanner"), {"seed": 2}, {"task": "apple"}
    )
    record = json.loads(path.read_text())
    assert (record["status"], record["error"], record["task"]) == ("error", "ValueError: no planner", "apple")
    assert record["config"] == {"seed": 2} and record["versions"]["mujoco"]


def test_help_lists_no_schema():
    r = launch_py("--help", timeout=120)
    assert r.returncode == 0, r.stderr
    groups = r.stdout.split("== Config ==")[0]
    tasks = "apple, bottle, doorknob, paper_apple, paper_bottle, paper_doorknob, paper_stapler, stapler"
    assert f"task: {tasks}" in groups
    assert "_schema" not in groups


# ------------------------------------------------------------------------------------- end to end


@pytest.mark.slow
def test_a_job_that_cannot_be_built_writes_an_error_record(tmp_path):
    run = tmp_path / "run"
    # Every value passes on its own; the planner refuses the combination when it is built.
    r = launch_py(
        "task=bottle", "seed=4", "planner=cem", "planner.num_elites=1000", f"hydra.run.dir={run}", *QUIET
    )
    assert r.returncode == 1
    errors = [line for line in r.stderr.splitlines() if line.startswith("contactmpc: error:")]
    assert len(errors) == 1 and "num_elites" in errors[0], r.stderr
    record = json.loads((run / "trial.json").read_text())
    assert record["status"] == "error" and "num_elites" in record["error"]
    assert "\n" not in record["error"] and "ConfigError" in record["traceback"]
    assert (record["task"], record["planner"], record["seed"]) == ("bottle", "cem", 4)
    # no variant chosen, but planner=cem: not the full method, so no variant name; the fidelity is named
    assert (record["variant"], record["fidelity"]) == (None, "paper") and record["host"]["name"]
    assert record["config"]["planner"]["num_elites"] == 1000 and record["config"]["output_dir"] == str(run)


@pytest.mark.slow
def test_ctrl_c_leaves_an_interrupted_record_and_one_line(tmp_path, refs):
    run = tmp_path / "run"
    p = start(
        "task=apple", f"task.reference_path={refs['apple']}", "duration=20", f"hydra.run.dir={run}", *QUIET
    )
    wait_for(lambda: locked(run))  # the job has begun
    time.sleep(2.0)  # into the trial
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    assert err.strip().splitlines() == [f"contactmpc: interrupted; record: {run / 'trial.json'}"]
    record = json.loads((run / "trial.json").read_text())
    assert record["status"] == "interrupted" and record["error"] == "KeyboardInterrupt"
    assert record["config"]["duration"] == 20


@pytest.mark.slow
def test_sigterm_leaves_an_interrupted_record_and_one_line(tmp_path, refs):
    """A SIGTERM (``kill``, ``timeout``) ends a trial as Ctrl-C does, the signal named."""
    run = tmp_path / "run"
    p = start(
        "task=apple", f"task.reference_path={refs['apple']}", "duration=20", f"hydra.run.dir={run}", *QUIET
    )
    wait_for(lambda: locked(run))
    time.sleep(2.0)
    p.send_signal(signal.SIGTERM)
    out, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    line = f"contactmpc: interrupted (terminated by SIGTERM); record: {run / 'trial.json'}"
    assert err.strip().splitlines() == [line]
    record = json.loads((run / "trial.json").read_text())
    assert record["status"] == "interrupted" and record["error"] == "Terminated: terminated by SIGTERM"


def _apple_sweep(sweep, refs) -> tuple[str, ...]:
    """A multirun of the synthetic apple for 20 s of control into ``sweep`` (its seeds still to choose)."""
    return (
        "-m",
        "task=apple",
        f"task.reference_path={refs['apple']}",
        "duration=20",
        f"hydra.sweep.dir={sweep}",
    )


@pytest.mark.slow
def test_sigterm_to_a_sweeps_processes_stops_it_as_ctrl_c_does(tmp_path, refs):
    """``timeout`` or a scheduler signals every process of a sweep: its running jobs leave interrupted
    records, no new job starts, and the summary follows."""
    sweep = tmp_path / "sweep"
    args = _apple_sweep(sweep, refs)
    first = start(
        *args, "seed=0,1,2", "hydra/launcher=joblib", "hydra.launcher.n_jobs=2", "planner.nthread=1", *QUIET
    )
    try:
        wait_for(lambda: sum(locked(d) for d in sweep.glob("*seed=*")) == 2)
        time.sleep(2.0)
    finally:
        os.killpg(first.pid, signal.SIGTERM)
        out, err = first.communicate(timeout=120)
    assert first.returncode == 130, err
    assert summary(out).endswith(
        ": 3 jobs: 0 ok / 0 diverged / 0 error / 2 interrupted, 0 skipped, 1 not started (interrupted)"
    )
    assert (
        err.count("contactmpc: interrupted (terminated by SIGTERM); record: ") == 2 and "Traceback" not in err
    )
    assert sorted(rec["status"] for rec in records(sweep).values()) == ["interrupted", "interrupted"]


@pytest.mark.slow
def test_resume_refuses_a_different_trial_unless_told_to_overwrite(tmp_path, refs):
    run = tmp_path / "run"
    apple = ["task=apple", f"task.reference_path={refs['apple']}", "duration=0.1", *TINY, *QUIET]
    bottle = ["task=bottle", f"task.reference_path={refs['bottle']}", "duration=0.1", *TINY, *QUIET]
    assert launch_py(*apple, f"hydra.run.dir={run}").returncode == 0

    r = launch_py(*bottle, f"hydra.run.dir={run}")
    assert r.returncode == 1
    [line] = r.stderr.splitlines()
    assert line.startswith(
        f"contactmpc: error: {run / 'trial.json'} holds a different trial "
        "(task._target_: contactmpc.tasks.BottleTask != contactmpc.tasks.AppleTask, "
    )
    assert line.endswith("; re-run with resume=overwrite or use another directory")
    assert json.loads((run / "trial.json").read_text())["task"] == "apple"  # left alone

    # In a multirun the refused job is reported and counted as failed; the record stays.
    m = launch_py("-m", *bottle, f"hydra.sweep.dir={run}", "hydra.sweep.subdir=.")
    assert m.returncode == 1
    assert summary(m.stdout).endswith(
        ": 1 jobs: 0 ok / 0 diverged / 0 error / 0 interrupted, 0 skipped, 1 refused (a different trial's "
        "record)"
    )
    assert "holds a different trial" in m.stderr
    assert json.loads((run / "trial.json").read_text())["task"] == "apple"

    o = launch_py(*bottle, f"hydra.run.dir={run}", "resume=overwrite")
    assert o.returncode == 0, o.stderr
    assert json.loads((run / "trial.json").read_text())["task"] == "bottle"


@pytest.mark.slow
def test_sweep_summary_flat_directories_and_exit_status(tmp_path, refs):
    """A path-valued override makes one flat directory per job; a failed job makes the exit status 1."""
    bad = tmp_path / "data" / "bad.npz"
    bad.parent.mkdir()
    bad.write_text("not a zip")
    sweep = tmp_path / "sweep"
    args = (
        "-m",
        "task=apple",
        f"task.reference_path={bad},{refs['apple']}",
        "duration=0.1",
        f"hydra.sweep.dir={sweep}",
    )
    r = launch_py(*args, *TINY, *QUIET)
    assert r.returncode == 1, r.stderr
    assert summary(r.stdout).endswith(": 2 jobs: 1 ok / 0 diverged / 1 error / 0 interrupted, 0 skipped")
    found = records(sweep)
    assert sorted(rec["status"] for rec in found.values()) == ["error", "ok"]
    assert all("/" not in name for name in found)  # one level: the job directories themselves
    assert any(name.startswith("duration=0.1,") and "task.reference_path=bad.npz" in name for name in found)
    assert not (sweep / sweep_summary.STATE_DIR).exists()

    again = launch_py(*args, *TINY, *QUIET)
    assert again.returncode == 1  # the bad file is still bad
    assert summary(again.stdout).endswith(": 2 jobs: 0 ok / 0 diverged / 1 error / 0 interrupted, 1 skipped")


@pytest.mark.slow
def test_a_second_process_skips_jobs_in_progress_and_ctrl_c_stops_a_sweep(tmp_path, refs):
    sweep = tmp_path / "sweep"
    args = _apple_sweep(sweep, refs)
    slow = ["planner.nthread=1", *QUIET]  # the lite planner: 20 s of control take minutes
    first = start(*args, "seed=0,1,2", "hydra/launcher=joblib", "hydra.launcher.n_jobs=2", *slow)
    try:
        wait_for(lambda: sum(locked(d) for d in sweep.glob("*seed=*")) == 2)  # two jobs running

        second = launch_py(*args, "seed=0,1", *slow)
        busy = [line for line in second.stdout.splitlines() if "in progress in another process" in line]
        assert len(busy) == 2, second.stdout
        assert summary(second.stdout).endswith("0 interrupted, 0 skipped, 2 running in another process")
        assert second.returncode == 1
    finally:
        os.killpg(first.pid, signal.SIGINT)  # Ctrl-C at the terminal
        out, err = first.communicate(timeout=120)
    assert first.returncode == 130, err
    assert summary(out).endswith(
        ": 3 jobs: 0 ok / 0 diverged / 0 error / 2 interrupted, 0 skipped, 1 not started (interrupted)"
    )
    assert err.count("contactmpc: interrupted; record: ") == 2 and "Traceback" not in err
    assert sorted(rec["status"] for rec in records(sweep).values()) == ["interrupted", "interrupted"]


@pytest.mark.slow
def test_a_sweep_through_the_submitit_local_launcher(tmp_path):
    """The Slurm code path minus the scheduler: experiment=smoke's jobs of one variant (2) through
    submitit's local executor, each a subprocess, and the analysis reads their records."""
    sweep = tmp_path / "sweep"
    r = launch_py(
        "-m", "experiment=smoke", "hydra/launcher=submitit_local", "hydra.sweeper.params.variant=full",
        f"hydra.sweep.dir={sweep}", timeout=600,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    assert "2 jobs: 2 ok" in r.stdout + r.stderr
    assert len(list(sweep.rglob("trial.json"))) == 2
    out = subprocess.run(
        [sys.executable, "-m", "analysis", str(sweep), "--out-dir", str(tmp_path / "analysis")],
        cwd=REPO_ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert out.returncode == 0 and "(2 trials)" in out.stdout, out.stderr


def test_an_option_a_planner_takes_through_kwargs_reads_as_its_base_s_default():
    """PredictiveSampling forwards ``**kwargs`` to Planner: a record made before Planner's options
    (iterations, anneal, early_stop) existed is the same trial at their defaults, not a refused resume."""
    new = _config("task=apple")
    old = json.loads(json.dumps(new))
    for name in ("iterations", "anneal", "early_stop"):
        assert name in new["job"]["planner"]
        del old["job"]["planner"][name]
    assert runs.config_differences(old, new) == []
    more = _config("task=apple", "planner.iterations=4")
    assert runs.config_differences(old, more) == [
        "job.planner.iterations: 4 != 1",
        "planner.iterations: 4 != 1",
    ]
