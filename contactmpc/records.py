"""Trial records: one flat ``trial.json`` plus a compact per-step time series, written atomically."""

from __future__ import annotations

import functools
import inspect
import json
import os
import platform
import secrets
import subprocess
from collections.abc import Iterable
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
    from contactmpc.config import locate  # imported here: config is not needed to write a record

    try:
        param = inspect.signature(locate(target)).parameters.get(name)
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
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
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
