"""The summary of a multirun of ``launch.py``: a Hydra callback that counts the jobs' outcomes, prints one
line and sets the exit status.

Registered in ``conf/config.yaml`` (``hydra.callbacks.sweep_summary``). It lives beside ``launch.py``, as
a top-level module, because it is Hydra's (the library, ``contactmpc/``, never imports Hydra).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import sys
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

from hydra.core.utils import JobStatus
from hydra.experimental.callback import Callback
from omegaconf import DictConfig, OmegaConf

from contactmpc.records import one_line, write_json
from contactmpc.runs import safe_dirname

__all__ = ["STATE_DIR", "SWEEP_STATE_ENV", "SweepSummary"]

STATE_DIR = ".contactmpc"
"""In a sweep's directory: one folder per running multirun with the outcomes of its jobs."""
SWEEP_STATE_ENV = "CONTACTMPC_SWEEP_STATE"
"""Set in a multirun job's process to its sweep's state folder (see :class:`SweepSummary`)."""

# Registered on import: a multirun job that runs in another process (joblib, submitit) imports this
# module when it unpickles the SweepSummary callback, before its directory (hydra.sweep.subdir) is
# resolved. launch.py imports this module, so the process that composes the config has it too.
OmegaConf.register_new_resolver("safe_dirname", safe_dirname, replace=True)


class SweepSummary(Callback):
    """Counts a multirun's job outcomes, prints one summary line and sets the exit status.

    Jobs may run in other processes (joblib, submitit), so each job's outcome is a file in
    ``<sweep dir>/.contactmpc/<this multirun>/``, written where the job ran (``on_job_start``:
    ``unfinished``; ``on_job_end``: what ``launch.main`` returned) and read here at the end. The exit
    status is 130 after Ctrl-C, else 1 if any job failed, was refused, ran elsewhere or left no outcome,
    else 0.

    Ctrl-C during a multirun whose jobs run in other processes stops it gently: the jobs running (which
    get the same Ctrl-C from the terminal) write their records with status ``interrupted``, no new job
    starts, and the summary follows; a second Ctrl-C aborts at once. A SIGTERM is taken as a Ctrl-C
    (``timeout`` and a cluster's scheduler signal every process of the job, so the jobs running get it
    too and end as ``interrupted``; launch.py's jobs take it as their Ctrl-C).
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
        self._sigterm: Any = None

    def on_multirun_start(self, config: DictConfig, **kwargs: Any) -> None:
        self.sweep_dir = Path(str(config.hydra.sweep.dir)).absolute()
        (self.sweep_dir / STATE_DIR).mkdir(parents=True, exist_ok=True)
        self.state = Path(tempfile.mkdtemp(prefix="multirun-", dir=self.sweep_dir / STATE_DIR))
        with contextlib.suppress(ValueError):  # not the main thread: keep Python's handlers
            self._sigint = signal.signal(signal.SIGINT, self._on_stop)
            self._sigterm = signal.signal(signal.SIGTERM, self._on_stop)

    def _on_stop(self, signum: int, frame: Any) -> None:
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
        if self._sigterm is not None:
            signal.signal(signal.SIGTERM, self._sigterm)
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
