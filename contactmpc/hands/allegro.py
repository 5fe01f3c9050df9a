"""Allegro right hand on the floating 6-DOF wrist, built from primitives with ``mujoco.MjSpec``.

Kinematics, joint limits and collision primitives follow the MuJoCo Menagerie model ``wonik_allegro``
(right hand). No mesh files are used: the collision primitives double as coloured visuals.

The ``palm`` body is the wrist root's child (see :class:`~contactmpc.hands.base.FloatingHand`),
rotated by quat (0, 1, 0, 1)/sqrt(2); the four fingers hang from the palm. Every joint has a position
actuator of the same name. The kinematic table (finger tree, palm placement and geom) is a set of class
attributes, so a subclass with another table builds another Allegro hand
(:class:`~contactmpc.hands.allegro_paper.AllegroPaperHand`).

Example:
    >>> spec = mujoco.MjSpec()
    >>> hand = AllegroHand()
    >>> hand.add_to(spec, root_pos=(0.0, 0.0, 0.3))
    >>> model = spec.compile()
    >>> hand.num_joints, hand.num_root, len(hand.link_names)
    (22, 6, 21)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

import mujoco
import numpy as np

from contactmpc.hands.base import FloatingHand
from contactmpc.validate import Ge, Gt, checked

__all__ = ["AllegroHand"]

_DARK = (0.2, 0.2, 0.2, 1.0)
_PALM = (0.27, 0.27, 0.27, 1.0)
_TIP = (0.9, 0.9, 0.9, 1.0)


@dataclass(frozen=True)
class _Geom:
    """A collision primitive in its body's frame.

    Attributes:
        type: ``"box"`` (size = 3 half-sizes) or ``"capsule"`` (size = radius, half-length along z).
        size: Geom size as MuJoCo reads it.
        pos: (3,) position in the body frame.
        mass: Mass in kg (inertia follows from the shape, uniform density).
    """

    type: str
    size: tuple[float, ...]
    pos: tuple[float, float, float]
    mass: float


@dataclass(frozen=True)
class _Link:
    """One body of the finger tree (the palm is built separately).

    Attributes:
        name: Body name.
        parent: Parent body name.
        pos: (3,) position in the parent frame.
        quat: (4,) orientation in the parent frame, scalar first (w, x, y, z).
        joint: Joint name, or ``None`` for a body welded to its parent.
        axis: (3,) joint axis in the body frame.
        range: Joint limits (rad).
        geom: Collision primitive.
    """

    name: str
    parent: str
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float]
    joint: str | None
    axis: tuple[float, float, float]
    range: tuple[float, float]
    geom: _Geom


_IDQ = (1.0, 0.0, 0.0, 0.0)
_Y = (0.0, 1.0, 0.0)
_Z = (0.0, 0.0, 1.0)

# Masses (kg) of the real hand's links (Wonik Robotics' Allegro URDF); the palm is 0.4154 kg.
_PALM_GEOM = _Geom("box", (0.0204, 0.0565, 0.0475), (-0.0093, 0.0, -0.0475), 0.4154)
_BASE_GEOM = _Geom("box", (0.0098, 0.01375, 0.0082), (0.0, 0.0, 0.0082), 0.0119)
_PROX_GEOM = _Geom("box", (0.0098, 0.01375, 0.027), (0.0, 0.0, 0.027), 0.065)
_MED_GEOM = _Geom("box", (0.0098, 0.01375, 0.0192), (0.0, 0.0, 0.0192), 0.0355)
_DIST_GEOM = _Geom("box", (0.0098, 0.01375, 0.008), (0.0, 0.0, 0.008), 0.0096)
_TIP_GEOM = _Geom("capsule", (0.012, 0.01), (0.0, 0.0, 0.019), 0.0168)
_TH_BASE_GEOM = _Geom("box", (0.0179, 0.017, 0.02275), (-0.0179, 0.009, 0.0145), 0.0176)
_TH_PROX_GEOM = _Geom("box", (0.0098, 0.01375, 0.00885), (0.0, 0.0, 0.00885), 0.0119)
_TH_MED_GEOM = _Geom("box", (0.0098, 0.01375, 0.0257), (0.0, 0.0, 0.0257), 0.038)
_TH_DIST_GEOM = _Geom("box", (0.0098, 0.01375, 0.0157), (0.0, 0.0, 0.0157), 0.0388)
_TH_TIP_GEOM = _Geom("capsule", (0.012, 0.008), (0.0, 0.0, 0.035), 0.0168)


def _finger(
    prefix: str,
    pos: tuple,
    quat: tuple,
    distal_quat: tuple = _IDQ,
    tip_offset: float = 0.0,
    tip_geom: _Geom = _TIP_GEOM,
) -> list[_Link]:
    """The five bodies of one long finger (ff, mf or rf), parent first: base at ``pos``/``quat`` on the
    palm, the distal link turned by ``distal_quat``, the tip body ``tip_offset`` beyond the distal
    joint carrying ``tip_geom``."""
    return [
        _Link(f"{prefix}_base", "palm", pos, quat, f"{prefix}j0", _Z, (-0.47, 0.47), _BASE_GEOM),
        _Link(f"{prefix}_proximal", f"{prefix}_base", (0, 0, 0.0164), _IDQ, f"{prefix}j1", _Y,
              (-0.196, 1.61), _PROX_GEOM),
        _Link(f"{prefix}_medial", f"{prefix}_proximal", (0, 0, 0.054), _IDQ, f"{prefix}j2", _Y,
              (-0.174, 1.709), _MED_GEOM),
        _Link(f"{prefix}_distal", f"{prefix}_medial", (0, 0, 0.0384), distal_quat, f"{prefix}j3", _Y,
              (-0.227, 1.618), _DIST_GEOM),
        _Link(f"{prefix}_tip", f"{prefix}_distal", (0, 0, tip_offset), _IDQ, None, _Z, (0, 0), tip_geom),
    ]  # fmt: skip


_FINGER_TREE: tuple[_Link, ...] = (
    *_finger("ff", (0.0, 0.0435, -0.001542), (0.999048, -0.0436194, 0.0, 0.0)),
    *_finger("mf", (0.0, 0.0, 0.0007), _IDQ),
    *_finger("rf", (0.0, -0.0435, -0.001542), (0.999048, 0.0436194, 0.0, 0.0)),
    _Link("th_base", "palm", (-0.0182, 0.019333, -0.045987), (0.477714, -0.521334, -0.521334, -0.477714),
          "thj0", (-1.0, 0.0, 0.0), (0.263, 1.396), _TH_BASE_GEOM),
    _Link("th_proximal", "th_base", (-0.027, 0.005, 0.0399), _IDQ, "thj1", _Z, (-0.105, 1.163),
          _TH_PROX_GEOM),
    _Link("th_medial", "th_proximal", (0, 0, 0.0177), _IDQ, "thj2", _Y, (-0.189, 1.644), _TH_MED_GEOM),
    _Link("th_distal", "th_medial", (0, 0, 0.0514), _IDQ, "thj3", _Y, (-0.162, 1.719), _TH_DIST_GEOM),
    _Link("th_tip", "th_distal", (0, 0, 0), _IDQ, None, _Z, (0, 0), _TH_TIP_GEOM),
)  # fmt: skip

_GEOM_TYPES = {"box": mujoco.mjtGeom.mjGEOM_BOX, "capsule": mujoco.mjtGeom.mjGEOM_CAPSULE}


class AllegroHand(FloatingHand):
    """Allegro right hand (16 finger DOFs) on the floating 6-DOF wrist of :class:`FloatingHand`.

    Finger joints carry damping, armature and force-limited position actuators (``kp`` only, the
    damping lives in the joint).

    Args:
        kp_finger: position gain of the finger actuators (N·m/rad).
        damping_finger: finger joint damping (N·m·s/rad).
        armature_finger: finger joint armature (kg·m²).
        force_limit_finger: finger actuator force limit (N·m), symmetric.
        name: identifier of this hand (for records); body, joint and actuator names are fixed.
        **kwargs: the wrist, see :class:`~contactmpc.hands.base.FloatingHand`.
    """

    FINGER_JOINTS: tuple[str, ...] = tuple(f"{f}j{i}" for f in ("ff", "mf", "rf", "th") for i in range(4))
    LINKS: tuple[str, ...] = (
        "palm",
        *(
            f"{f}_{p}"
            for f in ("ff", "mf", "rf", "th")
            for p in ("base", "proximal", "medial", "distal", "tip")
        ),
    )
    FINGERTIPS: tuple[str, ...] = ("ff_tip", "mf_tip", "rf_tip", "th_tip")
    # Flexion joints: 1-3 of each long finger, 2-3 of the thumb.
    FLEXION: tuple[str, ...] = tuple(f"{f}j{i}" for f in ("ff", "mf", "rf") for i in (1, 2, 3)) + (
        "thj2",
        "thj3",
    )
    # The kinematic table: the finger tree (parent before child), the palm's pose under the wrist root
    # (quaternion normalised at build time) and its collision geom.
    TREE: tuple[_Link, ...] = _FINGER_TREE
    PALM_POS: tuple[float, float, float] = (0.0, 0.0, 0.0)
    PALM_QUAT: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 1.0)
    PALM_GEOM: _Geom = _PALM_GEOM

    @checked
    def __init__(
        self,
        kp_finger: Annotated[float, Ge(0)] = 10.0,
        damping_finger: Annotated[float, Ge(0)] = 1.0,
        armature_finger: Annotated[float, Ge(0)] = 0.01,
        force_limit_finger: Annotated[float, Gt(0)] = 0.7,
        name: str = "allegro_right",
        **kwargs,
    ) -> None:
        super().__init__(name=name, **kwargs)
        self.kp_finger = float(kp_finger)
        self.damping_finger = float(damping_finger)
        self.armature_finger = float(armature_finger)
        self.force_limit_finger = float(force_limit_finger)

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}(name={self.name!r}, kp_finger={self.kp_finger}, "
            f"kp_slide={self.kp_slide}, kp_hinge={self.kp_hinge}, gravcomp={self.gravcomp})"
        )

    # ------------------------------------------------------------------ names and limits
    def finger_range(self, joint: str) -> tuple[float, float]:
        return {link.joint: link.range for link in self.TREE if link.joint is not None}[joint]

    # ------------------------------------------------------------------ building
    def add_fingers(
        self, spec: mujoco.MjSpec, root: mujoco.MjsBody, hinge_unit: float
    ) -> dict[str, mujoco.MjsBody]:
        palm_quat = np.asarray(self.PALM_QUAT, dtype=float)
        bodies = {
            "palm": root.add_body(
                name="palm", pos=list(self.PALM_POS), quat=(palm_quat / np.linalg.norm(palm_quat)).tolist()
            )
        }
        self._add_geom(bodies["palm"], "palm", self.PALM_GEOM, _PALM)
        for link in self.TREE:
            quat = np.asarray(link.quat, dtype=float)
            body = bodies[link.parent].add_body(
                name=link.name, pos=list(link.pos), quat=(quat / np.linalg.norm(quat)).tolist()
            )
            bodies[link.name] = body
            self._add_geom(body, link.name, link.geom, _TIP if link.name.endswith("_tip") else _DARK)
            if link.joint is not None:
                self._add_finger_joint(spec, body, link, hinge_unit)
        return bodies

    def add_excludes(self, spec: mujoco.MjSpec) -> None:
        for other in ("ff_base", "mf_base", "rf_base", "th_base", "th_proximal"):
            spec.add_exclude(bodyname1="palm", bodyname2=other)

    def _add_finger_joint(
        self, spec: mujoco.MjSpec, body: mujoco.MjsBody, link: _Link, hinge_unit: float
    ) -> None:
        """One finger hinge on ``body`` with its force-limited position actuator."""
        body.add_joint(
            name=link.joint,
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=list(link.axis),
            range=[hinge_unit * v for v in link.range],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            damping=self.damping_finger,
            armature=self.armature_finger,
        )
        self.add_position_actuator(spec, link.joint, self.kp_finger, link.range, self.force_limit_finger)

    @staticmethod
    def _add_geom(body: mujoco.MjsBody, link: str, geom: _Geom, rgba: tuple) -> None:
        """Collision geom ``f"{link}_col"`` (also the visual) colliding with everything."""
        body.add_geom(
            name=f"{link}_col",
            type=_GEOM_TYPES[geom.type],
            size=list(geom.size) + [0.0] * (3 - len(geom.size)),
            pos=list(geom.pos),
            mass=geom.mass,
            rgba=list(rgba),
            contype=1,
            conaffinity=1,
        )
