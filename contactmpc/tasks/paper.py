"""The paper's own tasks: the authors' scenes, in their world frame, around their retargeted demonstrations.

A :class:`PaperTask` reads the authors' files from the directory ``paper_data`` names (their
``mjpc/tasks``; the config's top-level ``paper_data``, by default the environment variable
``CONTACTMPC_PAPER_DATA``). It builds the object body as their ``shared_task_templates/<object>_sim_body.xml``
does (visual mesh ``<object>.obj``, convex collision pieces ``contact<i>.stl`` or primitives, their
densities and ``condim``), with their table and floor, and mounts the hand where their
``hand_startclamp`` is (:attr:`~contactmpc.tasks.base.Task.hand_mount`): at frame 0 of their hand curves
the wrist slides are ~0. Its demonstration is
:class:`~contactmpc.reference.paper.demonstration.PaperDemonstration` (the importer), its ``time_scale``
their slowdown. Coordinates are theirs, so a record can be checked against their files.

What differs from their scene: our :class:`~contactmpc.hands.AllegroPaperHand` (their kinematics, our
collision primitives and wrist servos) and our scene options (the scene's integrator, cone and time
steps; they use MuJoCo's defaults).
"""

from __future__ import annotations

from typing import ClassVar

import mujoco
import numpy as np

from contactmpc.hands.allegro_paper import AllegroPaperHand
from contactmpc.reference.data import ReferenceError
from contactmpc.reference.paper.importer import PaperFiles, start_configuration
from contactmpc.tasks.base import Task, quat_angle

__all__ = ["PaperTask"]

# The joint order of the paper hand (wrist, then ff, mf, rf, th joints 0-3), in which a paper task states
# its hand_home.
JOINT_NAMES = AllegroPaperHand.WRIST_JOINTS + AllegroPaperHand.FINGER_JOINTS


class PaperTask(Task):
    """Base class of the four paper tasks.

    Subclasses set the authors' names (``demo``, ``object_name``), ``slowdown`` (``allegro.h``),
    ``hand_mount`` (their ``hand_startclamp``), the object joints and bodies, and implement
    :meth:`add_objects`, :meth:`object_configuration` and :meth:`conditions`.

    Args:
        paper_data: the authors' ``mjpc/tasks`` directory (holds ``allegro/``, ``shared_assets/``,
            ``shared_spline_trajectories/``, ``shared_task_templates/``).
        hand_home: (22,) initial hand configuration; ``None``: frame 0 of their hand curves.
        time_scale: slow-down of the demonstration; ``None``: theirs (``slowdown``).
        **kwargs: see :class:`~contactmpc.tasks.base.Task`.

    Raises:
        ReferenceError: ``paper_data`` unset, missing, or without this task's files (one line that
            says how to get the data).
    """

    demo: ClassVar[str] = ""
    object_name: ClassVar[str] = ""
    slowdown: ClassVar[float] = 10.0
    LIFT: ClassVar[float] = 0.05  # m above its start for an object to count as lifted

    def __init__(
        self,
        paper_data: str | None = None,
        hand_home: list[float] | None = None,
        time_scale: float | None = None,
        **kwargs,
    ) -> None:
        try:
            self.files = PaperFiles.locate(paper_data, self.demo)
        except ReferenceError as err:
            raise ReferenceError(f"task {self.name!r}: {err}") from err
        self.paper_data = str(self.files.root)
        home, self.start_pos, self.start_quat = start_configuration(self.files, JOINT_NAMES, self.hand_mount)
        super().__init__(
            hand_home=home if hand_home is None else hand_home,
            time_scale=self.slowdown if time_scale is None else time_scale,
            **kwargs,
        )

    # --- scene -------------------------------------------------------------------------------
    def add_mesh(self, spec: mujoco.MjSpec, name: str, file: str) -> str:
        """Add ``shared_assets/<file>`` as mesh ``name``; returns the name."""
        spec.add_mesh(name=name, file=str(self.files.asset(file)))
        return name

    def add_visual(self, spec: mujoco.MjSpec, body: mujoco.MjsBody, rgba) -> None:
        """The object's visual mesh ``<object>.obj``: massless, no collisions, geom group 2."""
        mesh = self.add_mesh(spec, self.object_name, f"{self.object_name}/{self.object_name}.obj")
        body.add_geom(
            name=f"{self.object_name}_visual",
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=mesh,
            contype=0,
            conaffinity=0,
            group=2,
            mass=0.0,
            rgba=list(rgba),
        )

    def add_pieces(self, spec: mujoco.MjSpec, body: mujoco.MjsBody, names: tuple[str, ...], density: float):
        """The convex collision pieces ``contact<i>.stl`` (named ``<object>_<name>``), ``condim`` 4,
        geom group 3 (hidden in renders), friction 1 (their default)."""
        for i, piece in enumerate(names):
            mesh = self.add_mesh(spec, f"{self.object_name}_contact{i}", f"{self.object_name}/contact{i}.stl")
            body.add_geom(
                name=f"{self.object_name}_{piece}",
                type=mujoco.mjtGeom.mjGEOM_MESH,
                meshname=mesh,
                density=density,
                condim=4,
                group=3,
                friction=[1.0, 0.005, 0.0001],
            )

    @staticmethod
    def add_floor(spec: mujoco.MjSpec) -> None:
        """Their floor: a plane at z = -0.2 m."""
        spec.worldbody.add_geom(
            name="floor",
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            pos=[0, 0, -0.2],
            size=[3, 3, 0.05],
            material="floor_mat",
        )

    @staticmethod
    def add_box_table(spec: mujoco.MjSpec, center, half=0.5) -> None:
        """Their table: a box of half-size ``half`` centred at ``center`` (friction 1)."""
        spec.worldbody.add_geom(
            name="table",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=list(center),
            size=[half] * 3,
            rgba=[0.55, 0.55, 0.57, 1.0],
            friction=[1.0, 0.005, 0.0001],
        )

    def add_free_object(self, spec: mujoco.MjSpec, pieces: tuple[str, ...], density: float, rgba) -> None:
        """``<object>_sim`` with a free joint at frame 0 of the object curves, its visual mesh and its
        collision pieces."""
        body = spec.worldbody.add_body(
            name=self.object_bodies[0], pos=list(self.start_pos), quat=list(self.start_quat)
        )
        body.add_freejoint(name=self.object_joints[0].name)
        self.add_visual(spec, body, rgba)
        self.add_pieces(spec, body, pieces, density)

    # --- reference -----------------------------------------------------------------------------
    def object_configuration(self, pos: np.ndarray, quat: np.ndarray) -> np.ndarray:
        """(T, n_o) the object configuration of the object body's world pose ``pos`` (T, 3), ``quat``
        (T, 4): for a free body, the pose itself."""
        return np.concatenate([pos, quat], axis=1)

    # --- completion helpers ---------------------------------------------------------------------
    def rotation_from_start(self, qo: np.ndarray) -> np.ndarray:
        """(N,) angle (rad) between the free body's orientation and its first one."""
        q = self.layout.quaternion(qo)
        return quat_angle(q, q[:1])
