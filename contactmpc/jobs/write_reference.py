"""The write-reference job (``conf/job/write_reference.yaml``): a task's reference to an ``.npz``."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from contactmpc.reference.source import get_reference
from contactmpc.scene import Scene


def write_reference(
    make_scene: Callable[[], Scene],
    output_dir: str | Path,
    path: str | None = None,
    reference_cache: str | None = "outputs/cache/references",
    **_,
) -> Path:
    """Write the task's reference (synthesised, or the user's file re-validated) to an ``.npz``.

    Args:
        make_scene: builds the scene.
        output_dir: the run directory (the default destination).
        path: destination ``.npz``; ``None`` = ``<output_dir>/reference_<task>.npz``.
        reference_cache: directory caching synthesised references, shared with the trial job (a
            reference synthesised for a trial is written from there, and one synthesised here is
            cached for the trials); ``None`` synthesises afresh.
    """
    scene = make_scene()
    ref = get_reference(scene, reference_cache)
    return ref.save(Path(path) if path else Path(output_dir) / f"reference_{scene.task.name}.npz")
