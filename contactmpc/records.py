"""Trial records: one flat ``trial.json`` plus a compact per-step time series, written atomically.

A record (``schema`` 1) holds, besides the trial's outcome and costs
(:func:`contactmpc.jobs.trial.summarize`):

* the labels: the name of each config choice (``task``, ``hand``, ``cost``, ``sampler``, ``planner``,
  ``variant``, ``fidelity``, ``preset``, ``experiment``, ...; ``launch.LABELS``), ``seed`` and ``status``;
  a group left unset is recorded by the name of what it composes to (``variant: full``);
* ``config``: the resolved config, the trial's identity (less :data:`NOT_THE_TRIAL`);
* where and how it ran: ``versions`` (packages), ``git_revision``, ``cpu`` (the processor's model name)
  and ``logical_cpus``; ``host`` (:func:`host`: the machine's name, its processor's full description and
  its core counts); ``threads`` (rollout threads); ``concurrent_trials``: the most trials running at once
  on the machine while this one ran, itself included (:class:`RunningTrials`: it changes CPU-seconds).

A field added later is absent from older records: readers take it as unknown (``record.get``); none of
these fields is part of a trial's identity, so a resume (:func:`contactmpc.runs.resume_decision`)
compares only the configs and an older record resumes as before.
"""

from __future__ import annotations

import functools
import inspect
import json
import os
import platform
import secrets
import socket
import subprocess
import tempfile
import threading
from collections.abc import Iterable, Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

RECORD_NAME = "trial.json"
SERIES_NAME = "timeseries.npz"


def one_line(err: BaseException) -> str:
    """``"<Type>: <message>"`` on one line (whitespace collapsed), or the type alone without a message:
    how records and error lines name an exception."""
    message = " ".join(str(err).split())
    return f"{type(err).__name__}: {message}" if message else type(err).__name__


NOT_THE_TRIAL: tuple[str, ...] = (
    "output_dir",  # the run directory (Hydra's runtime.output_dir)
    "hydra",  # Hydra's own settings, should a record hold them
    "resume",  # whether a finished record is skipped
    "planner.nthread",  # rollout threads: the same rollouts, faster
    "job.progress",  # the progress bar
    "job.video",  # a video rendered after the trial ...
    "job.video_speed",  # ... and its playback speed
    "job.reference_cache",  # where synthesised references are cached (the same reference either way)
    # the root slot named after the variant group: its files are global (they set cost, sampler, ...),
    # so a plain value here changes nothing (experiment=operating_point set "full" until 2026-11-25)
    "variant",
)
"""Config keys (with everything under them) that do not change what a trial does: where it is written,
how fast it runs, what it shows. A trial's identity is its resolved config less these (and its seed):
resuming (``launch.py``) and the analysis (``analysis.aggregate``) both compare configs this way."""
SCHEMA_VERSION = 1

NO_DEFAULT = object()
"""What :func:`option_default` returns for a key that is no keyword option of a target."""


def option_default(flat: dict[str, Any], key: str) -> Any:
    """The default of the option ``key`` (dotted) of the config member that ``flat`` (a flattened
    config) builds at the key's parent: the keyword default of the class or function its
    ``<parent>._target_`` names, as a record stores it (a tuple as a list). A record made before an
    option existed lacks the key; the option's default is what the code did then (a new option keeps
    the old behaviour at its default), so a resume and the analysis read the absent key as it.

    Returns:
        the default, or :data:`NO_DEFAULT` where there is none (no target at the parent, a target
        that cannot be found, or no such keyword with a default).
    """
    parent, _, name = key.rpartition(".")
    target = flat.get(f"{parent}._target_") if parent else None
    if not isinstance(target, str):
        return NO_DEFAULT
    text = _keyword_default(target, name)
    return NO_DEFAULT if text is None else json.loads(text)


def with_defaults(flat: dict[str, Any], keys: Iterable[str]) -> dict[str, Any]:
    """``flat`` (a flattened config) plus, for each of ``keys`` it lacks, that option's default
    (:func:`option_default`) where it has one: a record read as if it had been made with every option
    that exists now."""
    out = dict(flat)
    for key in keys:
        if key not in out and (default := option_default(flat, key)) is not NO_DEFAULT:
            out[key] = default
    return out


@functools.lru_cache(maxsize=4096)
def _keyword_default(target: str, name: str) -> str | None:
    """The default of keyword ``name`` of the callable ``target`` names, as JSON text; ``None``: none."""
    # imported here: config is not needed to write a record
    from contactmpc.config import locate, parameters

    try:
        obj = locate(target)
        param = inspect.signature(obj).parameters.get(name)
        if param is None:  # a field of the job's inputs object, or a base's keyword taken by **kwargs
            param = next((p for p, _ in parameters(obj) if p.name == name), None)
    except (ImportError, TypeError, ValueError):
        return None
    if param is None or param.default is inspect.Parameter.empty:
        return None
    try:
        return json.dumps(param.default)
    except TypeError:
        return None


def _atomic_write(path: Path, write) -> None:
    """Write ``path`` through a temp file in its directory and a rename: readers see the old file or
    the new one, never half of it. The file gets the permissions of any new file (0666 less the
    umask, e.g. 0644), not the 0600 of :func:`tempfile.mkstemp`."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.parent / f".{path.name}.{secrets.token_hex(8)}.tmp"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _jsonable(x):
    # any mapping and sequence (a config's nodes among them) as JSON's objects and arrays
    if isinstance(x, Mapping):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, Sequence) and not isinstance(x, str | bytes):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def write_json(path: str | Path, record: dict) -> Path:
    """Write ``record`` as JSON atomically (temp file + rename); NaN/inf become null."""
    path = Path(path)
    data = json.dumps(_jsonable(record), indent=2, sort_keys=False).encode()
    _atomic_write(path, lambda f: f.write(data))
    return path


def write_series(path: str | Path, arrays: dict[str, np.ndarray]) -> Path:
    """Write a per-step time series as a compressed ``.npz`` atomically."""
    path = Path(path)
    _atomic_write(path, lambda f: np.savez_compressed(f, **arrays))
    return path


def versions() -> dict[str, str]:
    """Versions of the packages a record depends on."""
    out = {}
    for name in ("contactmpc", "mujoco", "numpy", "scipy", "hydra-core", "omegaconf", "numba"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def cpu_model() -> str:
    """The processor's model name (``/proc/cpuinfo``'s ``model name``; else :func:`platform.processor`),
    so that timings from different machines are never mixed."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return " ".join(line.split(":", 1)[1].split())
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def machine() -> dict[str, object]:
    """Where a record was made, as its fields: ``cpu`` (the model) and ``logical_cpus``."""
    return {"cpu": cpu_model(), "logical_cpus": os.cpu_count()}


def _cpuinfo() -> list[dict[str, str]]:
    """``/proc/cpuinfo``, one ``{key: value}`` per logical processor (empty where there is none)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return []
    blocks = []
    for block in text.strip().split("\n\n"):
        entry = {}
        for line in block.splitlines():
            key, sep, value = line.partition(":")
            if sep:
                entry[key.strip()] = " ".join(value.split())
        blocks.append(entry)
    return blocks


def host() -> dict[str, object]:
    """The machine a record was made on: ``name`` (the host name), ``cpu`` (the processor's full
    description: model name, vendor, family, model and stepping, as ``/proc/cpuinfo`` has them),
    ``logical_cpus`` and ``physical_cores`` (``None`` where unknown)."""
    info = _cpuinfo()
    first = info[0] if info else {}
    parts = [
        first[k] if k == "vendor_id" else f"{k.split()[-1]} {first[k]}"
        for k in ("vendor_id", "cpu family", "model", "stepping")
        if k in first
    ]
    cpu = cpu_model() + (f" ({', '.join(parts)})" if parts else "")
    cores = {(e.get("physical id"), e.get("core id")) for e in info if "core id" in e}
    return {
        "name": socket.gethostname(),
        "cpu": cpu,
        "logical_cpus": os.cpu_count(),
        "physical_cores": len(cores) or None,
    }


RUNNING_DIR_ENV = "CONTACTMPC_RUNNING_DIR"
"""Environment variable: the directory of :class:`RunningTrials`' files (default:
``<tmp>/contactmpc-running``)."""


def _proc_stat(pid: int) -> list[str] | None:
    """The fields of ``/proc/<pid>/stat`` after the process's name (the state first); ``None`` where
    unknown (no such process, or no ``/proc``)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return stat.rpartition(")")[2].split()


def _start_time(pid: int) -> str | None:
    """When process ``pid`` started (``/proc/<pid>/stat``'s start time, in clock ticks), so a pid file of
    a dead process is not taken for a new process given the same pid; ``None`` where unknown."""
    fields = _proc_stat(pid)
    return None if fields is None else fields[19]


def _stopped(pid: int) -> bool:
    """Whether process ``pid`` is stopped (``/proc/<pid>/stat``'s state ``T``, e.g. paused by SIGSTOP, or
    ``t``, stopped by a tracer): it holds no core while stopped; ``False`` where unknown."""
    fields = _proc_stat(pid)
    return fields is not None and fields[0] in ("T", "t")


def _alive(pid: int, started: str | None) -> bool:
    if started is not None and Path("/proc").is_dir():
        return _start_time(pid) == started
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class RunningTrials:
    """A machine-wide registry of running trials: how many ran at once while one did.

    While entered (``with RunningTrials() as running:``), the trial has a file ``<pid>-<token>`` in
    ``directory`` naming its process (and the process's start time). :meth:`count` counts the files of
    live processes that are not stopped (a trial paused with SIGSTOP holds no core until it is continued;
    a stale file, of a process that died without removing it, is ignored and removed); a
    thread samples it every ``interval`` seconds, and :attr:`max` is the most seen, the trial itself
    included. It only reads and writes small files: the trial computes the same with it or without.

    Args:
        directory: where the files are; ``None``: ``$CONTACTMPC_RUNNING_DIR``, else
            ``<tempfile.gettempdir()>/contactmpc-running``.
        interval: seconds between samples.
    """

    def __init__(self, directory: str | Path | None = None, interval: float = 1.0) -> None:
        default = os.environ.get(RUNNING_DIR_ENV) or Path(tempfile.gettempdir()) / "contactmpc-running"
        self.directory = Path(directory if directory is not None else default)
        self.interval = float(interval)
        self.max = 0
        self._file: Path | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def count(self) -> int:
        """Trials running now on this machine (files of live processes that are not stopped)."""
        n = 0
        try:
            files = list(self.directory.iterdir())
        except OSError:
            return 0
        for path in files:
            pid_text, _, _ = path.name.partition("-")
            try:
                started = path.read_text().strip() or None
                pid = int(pid_text)
            except (OSError, ValueError):
                continue
            if _alive(pid, started):
                n += not _stopped(pid)
            else:
                path.unlink(missing_ok=True)
        return n

    def sample(self) -> int:
        """Count now and keep the most seen in :attr:`max`; returns the count."""
        n = self.count()
        self.max = max(self.max, n)
        return n

    def _sample_loop(self) -> None:
        while not self._stop.wait(self.interval):
            self.sample()

    def __enter__(self) -> RunningTrials:
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            pid = os.getpid()
            self._file = self.directory / f"{pid}-{secrets.token_hex(4)}"
            self._file.write_text(_start_time(pid) or "")
        except OSError:  # a registry that cannot be written counts nothing; the trial runs all the same
            self._file = None
        self.sample()
        self._thread = threading.Thread(target=self._sample_loop, name="running-trials", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        self.sample()
        if self._file is not None:
            self._file.unlink(missing_ok=True)


def git_revision(cwd: str | Path | None = None) -> str | None:
    """The git revision of the source tree (``+dirty`` if modified), or ``None`` outside git."""
    cwd = Path(cwd or Path(__file__).resolve().parent)
    try:
        rev = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=cwd, capture_output=True, text=True, timeout=5, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=cwd,
            capture_output=True,
            text=True,
            timeout=5,
        ).stdout.strip()
        return rev + ("+dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return None
