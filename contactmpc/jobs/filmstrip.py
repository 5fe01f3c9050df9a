"""The filmstrip job (``conf/job/filmstrip.yaml``): frames of a task's reference side by side."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Annotated

from contactmpc.reference.source import get_reference
from contactmpc.render import render_reference_filmstrip
from contactmpc.scene import Scene
from contactmpc.validate import Ge, checked


@checked
def reference_filmstrip(
    make_scene: Callable[[], Scene],
    output_dir: str | Path,
    num_frames: Annotated[int, Ge(1)] = 7,
    size: tuple[Annotated[int, Ge(1)], Annotated[int, Ge(1)]] = (240, 320),
    reference_cache: str | None = "outputs/cache/references",
    **_,
) -> Path:
    """Render a filmstrip of the task's reference to ``<output_dir>/filmstrip_<task>.png``.

    Args:
        make_scene: builds the scene.
        output_dir: where the PNG goes.
        num_frames: frames in the strip, evenly spaced in time.
        size: (height, width) of each frame in pixels.
        reference_cache: cache directory of synthesised references (``None`` disables).
    """
    scene = make_scene()
    ref = get_reference(scene, reference_cache)
    return render_reference_filmstrip(
        scene, ref, Path(output_dir) / f"filmstrip_{scene.task.name}.png", num_frames, tuple(size)
    )
