"""The render-scene job (``conf/job/render_scene.yaml``): a task's scene with the hand at home."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Annotated

from contactmpc.render import render_frame, task_camera, write_png
from contactmpc.scene import Scene
from contactmpc.validate import Ge, checked


@checked
def render_scene(
    make_scene: Callable[[], Scene],
    output_dir: str | Path,
    size: tuple[Annotated[int, Ge(1)], Annotated[int, Ge(1)]] = (480, 640),
    **_,
) -> Path:
    """Render the task's scene with the hand in its initial pose to ``<output_dir>/scene_<task>.png``.

    Args:
        make_scene: builds the scene (``launch.py`` passes one built from the config).
        output_dir: where the PNG goes.
        size: (height, width) in pixels.

    Returns:
        The path of the written PNG.
    """
    scene = make_scene()
    img = render_frame(scene.plant_model, scene.make_data(), task_camera(scene), tuple(size))
    return write_png(img, Path(output_dir) / f"scene_{scene.task.name}.png")
