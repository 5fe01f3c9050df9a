"""MuJoCo's passive viewer on a live plant (``job=online job.viewer=true``).

:meth:`LiveViewer.open` opens ``mujoco.viewer.launch_passive`` on the plant's own model and data, and
the plant thread calls :meth:`LiveViewer.sync` between physics steps, a few dozen times a wall second.
Each sync draws

* a translucent **ghost** of the reference hand and object at the current control time: the geoms of
  every moving body of a second ``MjData``, posed at the reference (the hand's frames interpolated, the
  object on the planner's grid), added to the viewer's user scene (``mjv_addGeoms``) in a see-through
  blue;
* a text **overlay** (``Handle.set_texts``): time, replan rate, plan age, the plan's cost terms,
  milestones reached;

and hands the viewer's mouse **perturbation** to the plant: in passive mode ``Handle.sync`` clears the
data's ``xfrc_applied`` and applies the spring force of a drag (``mjv_applyPerturbForce``) to the data it
was given, the plant's, which keeps it until the next sync. The planner's rollouts start from the
plant's ``mjSTATE_FULLPHYSICS`` state, which holds no applied forces: a drag reaches the planner only
through the motion it causes. Each drag is recorded (:attr:`LiveViewer.drags`): the body, its start and
end in control time, and the largest force applied.

Without a display (no ``DISPLAY``/``WAYLAND_DISPLAY``, or one GLFW cannot open), :meth:`LiveViewer.open`
says so in one line and returns ``None``: the run goes on headless. (MuJoCo's viewer would otherwise
end the process when GLFW fails to initialise.)
"""

from __future__ import annotations

import re
import sys
import threading
import warnings

import mujoco
import numpy as np

from contactmpc.control.track import ReferenceTrack
from contactmpc.scene import Scene

GHOST_RGBA = (0.35, 0.6, 1.0, 0.3)
"""Colour of the reference ghost (translucent blue)."""


def display_problem() -> str | None:
    """Why no window can be opened here, or ``None`` if GLFW can open one."""
    try:
        import glfw
    except ImportError as err:  # mujoco's viewer needs it too
        return f"glfw is not importable ({err})"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ok = glfw.init()
    if ok:
        glfw.terminate()
        return None
    if not caught:
        return "GLFW could not be initialised"
    # glfw's warning reads "(65550) b'X11: Failed to open display :1'": keep the description
    found = re.search(r"b['\"](.*)['\"]$", str(caught[-1].message))
    return found.group(1) if found else str(caught[-1].message)


def reference_pose(track: ReferenceTrack, t: float) -> tuple[np.ndarray, np.ndarray]:
    """The reference at control time ``t``: hand configuration (J,), linear between its frames, and the
    object configuration (n_o,) on the planner's grid."""
    times = track.hand_times
    i = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 1))
    j = min(i + 1, len(times) - 1)
    w = 0.0 if j == i else float(np.clip((t - times[i]) / (times[j] - times[i]), 0.0, 1.0))
    hand = (1.0 - w) * track.hand_qpos[i] + w * track.hand_qpos[j]
    return hand, track.object_qpos[track.index(t)]


class LiveViewer:
    """The passive viewer of a live plant, with the reference ghost, an overlay and recorded drags.

    Use :meth:`open`; the plant thread calls :meth:`sync`.

    Args:
        handle: the ``mujoco.viewer.Handle`` of ``launch_passive`` on the plant.
        scene: the scene (names, index, the task's camera view).
        track: the reference on the planner's grid (the ghost's pose).
        model: the plant model the viewer shows.
    """

    def __init__(
        self,
        handle,
        scene: Scene,
        track: ReferenceTrack,
        model: mujoco.MjModel,
        threads: tuple[threading.Thread, ...] = (),
    ) -> None:
        self.handle = handle
        self.threads = threads  # the viewer's own (joined on close, before the process may end)
        self.scene, self.track, self.model = scene, track, model
        self.ghost = mujoco.MjData(model)
        self.ghost_option = mujoco.MjvOption()
        self.no_perturb = mujoco.MjvPerturb()
        self.ghost_geoms = 0
        self.drags: list[dict] = []
        self._drag: dict | None = None
        self._time = 0.0  # control time of the last sync
        # Handle.set_texts waits (without the GIL) for the render thread to take the text, a frame or
        # more: a thread of its own posts it, so the plant never waits for a frame.
        self._lines: list[tuple[str, str]] | None = None
        self._posted = threading.Event()
        self._closing = False
        self._texts = threading.Thread(target=self._post_texts, name="viewer-overlay", daemon=True)
        self._texts.start()
        view = scene.task.view
        with handle.lock():
            handle.cam.lookat[:] = view["lookat"]
            handle.cam.distance = view["distance"]
            handle.cam.azimuth = view["azimuth"]
            handle.cam.elevation = view["elevation"]

    @classmethod
    def open(
        cls, scene: Scene, track: ReferenceTrack, model: mujoco.MjModel, data: mujoco.MjData
    ) -> LiveViewer | None:
        """Open the passive viewer on the plant ``model``/``data``, or say in one line (stderr) why not
        and return ``None``."""
        problem = display_problem()
        if problem is not None:
            print(f"contactmpc: no display ({problem}): running headless", file=sys.stderr)
            return None
        import mujoco.viewer

        before = set(threading.enumerate())
        try:
            handle = mujoco.viewer.launch_passive(model, data, show_left_ui=False, show_right_ui=False)
        except Exception as err:  # macOS without mjpython, ...
            print(f"contactmpc: no viewer ({err}): running headless", file=sys.stderr)
            return None
        threads = tuple(t for t in threading.enumerate() if t not in before)
        return cls(handle, scene, track, model, threads)

    def is_running(self) -> bool:
        """Whether the window is still open."""
        return self.handle.is_running()

    def sync(self, data: mujoco.MjData, t: float, lines: list[tuple[str, str]]) -> None:
        """Show the plant at control time ``t`` with the ghost and the overlay ``lines`` (label, value),
        and apply the viewer's perturbation to ``data``. Call between physics steps, from the thread
        that steps ``data``."""
        h = self.handle
        with h.lock():
            self._draw_ghost(t)
        self._lines = lines
        self._posted.set()
        h.sync()  # copies data for rendering; clears xfrc_applied and applies the drag to `data`
        self._note_drag(data, t)

    def _post_texts(self) -> None:
        """The overlay thread: hand the latest lines to the viewer, one set per frame at most."""
        while not self._closing:
            if not self._posted.wait(0.1):
                continue
            self._posted.clear()
            lines = self._lines
            if lines is None or self._closing or not self.handle.is_running():
                continue
            self.handle.set_texts(
                (
                    mujoco.mjtFontScale.mjFONTSCALE_150,
                    mujoco.mjtGridPos.mjGRID_TOPLEFT,
                    "\n".join(label for label, _ in lines),
                    "\n".join(value for _, value in lines),
                )
            )

    def _draw_ghost(self, t: float) -> None:
        scn, g, idx = self.handle.user_scn, self.ghost, self.scene.index
        hand, obj = reference_pose(self.track, t)
        g.qpos[idx.hand_qpos] = hand
        g.qpos[idx.object_qpos] = obj
        mujoco.mj_kinematics(self.model, g)
        scn.ngeom = 0
        mujoco.mjv_addGeoms(
            self.model, g, self.ghost_option, self.no_perturb, mujoco.mjtCatBit.mjCAT_DYNAMIC, scn
        )
        for i in range(scn.ngeom):
            scn.geoms[i].rgba[:] = GHOST_RGBA
        self.ghost_geoms = scn.ngeom

    def _note_drag(self, data: mujoco.MjData, t: float) -> None:
        self._time = t
        pert = self.handle.perturb
        active = int(pert.active) | int(pert.active2)
        body = int(pert.select)
        if self._drag is not None and (not active or body != self._drag["body_id"]):
            self._drag["end"] = t
            self._drag.pop("body_id")
            self._drag = None
        if active and body > 0:
            force = float(np.linalg.norm(data.xfrc_applied[body, :3]))
            if self._drag is None:
                name = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, body) or str(body)
                kind = "rotate" if active & int(mujoco.mjtPertBit.mjPERT_ROTATE) else "translate"
                self._drag = {"body": name, "body_id": body, "kind": kind, "start": t, "end": None}
                self._drag["max_force"] = force
                self.drags.append(self._drag)
            self._drag["max_force"] = max(self._drag["max_force"], force)

    def close(self) -> None:
        """Close the window; a drag still on ends now."""
        if self._drag is not None:
            self._drag["end"] = self._time
            self._drag.pop("body_id")
            self._drag = None
        self._closing = True
        self._texts.join(timeout=1.0)
        self.handle.close()
        for thread in self.threads:  # a process that ends while the window closes may crash
            thread.join(timeout=2.0)
