"""Task base class: the fixtures and objects of one manipulation task, and its object configuration.

A task adds its table/fixtures and its object bodies to a ``mujoco.MjSpec``
(:class:`~contactmpc.tasks.fixtures.TaskScene`), declares the joints of its object configuration ``q_o``
(:class:`~contactmpc.tasks.layout.ObjectLayout`) and the conditions its trials are scored on
(:class:`~contactmpc.tasks.completion.TaskCompletion`). The names those modules define are importable
from here as well.
"""

from __future__ import annotations

from functools import cached_property
from typing import Annotated

import mujoco
import numpy as np

from contactmpc.tasks.completion import TaskCompletion, sustained, sustained_to_end
from contactmpc.tasks.fixtures import TaskScene
from contactmpc.tasks.layout import DOF_WIDTH, JOINT_WIDTH, ObjectError, ObjectJoint, ObjectLayout, quat_angle
from contactmpc.validate import Gt, checked

__all__ = [
    "DOF_WIDTH",
    "JOINT_WIDTH",
    "ObjectError",
    "ObjectJoint",
    "ObjectLayout",
    "Task",
    "TaskCompletion",
    "TaskScene",
    "quat_angle",
    "sustained",
    "sustained_to_end",
]


class Task(TaskScene, TaskCompletion):
    """Base class of a manipulation task.

    Subclasses set ``name``, ``object_joints`` (the ``q_o`` layout), ``object_bodies`` (bodies that get
    frame sensors; contact points are expressed in one of them) and implement :meth:`add_objects`.

    Args:
        hand_home: (num_joints,) initial hand configuration in the hand's joint order (for the
            Allegro hand: wrist x y z rx ry rz, then 16 finger joints); the scene checks its length.
        time_scale: slow-down factor applied to the demonstration before control (paper: 5-10).
        reference_path: optional user-supplied reference ``.npz``; ``None`` synthesises one.
        demonstration: the design of the task's synthetic demonstration (e.g.
            :class:`contactmpc.reference.synthetic.designs.AppleDemo`), used when ``reference_path``
            is ``None``.
    """

    name: str = "task"
    object_joints: tuple[ObjectJoint, ...] = ()
    object_bodies: tuple[str, ...] = ()
    table_height: float = 0.0
    # World position of the wrist's zero (the scene adds its ``hand_root`` to it): where the task mounts
    # the hand, e.g. the paper tasks' ``hand_startclamp``.
    hand_mount: tuple[float, float, float] = (0.0, 0.0, 0.0)
    # Default free camera for renders: see contactmpc.render.make_camera.
    view: dict = {"lookat": (0.0, 0.0, 0.06), "distance": 0.75, "azimuth": 135.0, "elevation": -25.0}

    @checked
    def __init__(
        self,
        hand_home: list[float] | np.ndarray,
        time_scale: Annotated[float, Gt(0)] = 5.0,
        reference_path: str | None = None,
        demonstration: object | None = None,
    ) -> None:
        self.hand_home = np.asarray(hand_home, dtype=float)
        if self.hand_home.ndim != 1:
            raise ValueError(
                f"task {self.name}: hand_home must be a flat list, got shape {self.hand_home.shape}"
            )
        self.time_scale = float(time_scale)
        self.reference_path = reference_path
        self.demonstration = demonstration

    @cached_property
    def layout(self) -> ObjectLayout:
        """The columns of ``q_o``."""
        return ObjectLayout(self.object_joints)

    def start_object_qpos(self, reference_qo: np.ndarray) -> np.ndarray:
        """(n_o,) where a trial puts the object at t = 0, given the reference's first configuration
        ``reference_qo`` (n_o,); the reference's own, unless a task moves it (the paper's apple)."""
        return np.array(reference_qo, dtype=float, copy=True)

    def initial_object_qpos(self, model: mujoco.MjModel) -> np.ndarray:
        """(n_o,) the object configuration of the model's default pose (``qpos0``)."""
        return model.qpos0[self.layout.qpos_indices(model)].copy()
