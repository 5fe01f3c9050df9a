"""The write-reference job (``conf/job/write_reference.yaml``): a task's reference to an ``.npz``."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from contactmpc.reference.source import get_reference
from contactmpc.scene import Scene


def write_reference(
    make_scene: Callable[[], Scene], output_dir: str | Path, path: str | None = None, **_
) -> Path:
    """Write the task's reference (synthesised, or the user's file re-validated) to an ``.npz``.

    Args:
        make_scene: builds the scene.
        output_dir: the run directory (the default destination).
        path: destination ``.npz``; ``None`` = ``<output_dir>/reference_<task>.npz``.
    """
    scene = make_scene()
    ref = get_reference(scene, None)
    return ref.save(Path(path) if path else Path(output_dir) / f"reference_{scene.task.name}.npz")
