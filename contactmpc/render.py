"""Offscreen rendering of scenes (and, later, references and trials) with ``mujoco.Renderer``.

Set ``MUJOCO_GL=egl`` (headless GPU/Mesa) or ``osmesa`` before MuJoCo creates its first context;
``launch.py`` defaults it to ``egl``.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless by default; read when the first context is made

from collections.abc import Sequence  # noqa: E402
from pathlib import Path  # noqa: E402

import imageio.v3 as iio  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from contactmpc.scene import Scene  # noqa: E402


def make_camera(
    lookat: Sequence[float], distance: float, azimuth: float, elevation: float
) -> mujoco.MjvCamera:
    """A free camera orbiting ``lookat``.

    Args:
        lookat: (3,) point the camera looks at (m).
        distance: distance from ``lookat`` (m).
        azimuth: degrees about the world z axis.
        elevation: degrees above the horizon (negative looks down).
    """
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = lookat
    cam.distance = distance
    cam.azimuth = azimuth
    cam.elevation = elevation
    return cam


def task_camera(scene: Scene) -> mujoco.MjvCamera:
    """The task's default view (``Task.view``: lookat, distance, azimuth, elevation)."""
    return make_camera(**scene.task.view)


def render_frame(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    camera: mujoco.MjvCamera,
    size: tuple[int, int] = (480, 640),
    renderer: mujoco.Renderer | None = None,
) -> np.ndarray:
    """Render one RGB frame.

    Args:
        model: the model of ``data``.
        data: the state to show (kinematics must be current).
        camera: the camera to render from.
        size: (height, width) in pixels.
        renderer: a renderer to reuse (its size wins), or ``None`` to make a temporary one.

    Returns:
        (H, W, 3) uint8 image.
    """
    own = renderer is None
    r = mujoco.Renderer(model, *size) if own else renderer
    try:
        r.update_scene(data, camera)
        return r.render().copy()
    finally:
        if own:
            r.close()


def render_scene(scene: Scene, output_dir: str | Path, size: tuple[int, int] = (480, 640), **_) -> Path:
    """Render the task's scene with the hand in its initial pose to ``<output_dir>/scene_<task>.png``.

    Returns:
        The path of the written PNG.
    """
    data = scene.make_data()
    img = render_frame(scene.plant_model, data, task_camera(scene), size)
    path = Path(output_dir) / f"scene_{scene.task.name}.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, img)
    return path
