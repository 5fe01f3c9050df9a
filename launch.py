"""ContactMPC entry point: compose the config, build the scene, run the selected job.

    python launch.py                         # one default trial; prints where its record is
    python launch.py task=doorknob seed=3    # override any config group or value
    python launch.py --cfg job               # print the composed config
    python launch.py job=render_scene task=stapler
    python launch.py -m task=apple,bottle seed=0,1,2   # a multirun sweep

Errors that come from bad input (config, reference files, scenes) are printed as one line naming the
problem, and the process exits with status 1. Ctrl-C leaves the trial's record (status
``interrupted``), prints one line and exits with status 130. A multirun ends with one summary line
(:class:`SweepSummary`) and a non-zero exit status unless every job finished.
"""

from __future__ import annotations

import contextlib
import functools
import json
import logging
import os
import shutil
import signal
import sys
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

os.environ.setdefault("MUJOCO_GL", "egl")

import hydra  # noqa: E402
from hydra.core.config_store import ConfigStore  # noqa: E402
from hydra.core.hydra_config import HydraConfig  # noqa: E402
from hydra.core.utils import JobStatus  # noqa: E402
from hydra.experimental.callback import Callback  # noqa: E402
from hydra.types import RunMode  # noqa: E402
from hydra.utils import get_method, instantiate  # noqa: E402
from omegaconf import DictConfig, OmegaConf  # noqa: E402

from contactmpc.config import Config, check_config, member_schemas  # noqa: E402
from contactmpc.jobs.trial import failure_status  # noqa: E402
from contactmpc.records import RECORD_NAME, one_line, write_json  # noqa: E402
from contactmpc.runs import (  # noqa: E402
    RESUME,
    job_lock,
    resume_decision,
    safe_dirname,
)

CONF_DIR = Path(__file__).resolve().parent / "conf"

LABELS = ("task", "hand", "cost", "sampler", "planner", "variant", "preset", "experiment", "perturbation")
STATE_DIR = ".contactmpc"
"""In a sweep's directory: one folder per running multirun with the outcomes of its jobs."""
SWEEP_STATE_ENV = "CONTACTMPC_SWEEP_STATE"
"""Set in a multirun job's process to its sweep's state folder (see :class:`SweepSummary`)."""

log = logging.getLogger("contactmpc")


def conf_members(conf_dir: Path = CONF_DIR) -> list[tuple[str, str, str]]:
    """``(group, member, target)`` of every member file ``conf/<group>/<member>.yaml`` whose top level
    has a ``_target_``: the objects the config builds."""
    members = []
    for path in sorted(conf_dir.glob("*/*.yaml")):
        node = OmegaConf.load(path)
        if isinstance(node, DictConfig) and "_target_" in node:
            members.append((path.parent.name, path.stem, node._target_))
    return members


# (group, name, schema) triples stored in Hydra's ConfigStore: the root schema, and one schema per
# member, generated from the signature of what it builds (contactmpc.config.schema). A member's YAML
# names its target and lists its schema, "/<group>_<member>_schema", in its defaults, so a typo in a key
# fails at compose time and every constructor parameter is settable; adding a member needs no other
# registration. The member schemas live at the root of the ConfigStore, not in their group: they are
# no choices of the group (`--help` and tab completion do not list them).
SCHEMAS = (
    (None, "config_schema", Config),
    *member_schemas(conf_members()),
)


def register_configs() -> None:
    """Store :data:`SCHEMAS` in Hydra's ConfigStore (idempotent); a name ``/x`` is stored at the root."""
    cs = ConfigStore.instance()
    for group, name, node in SCHEMAS:
        if name.startswith("/"):
            cs.store(name=name[1:], node=node)
        else:
            cs.store(group=group, name=name, node=node)


register_configs()


# Registered on import: a multirun job that runs in another process (joblib, submitit) imports this
# module when it unpickles the SweepSummary callback, before its directory is resolved.
OmegaConf.register_new_resolver("safe_dirname", safe_dirname, replace=True)


def build_scene(cfg: DictConfig):
    """Instantiate hand, task and scene from the composed config."""
    hand = instantiate(cfg.hand)
    task = instantiate(cfg.task)
    return instantiate(cfg.scene)(hand=hand, task=task)


# --------------------------------------------------------------------------------------------- jobs


def _sweep_state() -> Path | None:
    state = os.environ.get(SWEEP_STATE_ENV)
    return Path(state) if state else None


def _resolved(cfg: DictConfig) -> dict:
    try:
        return OmegaConf.to_container(cfg, resolve=True)
    except Exception:  # an interpolation that fails is the job's error to report; keep what there is
        return OmegaConf.to_container(cfg, resolve=False)


def run_job(cfg: DictConfig, labels: dict) -> dict:
    """Run the job of the composed config in its output directory, under the directory's lock.

    Returns:
        The outcome: ``{"status": ...}``, one of ``ok``, ``diverged``, ``error``, ``interrupted`` (the
        job ran), ``skipped`` (a finished record of the same trial), ``refused`` (a finished record of a
        different trial), ``busy`` (another process holds the directory's lock) or ``not_started``
        (the sweep was interrupted before this job began); ``record`` where the job wrote one.
    """
    output_dir = Path(cfg.output_dir)
    state = _sweep_state()
    if state is not None and (state / "STOP").exists():
        return {"status": "not_started"}
    if cfg.resume not in RESUME or not isinstance(cfg.resume, bool | str):
        print(f"contactmpc: error: resume={cfg.resume}: expected true, false or overwrite", file=sys.stderr)
        return {"status": "error"}
    config = _resolved(cfg)
    with job_lock(output_dir) as locked:
        if not locked:
            print(f"[contactmpc] skipped (in progress in another process): {output_dir}")
            return {"status": "busy"}
        action, line = resume_decision(output_dir, config, cfg.resume)
        if action != "run":
            print(line, file=sys.stderr if action == "refuse" else sys.stdout)
            return {"status": "skipped" if action == "skip" else "refused"}
        return _run(cfg, output_dir, config, labels)


def _run(cfg: DictConfig, output_dir: Path, config: dict, labels: dict) -> dict:
    job = None
    try:
        # Nonsense values fail first, before any work (contactmpc.validate); then the job's objects
        # (sampler, cost, planner) are built here, inside the guard: a job that cannot be built, or
        # whose config is refused, still leaves the record its function would have written (its
        # `record_failure`).
        check_config(config)
        job = instantiate(cfg.job)
        result = job(
            make_scene=functools.partial(build_scene, cfg),
            output_dir=output_dir,
            seed=cfg.seed,
            config=config,
            labels=labels,
        )
    except (Exception, KeyboardInterrupt) as err:
        if job is None and (record_failure := _record_failure(cfg.job._target_)) is not None:
            record_failure(output_dir, cfg.seed, err, config=config, labels=labels)
        record = output_dir / RECORD_NAME
        outcome: dict[str, Any] = {"status": failure_status(err)}
        if record.exists():
            outcome["record"] = str(record)
        if isinstance(err, KeyboardInterrupt):
            state = _sweep_state()
            if state is not None:  # no new job of this sweep starts
                (state / "STOP").touch()
            where = f"; record: {record}" if record.exists() else ""
            print(f"contactmpc: interrupted{where}", file=sys.stderr)
        else:
            # One line that names the problem; the trial's record (if it got that far) says the same.
            print(f"contactmpc: error: {one_line(err)}", file=sys.stderr)
        return outcome
    print(f"[contactmpc] {cfg.job._target_.rsplit('.', 1)[-1]}: wrote {result}")
    return {"status": "ok", "record": str(result)}


def _record_failure(target: str) -> Any:
    """The ``record_failure(output_dir, seed, error, config, labels)`` of a job function that writes a
    record (:func:`contactmpc.jobs.trial.record_failure`), or ``None``."""
    try:
        return getattr(get_method(target), "record_failure", None)
    except Exception:  # the target itself cannot be found: that is the error to report
        return None


@hydra.main(version_base="1.3", config_path="conf", config_name="config")
def main(cfg: DictConfig) -> dict:
    hc = HydraConfig.get()
    outcome = run_job(cfg, {g: hc.runtime.choices.get(g) for g in LABELS})
    if hc.mode != RunMode.MULTIRUN and outcome["status"] not in ("ok", "skipped"):
        sys.exit(130 if outcome["status"] == "interrupted" else 1)
    return outcome  # a multirun goes on with its other jobs; SweepSummary counts the outcomes


# ------------------------------------------------------------------------------------------- sweeps


class SweepSummary(Callback):
    """Counts a multirun's job outcomes, prints one summary line and sets the exit status.

    Registered in ``conf/config.yaml`` (``hydra.callbacks``). Jobs may run in other processes (joblib,
    submitit), so each job's outcome is a file in ``<sweep dir>/.contactmpc/<this multirun>/``, written
    where the job ran (``on_job_start``: ``unfinished``; ``on_job_end``: what :func:`main` returned) and
    read here at the end. The exit status is 130 after Ctrl-C, else 1 if any job failed, was refused,
    ran elsewhere or left no outcome, else 0.

    Ctrl-C during a multirun whose jobs run in other processes stops it gently: the jobs running (which
    get the same Ctrl-C from the terminal) write their records with status ``interrupted``, no new job
    starts, and the summary follows; a second Ctrl-C aborts at once.
    """

    COUNTED = ("ok", "diverged", "error", "interrupted")
    OTHERS = {
        "refused": "refused (a different trial's record)",
        "busy": "running in another process",
        "not_started": "not started (interrupted)",
        "unfinished": "left no outcome",
    }

    def __init__(self) -> None:
        self.state: Path | None = None
        self.sweep_dir: Path | None = None
        self.in_job = False  # a job runs in this process (the basic launcher)
        self.stopping = False
        self._sigint: Any = None

    def on_multirun_start(self, config: DictConfig, **kwargs: Any) -> None:
        self.sweep_dir = Path(str(config.hydra.sweep.dir)).absolute()
        (self.sweep_dir / STATE_DIR).mkdir(parents=True, exist_ok=True)
        self.state = Path(tempfile.mkdtemp(prefix="multirun-", dir=self.sweep_dir / STATE_DIR))
        with contextlib.suppress(ValueError):  # not the main thread: keep Python's handler
            self._sigint = signal.signal(signal.SIGINT, self._on_sigint)

    def _on_sigint(self, signum: int, frame: Any) -> None:
        if self.in_job or self.stopping:
            raise KeyboardInterrupt
        self.stopping = True
        if self.state is not None:
            (self.state / "STOP").touch()
        print(
            "[contactmpc] stopping the sweep: running jobs end as interrupted, no new job starts "
            "(Ctrl-C again to abort)",
            file=sys.stderr,
        )

    def on_job_start(self, config: DictConfig, **kwargs: Any) -> None:
        if self.state is None:
            return
        self.in_job = True
        os.environ[SWEEP_STATE_ENV] = str(self.state)
        write_json(self._outcome_path(config), {"status": "unfinished"})

    def on_job_end(self, config: DictConfig, job_return: Any, **kwargs: Any) -> None:
        if self.state is None:
            return
        self.in_job = False
        value = job_return._return_value
        if job_return.status == JobStatus.COMPLETED and isinstance(value, dict):
            outcome = value
        else:
            error = one_line(value) if isinstance(value, BaseException) else None
            outcome = {"status": "error", "error": error}
        outcome["dir"] = str(config.hydra.runtime.output_dir)
        write_json(self._outcome_path(config), outcome)

    def _outcome_path(self, config: DictConfig) -> Path:
        return self.state / f"job{config.hydra.job.num}.json"

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        if self._sigint is not None:
            signal.signal(signal.SIGINT, self._sigint)
        if self.state is None:
            return
        os.environ.pop(SWEEP_STATE_ENV, None)
        outcomes = [json.loads(p.read_text()) for p in sorted(self.state.glob("job*.json"))]
        shutil.rmtree(self.state, ignore_errors=True)
        with contextlib.suppress(OSError):
            self.state.parent.rmdir()  # the last multirun on this sweep removes .contactmpc/
        counts = Counter(o.get("status") for o in outcomes)
        line = " / ".join(f"{counts[s]} {s}" for s in self.COUNTED)
        line += f", {counts['skipped']} skipped"
        line += "".join(f", {counts[s]} {what}" for s, what in self.OTHERS.items() if counts[s])
        print(f"[contactmpc] sweep {self.sweep_dir}: {len(outcomes)} jobs: {line}")
        # Hydra passes no job results to the caller of main(): the exit status is set from here.
        if self.stopping or counts["interrupted"] or counts["not_started"]:
            raise SystemExit(130)
        if any(status not in ("ok", "diverged", "skipped") for status in counts):
            raise SystemExit(1)


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:  # outside a job (a job's Ctrl-C is handled in run_job)
        print("contactmpc: interrupted", file=sys.stderr)
        sys.exit(130)
