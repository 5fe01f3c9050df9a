r"""The phases of a demonstration (approach, reach, close, moves of the object, open, retreat), each a
motion over its progress ``s`` in [0, 1] with a minimum-jerk profile (:func:`min_jerk`) between the
object keyframes.

While the hand holds the object it *rides* with it: with :math:`T_b(q_o)` the pose of the grasp body
and :math:`G = T_b(q_o^*)^{-1} T_r^*` the grasp offset of the hand root (solved at :math:`q_o^*`),

.. math::  T_r(t) = T_b(q_o(t))\, G, \qquad q_\text{fingers}(t) = q_\text{fingers}^*

(:meth:`PhaseContext.ride`; with a :class:`~contactmpc.reference.synthetic.grasp.GraspSchedule`,
offset and fingers are interpolated between the grasps).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from contactmpc.reference.synthetic.grasp import GraspSchedule
from contactmpc.reference.synthetic.kinematics import Kinematics, Pose

if TYPE_CHECKING:
    from contactmpc.tasks.base import Task

__all__ = [
    "Approach",
    "Close",
    "Move",
    "Open",
    "Phase",
    "PhaseContext",
    "Reach",
    "Retreat",
    "min_jerk",
]


def min_jerk(s: np.ndarray | float) -> np.ndarray:
    r"""Minimum-jerk profile :math:`10 s^3 - 15 s^4 + 6 s^5` of ``s`` clipped to [0, 1] (zero velocity
    and acceleration at both ends)."""
    s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


@dataclass
class PhaseContext:
    """What a phase needs: the scene's kinematics, the grasp and the state where the phase starts."""

    kin: Kinematics
    task: Task
    body: int
    schedule: GraspSchedule
    home: np.ndarray  # (J,)
    preshape: np.ndarray  # (num_fingers,)
    approach_offset: np.ndarray  # (3,) in the grasp body's frame at the grasp
    object_qpos: np.ndarray  # at the start of the phase
    wrist: Pose  # root pose at the start of the phase
    fingers: np.ndarray  # at the start of the phase

    def body_pose(self, object_qpos: np.ndarray) -> Pose:
        self.kin.set(self.home, object_qpos)
        return self.kin.body_pose(self.body)

    def ride(self, object_qpos: np.ndarray) -> tuple[Pose, np.ndarray]:
        """Root pose and fingers of the hand holding the object at ``object_qpos``."""
        offset, fingers = self.schedule.at(object_qpos)
        return self.body_pose(object_qpos) * offset, fingers

    def pregrasp(self) -> Pose:
        grasp_wrist, _ = self.ride(self.schedule.first.object_qpos)
        body = self.body_pose(self.schedule.first.object_qpos)
        return grasp_wrist.translated(body.rot.apply(self.approach_offset))


@dataclass(frozen=True)
class Phase:
    """A span of the demonstration; subclasses define the motion over ``s`` in [0, 1].

    Attributes:
        name: label stored in the reference's ``meta["phases"]``.
        duration: seconds (rounded to whole frames).
    """

    name: str
    duration: float
    holding = False  # the hand holds (and moves with) the object throughout

    def sample(self, s: float, ctx: PhaseContext) -> tuple[Pose, np.ndarray, np.ndarray]:
        """Root pose, (num_fingers,) fingers and (n_o,) object configuration at progress ``s``."""
        raise NotImplementedError


@dataclass(frozen=True)
class Approach(Phase):
    """From the start (home) to the pre-grasp pose (grasp pose + approach offset), shaping the fingers."""

    name: str = "approach"
    duration: float = 1.5

    def sample(self, s, ctx):
        e = float(min_jerk(s))
        fingers = (1.0 - e) * ctx.fingers + e * ctx.preshape
        return ctx.wrist.interpolate(ctx.pregrasp(), e), fingers, ctx.object_qpos


@dataclass(frozen=True)
class Reach(Phase):
    """From the pre-grasp pose onto the grasp pose, fingers still open."""

    name: str = "reach"
    duration: float = 1.0

    def sample(self, s, ctx):
        e = float(min_jerk(s))
        grasp_wrist, _ = ctx.ride(ctx.object_qpos)
        return ctx.wrist.interpolate(grasp_wrist, e), ctx.fingers, ctx.object_qpos


@dataclass(frozen=True)
class Close(Phase):
    """Fingers from their current pose (the pre-shape) to the grasp along a straight joint-space
    path (the one :func:`solve_preshape` keeps collision-free), the wrist at the grasp pose."""

    name: str = "close"
    duration: float = 1.0

    def sample(self, s, ctx):
        wrist, target = ctx.ride(ctx.object_qpos)
        e = float(min_jerk(s))
        return wrist, (1.0 - e) * ctx.fingers + e * target, ctx.object_qpos


@dataclass(frozen=True)
class Move(Phase):
    """The hand holds the object while it moves (min-jerk) to ``object_qpos``; None holds it still."""

    name: str = "hold"
    duration: float = 1.0
    object_qpos: tuple[float, ...] | None = None
    holding = True

    def sample(self, s, ctx):
        target = ctx.object_qpos if self.object_qpos is None else np.asarray(self.object_qpos, float)
        qo = ctx.task.layout.interpolate(ctx.object_qpos, target, float(min_jerk(s)))
        wrist, fingers = ctx.ride(qo)
        return wrist, fingers, qo


@dataclass(frozen=True)
class Open(Phase):
    """Fingers back to the pre-shape, the wrist where the grasp left it (object still)."""

    name: str = "open"
    duration: float = 1.0

    def sample(self, s, ctx):
        e = float(min_jerk(s))
        return ctx.wrist, (1.0 - e) * ctx.fingers + e * ctx.preshape, ctx.object_qpos


@dataclass(frozen=True)
class Retreat(Phase):
    """The open hand backs off along the approach direction (in the grasp body's current frame)."""

    name: str = "retreat"
    duration: float = 1.0
    distance: float = 1.0  # multiple of the approach offset

    def sample(self, s, ctx):
        e = float(min_jerk(s))
        body = ctx.body_pose(ctx.object_qpos)
        offset = body.rot.apply(ctx.approach_offset) * self.distance
        return ctx.wrist.translated(e * offset), ctx.fingers, ctx.object_qpos
