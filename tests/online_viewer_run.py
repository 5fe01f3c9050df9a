"""An online run with the viewer and a scripted drag, under a (virtual) display.

Run by ``tests/test_online.py`` under ``xvfb-run`` (or on the display of ``DISPLAY``); it also took the
README's screenshot (``analysis/images/online_viewer.png``)::

    mkdir -p /tmp/fb && xvfb-run -a -s "-screen 0 1280x800x24 -fbdir /tmp/fb" \\
        python tests/online_viewer_run.py --task apple --duration 4.6 --slowdown 4 \\
        --drag 3.6 4.6 --pull 0 0.12 0.1 --shot-at 4.35 --planner \\
        --framebuffer /tmp/fb/Xvfb_screen0 --shot analysis/images/online_viewer.png

(``--planner`` with no overrides: the lite preset; by default a tiny planner, for the test.)

It drags the task's object the way a mouse drag does (the viewer's ``MjvPerturb``: the object selected,
a translation spring towards its position at the drag's start + ``--pull``, from the first to the
second ``--drag`` time), optionally saves the screen at ``--shot-at`` (read from Xvfb's ``-fbdir``
framebuffer, an XWD file), and prints one JSON line: the run's drags, the object's height, the ghost's
geoms.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import mujoco
import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[1]
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from contactmpc.online import OnlineLoop  # noqa: E402
from contactmpc.viewer import LiveViewer  # noqa: E402


def read_xwd(path: str | Path) -> np.ndarray:
    """(H, W, 3) uint8 RGB of an XWD screen dump of 32 bits per pixel (what ``Xvfb -fbdir`` keeps)."""
    raw = np.fromfile(path, np.uint8)
    header = raw[:100].view(">u4")
    size, width, height, byte_order, bits, per_line, ncolors = (
        int(header[i]) for i in (0, 4, 5, 7, 11, 12, 19)
    )
    if bits != 32:
        raise ValueError(f"{path}: {bits} bits per pixel, expected 32")
    start = size + 12 * ncolors
    pixels = raw[start : start + per_line * height].reshape(height, per_line)[:, : 4 * width]
    pixels = pixels.reshape(height, width, 4)
    return pixels[..., [2, 1, 0]] if byte_order == 0 else pixels[..., [1, 2, 3]]


class ScriptedViewer(LiveViewer):
    """The live viewer, with a drag of the object scripted in control time and an optional screenshot."""

    drag: tuple[float, float] = (0.1, 0.3)
    pull: tuple[float, float, float] = (0.0, 0.0, 0.2)
    shot_at: float | None = None
    framebuffer: str | None = None
    shot: str | None = None
    shot_stats: dict | None = None

    def sync(self, data, t, lines) -> None:
        pert, body = self.handle.perturb, int(self.scene.index.object_bodies[0])
        if self.drag[0] <= t < self.drag[1]:
            if not pert.active:
                # what a double-click on the object and a Ctrl + right drag set (mjv_initPerturb,
                # mjv_movePerturb): the grabbed point, the point it is pulled towards, the spring's mass
                pert.select = body
                pert.localpos[:] = 0.0
                pert.localmass = self.model.body_subtreemass[body]
                pert.refselpos[:] = data.xpos[body] + np.asarray(self.pull)
                pert.refpos[:] = pert.refselpos
                pert.active = int(mujoco.mjtPertBit.mjPERT_TRANSLATE)
        elif pert.active:
            pert.active = 0
            pert.select = 0
        super().sync(data, t, lines)
        if self.shot_at is not None and t >= self.shot_at and self.shot_stats is None and self.framebuffer:
            img = read_xwd(self.framebuffer)
            self.shot_stats = {"std": float(img.std()), "mean": float(img.mean()), "shape": list(img.shape)}
            if self.shot:
                from PIL import Image

                rows, cols = np.nonzero(img.any(axis=-1))  # the window, without the screen's black
                Image.fromarray(img[: rows.max() + 1, : cols.max() + 1]).save(self.shot)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="apple")
    parser.add_argument("--reference", help="a reference .npz (task.reference_path); default: the task's")
    parser.add_argument("--duration", type=float, default=0.5)
    parser.add_argument("--slowdown", type=float, default=10.0)
    parser.add_argument("--drag", type=float, nargs=2, default=(0.1, 0.3))
    parser.add_argument("--pull", type=float, nargs=3, default=(0.0, 0.0, 0.2))
    parser.add_argument("--shot-at", type=float)
    parser.add_argument("--framebuffer")
    parser.add_argument("--shot")
    parser.add_argument("--planner", nargs="*", default=["planner.num_samples=8", "planner.horizon=0.3"])
    args = parser.parse_args(argv)

    from hydra.utils import instantiate

    from contactmpc.reference.source import get_reference
    from contactmpc.trial import Trial
    from tests.conftest import build_scene, compose_config

    overrides = [f"task={args.task}", "planner.nthread=1", *args.planner]
    if args.reference:
        overrides.append(f"task.reference_path={args.reference}")
    cfg = compose_config(overrides)
    scene = build_scene(tuple(overrides))
    reference = get_reference(scene, str(REPO_ROOT / cfg.job.reference_cache))
    planner = instantiate(cfg.planner)
    trial = Trial(
        scene, reference, instantiate(cfg.sampler), instantiate(cfg.cost), planner, 0, duration=args.duration,
        progress=False,
    )  # fmt: skip
    opened: list[ScriptedViewer | None] = []

    def open_viewer(*a) -> ScriptedViewer | None:
        viewer = ScriptedViewer.open(*a)
        if viewer is not None:
            viewer.drag, viewer.pull, viewer.shot_at = tuple(args.drag), tuple(args.pull), args.shot_at
            viewer.framebuffer, viewer.shot = args.framebuffer, args.shot
        opened.append(viewer)
        return viewer

    loop = OnlineLoop(trial, args.slowdown, viewer=open_viewer)
    try:
        series = loop.run().arrays()
    finally:
        planner.close()
    summary = loop.summary()
    viewer = opened[0] if opened else None
    c = scene.task.layout.free_columns[0]  # the free object's x, y, z, quaternion
    z = series["object_qpos"][:, c + 2]
    out = {
        "viewer": summary["viewer"],
        "drags": summary["drags"],
        "object_body": scene.task.object_bodies[0],
        "z_start": float(z[0]),
        "z_max": float(z.max()),
        "time_of_z_max": float(series["time"][int(np.argmax(z))]),
        "ghost_geoms": None if viewer is None else viewer.ghost_geoms,
        "num_plans": summary["num_plans"],
        "shot": None if viewer is None else viewer.shot_stats,
    }
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
