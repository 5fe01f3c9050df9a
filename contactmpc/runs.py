"""Runs on disk, independent of Hydra: flat job directory names, the record a directory holds, whether
a job resumes, skips or refuses it, and the per-job lock. ``launch.py`` drives them.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from contactmpc.labels import upgrade_config
from contactmpc.records import NOT_THE_TRIAL, RECORD_NAME, with_defaults

FINISHED = ("ok", "diverged")
"""Record statuses of a job that finished (a resume skips it)."""
RESUME = (True, False, "overwrite")
"""Values of ``resume``: skip a job whose finished record holds the same trial (``true``), run it
again (``false``), or run it even over a finished record of a different trial (``overwrite``)."""
LOCK_NAME = ".lock"
"""In a job's directory: locked (``flock``) while a process runs the job."""


_FOLDERS = re.compile(r"(?<==)[^,]*/")  # the folders of a path value: "=/data/refs/" in "k=/data/refs/a.npz"
_UNSAFE = re.compile(r"[^A-Za-z0-9._,=+-]")


def safe_dirname(name: str, max_length: int = 200) -> str:
    """``name`` as one flat, portable directory name (the resolver of ``hydra.sweep.subdir``).

    A path value keeps its file name only (``task.reference_path=/data/apple.npz`` ->
    ``task.reference_path=apple.npz``), other characters than ASCII letters, digits and ``. _ , = + -``
    become ``_``, and a name longer than ``max_length`` is cut. Whenever the name changed, 8 hex digits
    of the original's SHA-1 are appended, so different overrides keep different directories. A safe,
    short name (``seed=0,task=apple``) is returned as it is.
    """
    safe = _UNSAFE.sub("_", _FOLDERS.sub("", name))
    if safe == name and len(name) <= max_length:
        return name
    return f"{safe[: max_length - 9]}-{hashlib.sha1(name.encode()).hexdigest()[:8]}"


def read_record(output_dir: Path) -> dict | None:
    """The record in ``output_dir``, if there is a readable one."""
    try:
        record = json.loads((output_dir / RECORD_NAME).read_text())
    except (OSError, json.JSONDecodeError):
        return None
    return record if isinstance(record, dict) else None


def existing_record(output_dir: Path) -> dict | None:
    """The finished record in ``output_dir`` (status ok or diverged), if any."""
    record = read_record(output_dir)
    return record if record is not None and record.get("status") in FINISHED else None


_ABSENT = object()


def _plain(value: Any) -> Any:
    """A config value as its record stores it (JSON: tuples as lists, NaN and infinities as null)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _flatten(node: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(node, dict) and node:
        return {k: v for key, value in node.items() for k, v in _flatten(value, f"{prefix}{key}.").items()}
    return {prefix[:-1]: node}


def _show(value: Any, width: int = 40) -> str:
    """A value in a line: a long string by its end (a dotted path's class, a file's name), else its start."""
    if isinstance(value, str):
        return value if len(value) <= width else "..." + value[3 - width :]
    text = "<absent>" if value is _ABSENT else json.dumps(value)
    return text if len(text) <= width else text[: width - 3] + "..."


def config_differences(stored: dict | None, new: dict) -> list[str]:
    """Where two resolved configs describe different trials: ``"key: new != stored"`` per dotted key.

    Keys in :data:`NOT_THE_TRIAL` are ignored; ``_target_`` keys come first, then the others in order.
    A key one config lacks reads as its option's default (:func:`~contactmpc.records.option_default`:
    a record made before the option existed is the same trial as one with the option at its default),
    and a key since renamed by its name now (:func:`~contactmpc.labels.upgrade_config`). A record
    without a config differs from every config.
    """
    if not isinstance(stored, dict):
        return ["config: not in the record"]
    a, b = _flatten(_plain(upgrade_config(stored))), _flatten(_plain(upgrade_config(new)))

    def compared(key: str) -> bool:
        return not any(key == k or key.startswith(k + ".") for k in NOT_THE_TRIAL)

    a, b = with_defaults(a, b), with_defaults(b, a)  # an option the stored record predates: its default
    keys = sorted(filter(compared, a.keys() | b.keys()), key=lambda k: (not k.endswith("_target_"), k))
    return [
        f"{k}: {_show(b.get(k, _ABSENT))} != {_show(a.get(k, _ABSENT))}"
        for k in keys
        if a.get(k, _ABSENT) != b.get(k, _ABSENT)
    ]


def resume_decision(output_dir: Path, config: dict, resume: bool | str) -> tuple[str, str | None]:
    """What to do with a job given the record its directory may hold already.

    Returns:
        ``("run", None)``; ``("skip", line)``: a finished record of the same trial and ``resume`` is
        true; or ``("refuse", line)``: a finished record of a different trial, which only
        ``resume=overwrite`` replaces. Unfinished records (error, interrupted) are always run again.
    """
    record = existing_record(output_dir)
    path = output_dir / RECORD_NAME
    if record is None or resume == "overwrite":
        return "run", None
    differences = config_differences(record.get("config"), config)
    if differences:
        more = len(differences) - 3
        shown = ", ".join(differences[:3]) + (f", ... {more} more" if more > 0 else "")
        return "refuse", (
            f"contactmpc: error: {path} holds a different trial ({shown}); "
            "re-run with resume=overwrite or use another directory"
        )
    if resume is True:
        return "skip", f"[contactmpc] skipped (record exists, status {record['status']}): {path}"
    return "run", None


@contextlib.contextmanager
def job_lock(output_dir: Path) -> Iterator[bool]:
    """Lock ``output_dir/.lock`` (``flock``, not blocking) while the job runs; yields whether it got it."""
    output_dir.mkdir(parents=True, exist_ok=True)
    with open(output_dir / LOCK_NAME, "a") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            yield False
            return
        try:
            yield True
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)
