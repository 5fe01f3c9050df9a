"""The hand interface, and the floating 6-DOF wrist every hand of this project is mounted on.

A :class:`Hand` is a ``mujoco.MjSpec`` piece plus the names the rest of the library needs: its joints
(root DOFs first, then the finger joints: the column order of every hand configuration, reference
and control target), its contact links (bodies whose contacts a reference summarises), its actuators
(one position servo per joint, named like it), and the joint ranges. Nothing outside ``hands/`` knows
how many joints a hand has: sizes come from :attr:`Hand.num_joints`, :attr:`Hand.num_root` and
:attr:`Hand.num_fingers`. Ids and array addresses are resolved from these names once, by
:class:`contactmpc.scene.SceneIndex`.

:class:`FloatingHand` implements the wrist shared by every hand here: a body ``hand_root`` carrying
six joints, in this order::

    wrist_x, wrist_y, wrist_z      slide joints along world x, y, z
    wrist_rx, wrist_ry, wrist_rz   hinge joints about x, y, z

All six act on the same body, so the root pose is ``p = root_pos + (x, y, z)`` and
``R = Rx(rx) @ Ry(ry) @ Rz(rz)``. A subclass adds its fingers under ``hand_root``
(:meth:`FloatingHand.add_fingers`) and names them; every body it returns gets gravity compensation
and each contact link a world position/orientation sensor pair ``<link>_pos`` / ``<link>_quat``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Annotated

import mujoco
import numpy as np

from contactmpc.validate import ConfigError, Ge, checked

__all__ = ["FloatingHand", "Hand"]


class Hand(ABC):
    """What the library needs to know of a hand.

    Attributes:
        name: identifier of the hand (for records).
        root_body: the body the hand hangs from (the wrist's moving body).
    """

    name: str
    root_body: str

    @property
    @abstractmethod
    def root_joints(self) -> tuple[str, ...]:
        """(num_root,) names of the root (wrist) joints, first in the joint order."""

    @property
    @abstractmethod
    def finger_joints(self) -> tuple[str, ...]:
        """(num_fingers,) names of the finger joints, after the root joints."""

    @property
    @abstractmethod
    def link_names(self) -> tuple[str, ...]:
        """(L,) names of the contact links (bodies), palm first."""

    @property
    @abstractmethod
    def joint_ranges(self) -> np.ndarray:
        """(num_joints, 2) joint limits ``[low, high]`` in :attr:`joint_names` order (m or rad)."""

    @property
    def flexion_joints(self) -> tuple[str, ...]:
        """Finger joints that close the hand (a synthesised pre-shape opens them); default none."""
        return ()

    @abstractmethod
    def add_to(self, spec: mujoco.MjSpec, root_pos: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        """Add the hand (bodies, joints, actuators, link sensors) to ``spec``.

        Args:
            spec: spec to extend; the hand hangs from ``spec.worldbody``.
            root_pos: (3,) world position of :attr:`root_body` at zero root joints.
        """

    # ---------------------------------------------------------------- derived names and sizes
    @property
    def joint_names(self) -> tuple[str, ...]:
        """(num_joints,) root joints then finger joints: the hand's joint order everywhere."""
        return self.root_joints + self.finger_joints

    @property
    def actuator_names(self) -> tuple[str, ...]:
        """(num_joints,) actuator names, one position servo per joint, named like it."""
        return self.joint_names

    @property
    def link_geoms(self) -> tuple[str, ...]:
        """(L,) the collision geom of each contact link, ``<link>_col``."""
        return tuple(f"{link}_col" for link in self.link_names)

    @property
    def num_root(self) -> int:
        """Number of root (wrist) DOFs."""
        return len(self.root_joints)

    @property
    def num_fingers(self) -> int:
        """Number of finger joints."""
        return len(self.finger_joints)

    @property
    def num_joints(self) -> int:
        """Number of hand joints (root + fingers)."""
        return len(self.joint_names)

    @property
    def finger_ranges(self) -> np.ndarray:
        """(num_fingers, 2) finger joint limits."""
        return self.joint_ranges[self.num_root :]


class FloatingHand(Hand):
    """A hand on a floating 6-DOF wrist: three slides and three hinges on ``hand_root``.

    Wrist joints carry position actuators whose damping is joint damping, which the Euler/implicit
    integrators treat implicitly (stable at the 10 ms planning step).

    Args:
        kp_slide: position gain of the wrist slide actuators (N/m).
        damping_slide: wrist slide joint damping (N·s/m).
        kp_hinge: position gain of the wrist hinge actuators (N·m/rad).
        damping_hinge: wrist hinge joint damping (N·m·s/rad).
        armature_wrist: armature of the six wrist joints (kg for slides, kg·m² for hinges).
        slide_range: limits of the wrist slides (m), relative to ``root_pos``.
        hinge_range: limits of the wrist hinges (rad); wider than +-pi so that palm-down poses
            (rx = pi) lie inside the range.
        gravcomp: compensate gravity on every hand body.
        name: identifier of this hand (for records); body, joint and actuator names are fixed.
    """

    root_body = "hand_root"
    WRIST_JOINTS: tuple[str, ...] = ("wrist_x", "wrist_y", "wrist_z", "wrist_rx", "wrist_ry", "wrist_rz")
    # A subclass names its finger joints, its contact links (palm first) and the finger joints that
    # close the hand (a synthesised pre-shape opens them).
    FINGER_JOINTS: tuple[str, ...] = ()
    LINKS: tuple[str, ...] = ()
    FLEXION: tuple[str, ...] = ()

    @checked
    def __init__(
        self,
        kp_slide: Annotated[float, Ge(0)] = 600.0,
        damping_slide: Annotated[float, Ge(0)] = 60.0,
        kp_hinge: Annotated[float, Ge(0)] = 40.0,
        damping_hinge: Annotated[float, Ge(0)] = 3.0,
        armature_wrist: Annotated[float, Ge(0)] = 0.0,
        slide_range: tuple[float, float] = (-1.0, 1.0),
        hinge_range: tuple[float, float] = (-6.2832, 6.2832),
        gravcomp: bool = True,
        name: str = "hand",
    ) -> None:
        self.kp_slide = float(kp_slide)
        self.damping_slide = float(damping_slide)
        self.kp_hinge = float(kp_hinge)
        self.damping_hinge = float(damping_hinge)
        self.armature_wrist = float(armature_wrist)
        self.slide_range = (float(slide_range[0]), float(slide_range[1]))
        self.hinge_range = (float(hinge_range[0]), float(hinge_range[1]))
        self.gravcomp = bool(gravcomp)
        self.name = str(name)
        for label, (lo, hi) in (("slide_range", self.slide_range), ("hinge_range", self.hinge_range)):
            if not lo < hi:
                raise ConfigError(
                    f"{type(self).__name__}.{label} must be (low, high) with low < high, got {[lo, hi]}"
                )

    @property
    def root_joints(self) -> tuple[str, ...]:
        return self.WRIST_JOINTS

    @property
    def finger_joints(self) -> tuple[str, ...]:
        return self.FINGER_JOINTS

    @property
    def link_names(self) -> tuple[str, ...]:
        return self.LINKS

    @property
    def flexion_joints(self) -> tuple[str, ...]:
        return self.FLEXION

    @property
    def joint_ranges(self) -> np.ndarray:
        wrist = [self.slide_range] * 3 + [self.hinge_range] * 3
        return np.array(wrist + [self.finger_range(j) for j in self.finger_joints], dtype=float)

    @abstractmethod
    def finger_range(self, joint: str) -> tuple[float, float]:
        """Limits ``(low, high)`` of finger joint ``joint`` (rad or m)."""

    @abstractmethod
    def add_fingers(
        self, spec: mujoco.MjSpec, root: mujoco.MjsBody, hinge_unit: float
    ) -> dict[str, mujoco.MjsBody]:
        """Add the palm and fingers under ``root`` (bodies, geoms, joints with their actuators).

        Args:
            spec: the spec (for actuators and excludes).
            root: the wrist's moving body.
            hinge_unit: factor from radians to the spec's compile-time angle unit (1 or 180/pi).

        Returns:
            Every body added, by name (all of them get gravity compensation).
        """

    # ------------------------------------------------------------------ building
    def add_to(self, spec: mujoco.MjSpec, root_pos: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        """Add wrist, fingers, gravity compensation and link sensors to ``spec``.

        Raises:
            ValueError: if ``spec`` already has a body named like :attr:`root_body`.
        """
        if spec.body(self.root_body) is not None:
            raise ValueError(f"spec already has a body named {self.root_body!r}: add the hand only once")
        # A fresh MjSpec reads hinge ranges in degrees (compiler.degree=True); respect the caller's
        # setting instead of changing it. Actuator ctrlrange is never converted.
        hinge_unit = float(np.degrees(1.0)) if spec.compiler.degree else 1.0
        root = spec.worldbody.add_body(name=self.root_body, pos=[float(v) for v in root_pos])
        self._add_wrist(spec, root, hinge_unit)
        bodies = self.add_fingers(spec, root, hinge_unit)
        if self.gravcomp:
            root.gravcomp = 1.0
            for body in bodies.values():
                body.gravcomp = 1.0
        self.add_excludes(spec)
        for link in self.link_names:
            for suffix, kind in (
                ("pos", mujoco.mjtSensor.mjSENS_FRAMEPOS),
                ("quat", mujoco.mjtSensor.mjSENS_FRAMEQUAT),
            ):
                spec.add_sensor(
                    name=f"{link}_{suffix}", type=kind, objtype=mujoco.mjtObj.mjOBJ_XBODY, objname=link
                )

    def add_excludes(self, spec: mujoco.MjSpec) -> None:
        """Contact excludes between hand bodies (none by default)."""

    def _add_wrist(self, spec: mujoco.MjSpec, root: mujoco.MjsBody, hinge_unit: float) -> None:
        """Six wrist joints on ``root`` (slides x, y, z then hinges x, y, z) with position actuators."""
        axes = np.eye(3)
        for k, jname in enumerate(self.WRIST_JOINTS):
            is_slide = k < 3
            rng = self.slide_range if is_slide else self.hinge_range
            unit = 1.0 if is_slide else hinge_unit
            root.add_joint(
                name=jname,
                type=mujoco.mjtJoint.mjJNT_SLIDE if is_slide else mujoco.mjtJoint.mjJNT_HINGE,
                axis=axes[k % 3].tolist(),
                range=[unit * v for v in rng],
                limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                damping=self.damping_slide if is_slide else self.damping_hinge,
                armature=self.armature_wrist,
            )
            self.add_position_actuator(
                spec, jname, self.kp_slide if is_slide else self.kp_hinge, rng, force_limit=None
            )

    @staticmethod
    def add_position_actuator(
        spec: mujoco.MjSpec, joint: str, kp: float, ctrlrange: tuple[float, float], force_limit: float | None
    ) -> None:
        """Position servo ``force = kp * (ctrl - q)`` on ``joint``, named like it (damping: the joint's)."""
        act = spec.add_actuator(name=joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=kp, kv=0.0)
        act.ctrlrange = list(ctrlrange)
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        if force_limit is not None:
            act.forcerange = [-force_limit, force_limit]
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        else:
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE
