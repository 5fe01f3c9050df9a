"""Allegro right hand on a floating 6-DOF wrist, built from primitives with ``mujoco.MjSpec``.

Kinematics, joint limits and collision primitives follow the MuJoCo Menagerie model ``wonik_allegro``
(right hand). No mesh files are used: the collision primitives double as coloured visuals.

The hand hangs from a body ``hand_root`` that carries six joints, in this order::

    wrist_x, wrist_y, wrist_z      slide joints along world x, y, z
    wrist_rx, wrist_ry, wrist_rz   hinge joints about x, y, z

All six act on the same body, so the root pose is ``p = root_pos + (x, y, z)`` and
``R = Rx(rx) @ Ry(ry) @ Rz(rz)`` (each hinge turns about its axis in the frame left by the previous
ones). The ``palm`` body is the root's child, rotated by quat (0, 1, 0, 1)/sqrt(2); the four fingers
hang from the palm. Every joint has a position actuator of the same name.

Example:
    >>> spec = mujoco.MjSpec()
    >>> hand = AllegroHand()
    >>> hand.add_to(spec, root_pos=(0.0, 0.0, 0.3))
    >>> model = spec.compile()
    >>> qadr = hand.qpos_adr(model)  # (22,) addresses into qpos, in AllegroHand.JOINTS order
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

__all__ = ["AllegroHand", "name2ids"]

_DARK = (0.2, 0.2, 0.2, 1.0)
_PALM = (0.27, 0.27, 0.27, 1.0)
_TIP = (0.9, 0.9, 0.9, 1.0)

_PALM_QUAT = (0.0, 1.0, 0.0, 1.0)  # normalised at build time


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


def _finger(prefix: str, pos: tuple, quat: tuple) -> list[_Link]:
    """The five bodies of one long finger (ff, mf or rf), parent first."""
    return [
        _Link(f"{prefix}_base", "palm", pos, quat, f"{prefix}j0", _Z, (-0.47, 0.47), _BASE_GEOM),
        _Link(f"{prefix}_proximal", f"{prefix}_base", (0, 0, 0.0164), _IDQ, f"{prefix}j1", _Y,
              (-0.196, 1.61), _PROX_GEOM),
        _Link(f"{prefix}_medial", f"{prefix}_proximal", (0, 0, 0.054), _IDQ, f"{prefix}j2", _Y,
              (-0.174, 1.709), _MED_GEOM),
        _Link(f"{prefix}_distal", f"{prefix}_medial", (0, 0, 0.0384), _IDQ, f"{prefix}j3", _Y,
              (-0.227, 1.618), _DIST_GEOM),
        _Link(f"{prefix}_tip", f"{prefix}_distal", (0, 0, 0), _IDQ, None, _Z, (0, 0), _TIP_GEOM),
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


def name2ids(model: mujoco.MjModel, objtype: mujoco.mjtObj, names: Sequence[str]) -> np.ndarray:
    """Resolve MuJoCo names to ids, failing loudly on any name the model lacks.

    Args:
        model: Compiled model.
        objtype: Object type, e.g. ``mujoco.mjtObj.mjOBJ_BODY``.
        names: (n,) names to resolve.

    Returns:
        (n,) int array of ids, in the order of ``names``.

    Raises:
        ValueError: Naming every missing object.
    """
    ids = np.array([mujoco.mj_name2id(model, objtype, n) for n in names], dtype=int)
    missing = [n for n, i in zip(names, ids, strict=True) if i < 0]
    if missing:
        kind = mujoco.mjtObj(objtype).name.removeprefix("mjOBJ_").lower()
        raise ValueError(f"model has no {kind} named {missing}")
    return ids


class AllegroHand:
    """Allegro right hand (16 finger DOFs) on a 6-DOF floating wrist, as a ``mujoco.MjSpec`` piece.

    Finger joints carry damping, armature and force-limited position actuators (``kp`` only, the
    damping lives in the joint). Wrist joints carry position actuators whose damping is joint damping,
    which the Euler/implicit integrators treat implicitly (stable at the 10 ms planning step).

    Args:
        kp_finger: Position gain of the finger actuators (N·m/rad).
        damping_finger: Finger joint damping (N·m·s/rad).
        armature_finger: Finger joint armature (kg·m²).
        force_limit_finger: Finger actuator force limit (N·m), symmetric.
        kp_slide: Position gain of the wrist slide actuators (N/m).
        damping_slide: Wrist slide joint damping (N·s/m).
        kp_hinge: Position gain of the wrist hinge actuators (N·m/rad).
        damping_hinge: Wrist hinge joint damping (N·m·s/rad).
        armature_wrist: Armature of the six wrist joints (kg for slides, kg·m² for hinges).
        slide_range: Limits of the wrist slides (m), relative to ``root_pos``.
        hinge_range: Limits of the wrist hinges (rad); wider than +-pi so that palm-down poses
            (rx = pi) lie inside the range.
        gravcomp: Compensate gravity on every hand body.
        name: Identifier of this hand (for records); body, joint and actuator names are fixed.
    """

    WRIST_JOINTS: tuple[str, ...] = ("wrist_x", "wrist_y", "wrist_z", "wrist_rx", "wrist_ry", "wrist_rz")
    FINGER_JOINTS: tuple[str, ...] = tuple(f"{f}j{i}" for f in ("ff", "mf", "rf", "th") for i in range(4))
    JOINTS: tuple[str, ...] = WRIST_JOINTS + FINGER_JOINTS
    LINKS: tuple[str, ...] = (
        "palm",
        *(
            f"{f}_{p}"
            for f in ("ff", "mf", "rf", "th")
            for p in ("base", "proximal", "medial", "distal", "tip")
        ),
    )
    ACTUATORS: tuple[str, ...] = JOINTS
    FINGERTIPS: tuple[str, ...] = ("ff_tip", "mf_tip", "rf_tip", "th_tip")
    ROOT_BODY: str = "hand_root"

    def __init__(
        self,
        kp_finger: float = 10.0,
        damping_finger: float = 1.0,
        armature_finger: float = 0.01,
        force_limit_finger: float = 0.7,
        kp_slide: float = 600.0,
        damping_slide: float = 60.0,
        kp_hinge: float = 40.0,
        damping_hinge: float = 3.0,
        armature_wrist: float = 0.0,
        slide_range: tuple[float, float] = (-1.0, 1.0),
        hinge_range: tuple[float, float] = (-6.2832, 6.2832),
        gravcomp: bool = True,
        name: str = "allegro_right",
    ) -> None:
        self.kp_finger = float(kp_finger)
        self.damping_finger = float(damping_finger)
        self.armature_finger = float(armature_finger)
        self.force_limit_finger = float(force_limit_finger)
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
                raise ValueError(f"{label} must be (low, high) with low < high, got {(lo, hi)}")
        if self.force_limit_finger <= 0:
            raise ValueError(f"force_limit_finger must be > 0, got {self.force_limit_finger}")

    def __repr__(self) -> str:
        return (
            f"AllegroHand(name={self.name!r}, kp_finger={self.kp_finger}, kp_slide={self.kp_slide}, "
            f"kp_hinge={self.kp_hinge}, gravcomp={self.gravcomp})"
        )

    # ------------------------------------------------------------------ names and limits
    @property
    def joint_names(self) -> tuple[str, ...]:
        """(22,) joint names: wrist 6 then fingers 16 (the hand's joint order everywhere)."""
        return self.JOINTS

    @property
    def link_names(self) -> tuple[str, ...]:
        """(21,) contact link (body) names."""
        return self.LINKS

    @property
    def actuator_names(self) -> tuple[str, ...]:
        """(22,) actuator names, one per joint, named like it."""
        return self.ACTUATORS

    @property
    def joint_ranges(self) -> np.ndarray:
        """(22, 2) joint limits [low, high] in JOINTS order (m for slides, rad for hinges)."""
        wrist = [self.slide_range] * 3 + [self.hinge_range] * 3
        fingers = {link.joint: link.range for link in _FINGER_TREE if link.joint is not None}
        return np.array(wrist + [fingers[j] for j in self.FINGER_JOINTS], dtype=float)

    @property
    def finger_ranges(self) -> np.ndarray:
        """(16, 2) finger joint limits in FINGER_JOINTS order (rad)."""
        return self.joint_ranges[len(self.WRIST_JOINTS) :]

    def open_pose(self) -> np.ndarray:
        """A relaxed open hand: every finger joint at 0, thumb base ``thj0`` at its lower limit.

        Returns:
            (16,) finger joint angles (rad) in FINGER_JOINTS order, inside the joint limits.
        """
        return np.clip(np.zeros(len(self.FINGER_JOINTS)), *self.finger_ranges.T)

    # ------------------------------------------------------------------ building
    def add_to(self, spec: mujoco.MjSpec, root_pos: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        """Add the hand (bodies, joints, actuators, sensors, contact excludes) to ``spec``.

        Args:
            spec: Spec to extend; the hand hangs from ``spec.worldbody``.
            root_pos: (3,) world position of ``hand_root`` (the wrist slides are offsets from it).

        Raises:
            ValueError: If ``spec`` already has a body named ``hand_root``.
        """
        if spec.body(self.ROOT_BODY) is not None:
            raise ValueError(f"spec already has a body named {self.ROOT_BODY!r}: add the hand only once")
        # A fresh MjSpec reads hinge ranges in degrees (compiler.degree=True); respect the caller's
        # setting instead of changing it. Actuator ctrlrange is never converted.
        hinge_unit = float(np.degrees(1.0)) if spec.compiler.degree else 1.0
        root = spec.worldbody.add_body(name=self.ROOT_BODY, pos=[float(v) for v in root_pos])
        self._add_wrist(spec, root, hinge_unit)

        palm_quat = np.asarray(_PALM_QUAT) / np.linalg.norm(_PALM_QUAT)
        bodies = {"palm": root.add_body(name="palm", quat=palm_quat.tolist())}
        self._add_geom(bodies["palm"], "palm", _PALM_GEOM, _PALM)
        for link in _FINGER_TREE:
            quat = np.asarray(link.quat, dtype=float)
            body = bodies[link.parent].add_body(
                name=link.name, pos=list(link.pos), quat=(quat / np.linalg.norm(quat)).tolist()
            )
            bodies[link.name] = body
            self._add_geom(body, link.name, link.geom, _TIP if link.name.endswith("_tip") else _DARK)
            if link.joint is not None:
                self._add_finger_joint(spec, body, link, hinge_unit)
        if self.gravcomp:
            root.gravcomp = 1.0
            for body in bodies.values():
                body.gravcomp = 1.0

        for other in ("ff_base", "mf_base", "rf_base", "th_base", "th_proximal"):
            spec.add_exclude(bodyname1="palm", bodyname2=other)
        for link in self.LINKS:
            spec.add_sensor(
                name=f"{link}_pos",
                type=mujoco.mjtSensor.mjSENS_FRAMEPOS,
                objtype=mujoco.mjtObj.mjOBJ_XBODY,
                objname=link,
            )
            spec.add_sensor(
                name=f"{link}_quat",
                type=mujoco.mjtSensor.mjSENS_FRAMEQUAT,
                objtype=mujoco.mjtObj.mjOBJ_XBODY,
                objname=link,
            )

    def _add_wrist(self, spec: mujoco.MjSpec, root: mujoco.MjsBody, hinge_unit: float) -> None:
        """Six wrist joints on ``root`` (slides x, y, z then hinges x, y, z) with position actuators.

        ``hinge_unit`` converts radians to the spec's compile-time angle unit (1 or 180/pi).
        """
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
            self._add_position_actuator(
                spec, jname, self.kp_slide if is_slide else self.kp_hinge, rng, force_limit=None
            )

    def _add_finger_joint(
        self, spec: mujoco.MjSpec, body: mujoco.MjsBody, link: _Link, hinge_unit: float
    ) -> None:
        """One finger hinge on ``body`` with its force-limited position actuator (see ``_add_wrist``)."""
        body.add_joint(
            name=link.joint,
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=list(link.axis),
            range=[hinge_unit * v for v in link.range],
            limited=mujoco.mjtLimited.mjLIMITED_TRUE,
            damping=self.damping_finger,
            armature=self.armature_finger,
        )
        self._add_position_actuator(spec, link.joint, self.kp_finger, link.range, self.force_limit_finger)

    @staticmethod
    def _add_position_actuator(
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

    # ------------------------------------------------------------------ ids in a compiled model
    def link_body_ids(self, model: mujoco.MjModel) -> np.ndarray:
        """(21,) body ids of LINKS."""
        return name2ids(model, mujoco.mjtObj.mjOBJ_BODY, self.LINKS)

    def link_geom_ids(self, model: mujoco.MjModel) -> np.ndarray:
        """(21,) collision geom ids (``f"{link}_col"``) of LINKS."""
        return name2ids(model, mujoco.mjtObj.mjOBJ_GEOM, [f"{link}_col" for link in self.LINKS])

    def geom_link_index(self, model: mujoco.MjModel) -> np.ndarray:
        """Map every geom of the model to its hand link, for contact attribution.

        Returns:
            (ngeom,) int array: index into LINKS of the link owning the geom, -1 for non-hand geoms.
        """
        out = np.full(model.ngeom, -1, dtype=int)
        body_to_link = np.full(model.nbody, -1, dtype=int)
        body_to_link[self.link_body_ids(model)] = np.arange(len(self.LINKS))
        out[:] = body_to_link[model.geom_bodyid]
        return out

    def joint_ids(self, model: mujoco.MjModel) -> np.ndarray:
        """(22,) joint ids of JOINTS."""
        return name2ids(model, mujoco.mjtObj.mjOBJ_JOINT, self.JOINTS)

    def qpos_adr(self, model: mujoco.MjModel) -> np.ndarray:
        """(22,) addresses of the hand joints in ``qpos``, in JOINTS order."""
        return model.jnt_qposadr[self.joint_ids(model)].copy()

    def dof_adr(self, model: mujoco.MjModel) -> np.ndarray:
        """(22,) addresses of the hand joints in ``qvel``, in JOINTS order."""
        return model.jnt_dofadr[self.joint_ids(model)].copy()

    def actuator_ids(self, model: mujoco.MjModel) -> np.ndarray:
        """(22,) actuator ids (= ``ctrl`` indices) of ACTUATORS."""
        return name2ids(model, mujoco.mjtObj.mjOBJ_ACTUATOR, self.ACTUATORS)

    def link_sensor_adr(self, model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
        """Addresses in ``sensordata`` of the link frame sensors.

        Returns:
            ``(pos_adr, quat_adr)``: (21,) start of each ``f"{link}_pos"`` (3 values, world frame) and
            (21,) start of each ``f"{link}_quat"`` (4 values, w x y z), in LINKS order.
        """
        pos = name2ids(model, mujoco.mjtObj.mjOBJ_SENSOR, [f"{link}_pos" for link in self.LINKS])
        quat = name2ids(model, mujoco.mjtObj.mjOBJ_SENSOR, [f"{link}_quat" for link in self.LINKS])
        return model.sensor_adr[pos].copy(), model.sensor_adr[quat].copy()
