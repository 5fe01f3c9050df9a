"""Task base class: the fixtures and objects of one manipulation task, and its object configuration.

A task adds its table/fixtures and its object bodies to a ``mujoco.MjSpec``. Its object configuration
``q_o`` is the concatenation of the qpos of a declared list of object joints: a free joint contributes
7 entries (position, unit quaternion w x y z), a hinge or slide joint one angle/offset each. Which
column means what is known in one place, :class:`ObjectLayout`: it resolves the columns' qpos, qvel
and sensor addresses, measures errors between configurations, interpolates between two of them and
resamples a trajectory of them in time.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Annotated

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from contactmpc.validate import Gt, checked

JOINT_WIDTH = {"free": 7, "hinge": 1, "slide": 1}  # entries in qpos
DOF_WIDTH = {"free": 6, "hinge": 1, "slide": 1}  # entries in qvel


@dataclass(frozen=True)
class ObjectJoint:
    """One joint of the object configuration ``q_o``.

    Attributes:
        name: MuJoCo joint name.
        kind: ``"free"``, ``"hinge"`` or ``"slide"``.
    """

    name: str
    kind: str

    def __post_init__(self) -> None:
        if self.kind not in JOINT_WIDTH:
            raise ValueError(f"object joint {self.name!r}: kind must be one of {sorted(JOINT_WIDTH)}")


@dataclass(frozen=True)
class ObjectError:
    """Errors between two object configurations, each of shape (...,).

    Attributes:
        position: Euclidean distance of the free body's position (m); 0 when there is none.
        rotation: geodesic angle between the free body's orientations (rad); 0 when there is none.
        articulation: Euclidean norm of the articulation differences (rad or m); 0 when there are none.
    """

    position: np.ndarray
    rotation: np.ndarray
    articulation: np.ndarray


def sustained(mask: np.ndarray, time: np.ndarray, duration: float) -> bool:
    """Whether ``mask`` is true on consecutive samples spanning at least ``duration`` seconds.

    Args:
        mask: (N,) bool.
        time: (N,) increasing sample times (s).
        duration: minimum span (s); 0 accepts a single sample.
    """
    start = None
    for i, ok in enumerate(np.asarray(mask, bool)):
        if not ok:
            start = None
            continue
        start = i if start is None else start
        if time[i] - time[start] >= duration - 1e-9:
            return True
    return False


def sustained_to_end(mask: np.ndarray, time: np.ndarray, duration: float) -> float | None:
    """The start (s) of the run of true samples that ends at the last sample, if it spans at least
    ``duration`` seconds; ``None`` otherwise (the last sample false, or the final run too short).

    Args:
        mask: (N,) bool.
        time: (N,) increasing sample times (s).
        duration: minimum span (s); 0 accepts the last sample alone.
    """
    mask = np.asarray(mask, bool)
    if not len(mask) or not mask[-1]:
        return None
    false = np.flatnonzero(~mask)
    start = int(false[-1]) + 1 if len(false) else 0
    return float(time[start]) if time[-1] - time[start] >= duration - 1e-9 else None


def quat_angle(qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    """Geodesic angle between unit quaternions.

    Args:
        qa: (..., 4) quaternions, w x y z.
        qb: (..., 4) quaternions, w x y z.

    Returns:
        (...,) angle in [0, pi] of the rotation that takes ``qa`` to ``qb``.
    """
    dot = np.abs(np.sum(qa * qb, axis=-1))
    dot /= np.linalg.norm(qa, axis=-1) * np.linalg.norm(qb, axis=-1)
    return 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))


class ObjectLayout:
    """The columns of ``q_o``, from its joints: free blocks (position 3 + quaternion 4) and
    articulations (one column per hinge or slide joint).

    Args:
        joints: the object joints, in ``q_o`` order.

    Attributes:
        joints: the object joints.
        width: ``n_o``, the number of columns.
        free_columns: (F,) first column of each free block.
        articulation_columns: (A,) column of each hinge/slide joint.
        articulation_joints: (A,) names of those joints, in ``q_o`` order.
    """

    def __init__(self, joints: tuple[ObjectJoint, ...]) -> None:
        self.joints = tuple(joints)
        free, art, col = [], [], 0
        for j in self.joints:
            (free if j.kind == "free" else art).append((col, j.name))
            col += JOINT_WIDTH[j.kind]
        self.width = col
        self.free_columns = tuple(c for c, _ in free)
        self.articulation_columns = tuple(c for c, _ in art)
        self.articulation_joints = tuple(n for _, n in art)

    @property
    def quat_index(self) -> int | None:
        """Column of the first free block's quaternion (w x y z), or None without a free joint."""
        return self.free_columns[0] + 3 if self.free_columns else None

    def position(self, qo: np.ndarray) -> np.ndarray:
        """(..., 3) position of the first free block of ``qo`` (..., n_o)."""
        c = self.free_columns[0]
        return qo[..., c : c + 3]

    def quaternion(self, qo: np.ndarray) -> np.ndarray:
        """(..., 4) quaternion (w x y z) of the first free block of ``qo`` (..., n_o)."""
        c = self.free_columns[0] + 3
        return qo[..., c : c + 4]

    # --- addresses in a compiled model -----------------------------------------------------
    def qpos_indices(self, model: mujoco.MjModel) -> np.ndarray:
        """(n_o,) indices into ``qpos`` that make up ``q_o``, resolved by joint name."""
        return self._indices(model, model.jnt_qposadr, JOINT_WIDTH)

    def dof_indices(self, model: mujoco.MjModel) -> np.ndarray:
        """(nv_o,) indices into ``qvel`` of the object joints."""
        return self._indices(model, model.jnt_dofadr, DOF_WIDTH)

    def _indices(self, model: mujoco.MjModel, address: np.ndarray, width: dict[str, int]) -> np.ndarray:
        idx = []
        for j in self.joints:
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            if jid < 0:
                raise ValueError(f"object joint {j.name!r} not in the model")
            idx.extend(range(address[jid], address[jid] + width[j.kind]))
        return np.asarray(idx, dtype=int)

    def sensors(self, model: mujoco.MjModel) -> list[tuple[str, int]]:
        """Sensors that read ``q_o`` directly, in ``q_o`` order: ``(name, width)`` pairs.

        A free block is read by its body's frame sensors ``<body>_pos`` (3) and ``<body>_quat`` (4),
        an articulation by its joint-position sensor ``<joint>_pos`` (1) (see :meth:`Task.add_to`).
        """
        out = []
        for j in self.joints:
            if JOINT_WIDTH[j.kind] == 1:
                out.append((f"{j.name}_pos", 1))
                continue
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            if jid < 0:
                raise ValueError(f"object joint {j.name!r} not in the model")
            body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.jnt_bodyid[jid])
            out += [(f"{body}_pos", 3), (f"{body}_quat", 4)]
        return out

    # --- arithmetic on configurations -------------------------------------------------------
    def error(self, qo_a: np.ndarray, qo_b: np.ndarray) -> ObjectError:
        """Errors between object configurations, vectorised over leading axes.

        Args:
            qo_a: (..., n_o) object configurations.
            qo_b: (..., n_o) object configurations (broadcastable to ``qo_a``).

        Returns:
            :class:`ObjectError` with arrays of shape (...,): position and rotation summed over the
            free blocks, articulation the norm over the articulation columns.
        """
        qo_a, qo_b = np.broadcast_arrays(np.asarray(qo_a, float), np.asarray(qo_b, float))
        shape = qo_a.shape[:-1]
        pos = np.zeros(shape)
        rot = np.zeros(shape)
        art = np.zeros(shape)
        for c in self.free_columns:
            pos = pos + np.linalg.norm(qo_a[..., c : c + 3] - qo_b[..., c : c + 3], axis=-1)
            rot = rot + quat_angle(qo_a[..., c + 3 : c + 7], qo_b[..., c + 3 : c + 7])
        for c in self.articulation_columns:
            art = art + (qo_a[..., c] - qo_b[..., c]) ** 2
        return ObjectError(position=pos, rotation=rot, articulation=np.sqrt(art))

    def interpolate(self, qa: np.ndarray, qb: np.ndarray, s: float) -> np.ndarray:
        """The configuration a fraction ``s`` of the way from ``qa`` (s = 0) to ``qb`` (s = 1).

        Positions and articulations linearly; each quaternion along the geodesic, with the sign of
        ``qa``'s.

        Returns:
            (n_o,) the configuration.
        """
        qa, qb = np.asarray(qa, float), np.asarray(qb, float)
        out = (1.0 - s) * qa + s * qb
        for c in self.free_columns:
            ra = Rotation.from_quat(qa[c + 3 : c + 7], scalar_first=True)
            rb = Rotation.from_quat(qb[c + 3 : c + 7], scalar_first=True)
            rot = ra * Rotation.from_rotvec(s * (ra.inv() * rb).as_rotvec())
            quat = rot.as_quat(scalar_first=True)
            if np.dot(quat, qa[c + 3 : c + 7]) < 0:
                quat = -quat
            out[c + 3 : c + 7] = quat
        return out

    def resample(self, times: np.ndarray, qo: np.ndarray, query: np.ndarray) -> np.ndarray:
        """A trajectory of configurations at other times: linear for positions and articulations,
        slerp for quaternions.

        Args:
            times: (T,) increasing sample times.
            qo: (T, n_o) object configurations.
            query: (N,) query times (clipped to ``times``' range).

        Returns:
            (N, n_o) configurations.
        """
        query = np.clip(query, times[0], times[-1])
        out = np.empty((len(query), qo.shape[1]))
        for c in range(qo.shape[1]):
            out[:, c] = np.interp(query, times, qo[:, c])
        for c in self.free_columns:
            rot = Rotation.from_quat(qo[:, c + 3 : c + 7], scalar_first=True)
            out[:, c + 3 : c + 7] = Slerp(times, rot)(query).as_quat(scalar_first=True, canonical=False)
        return out


class Task:
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

    # --- scene -------------------------------------------------------------------------------
    def add_to(self, spec: mujoco.MjSpec) -> None:
        """Add the task's fixtures, objects and object sensors to ``spec``: frame sensors
        ``<body>_pos``/``<body>_quat`` on every object body, and joint-position sensors ``<joint>_pos``
        on the articulations, so that ``q_o`` comes back in sensordata too."""
        self.add_objects(spec)
        for body in self.object_bodies:
            spec.add_sensor(
                name=f"{body}_pos",
                type=mujoco.mjtSensor.mjSENS_FRAMEPOS,
                objtype=mujoco.mjtObj.mjOBJ_XBODY,  # body frame, not the CoM frame
                objname=body,
            )
            spec.add_sensor(
                name=f"{body}_quat",
                type=mujoco.mjtSensor.mjSENS_FRAMEQUAT,
                objtype=mujoco.mjtObj.mjOBJ_XBODY,  # body frame, not the CoM frame
                objname=body,
            )
        for joint in self.layout.articulation_joints:
            spec.add_sensor(
                name=f"{joint}_pos",
                type=mujoco.mjtSensor.mjSENS_JOINTPOS,
                objtype=mujoco.mjtObj.mjOBJ_JOINT,
                objname=joint,
            )

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        """Add fixtures and object bodies (with the joints of ``object_joints``) to ``spec``."""
        raise NotImplementedError

    @staticmethod
    def add_table(spec: mujoco.MjSpec, size=(0.45, 0.45), height: float = 0.0) -> None:
        """A table whose top is the plane z = ``height``, with visual-only legs and top slab."""
        world = spec.worldbody
        world.add_geom(
            name="table_top",
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            pos=[0, 0, height],
            size=[size[0], size[1], 0.01],
            rgba=[0.62, 0.47, 0.33, 1.0],
            friction=[0.8, 0.01, 0.001],
        )
        slab = 0.02
        world.add_geom(
            name="table_slab",
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=[0, 0, height - slab - 0.0005],
            size=[size[0], size[1], slab],
            rgba=[0.55, 0.40, 0.28, 1.0],
            contype=0,
            conaffinity=0,
        )
        leg_h = 0.35
        world.add_geom(
            name="floor",
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            pos=[0, 0, height - 2 * slab - 2 * leg_h],
            size=[2.0, 2.0, 0.05],
            material="floor_mat",
            contype=0,
            conaffinity=0,
        )
        for i, (sx, sy) in enumerate([(1, 1), (1, -1), (-1, 1), (-1, -1)]):
            world.add_geom(
                name=f"table_leg{i}",
                type=mujoco.mjtGeom.mjGEOM_BOX,
                pos=[sx * (size[0] - 0.03), sy * (size[1] - 0.03), height - 2 * slab - leg_h],
                size=[0.02, 0.02, leg_h],
                rgba=[0.45, 0.33, 0.22, 1.0],
                contype=0,
                conaffinity=0,
            )

    # --- completion -------------------------------------------------------------------------
    def conditions(self, qo: np.ndarray, expected: np.ndarray) -> dict[str, np.ndarray]:
        """The task's milestone conditions, per logged sample.

        Args:
            qo: (N, n_o) the plant's object configuration over the trial.
            expected: (N, n_o) the reference's object configuration at the same times.

        Returns:
            Milestone name -> (N,) bool, whether the object satisfies it at that sample.
        """
        raise NotImplementedError

    def milestones(
        self, qo: np.ndarray, expected: np.ndarray, held: np.ndarray, time: np.ndarray, hold: float
    ) -> dict[str, bool]:
        """Which milestones a trial reached: each condition of :meth:`conditions` must hold *while the
        hand touches the object* for at least ``hold`` seconds in a row (one rule for every task, so an
        object falling through a goal pose, or touching it for an instant, does not count).

        Args:
            qo: (N, n_o) the plant's object configuration over the trial.
            expected: (N, n_o) the reference's object configuration at the same times.
            held: (N,) bool, whether any hand link touches the object.
            time: (N,) sample times (s).
            hold: minimum duration (s).

        Returns:
            Milestone name -> reached. The task is completed when all are reached.
        """
        return {name: sustained(ok & held, time, hold) for name, ok in self.conditions(qo, expected).items()}

    # --- the final milestone: the object left where the reference leaves it --------------------
    # Tolerances from the reference's final object configuration (subclasses set their own where
    # they have a milestone tolerance already): the first free body's position (m) and orientation
    # (rad), and the norm over the articulations (rad, or m for a slide).
    SETTLE_POSITION: float = 0.05
    SETTLE_ROTATION: float = float(np.radians(30.0))
    SETTLE_ARTICULATION: float = 0.1
    # "At rest": the object's speed between consecutive logged rows at most these (m/s, rad/s, rad/s
    # or m/s). Measured (lite preset, 50 ms rows): resting on the table 0; held still by the MPC hand
    # (apple, seed 0, last second) up to 7.7 mm/s and 0.25 rad/s; rolling off the table after an
    # open-loop replay 77 mm/s median, 121 mm/s and 3.3 rad/s at most.
    REST_SPEED: float = 0.02
    REST_ANGULAR_SPEED: float = 0.5
    REST_ARTICULATION_SPEED: float = 0.05

    def near_final(self, qo: np.ndarray, final: np.ndarray) -> np.ndarray:
        """(N,) whether the object is within the ``SETTLE_*`` tolerances of the configuration ``final``
        (n_o,) (the reference's last) at each sample of ``qo`` (N, n_o)."""
        err = self.layout.error(qo, np.asarray(final, float)[None])
        return (
            (err.position <= self.SETTLE_POSITION)
            & (err.rotation <= self.SETTLE_ROTATION)
            & (err.articulation <= self.SETTLE_ARTICULATION)
        )

    def at_rest(self, qo: np.ndarray, time: np.ndarray) -> np.ndarray:
        """(N,) whether the object is at rest at each sample: its speed from the previous sample and to
        the next (where there is one) is within the ``REST_*`` speeds.

        Args:
            qo: (N, n_o) object configurations.
            time: (N,) increasing sample times (s).
        """
        qo = np.asarray(qo, float)
        dt = np.maximum(np.diff(np.asarray(time, float)), 1e-12)
        step = self.layout.error(qo[1:], qo[:-1])
        slow = (
            (step.position / dt <= self.REST_SPEED)
            & (step.rotation / dt <= self.REST_ANGULAR_SPEED)
            & (step.articulation / dt <= self.REST_ARTICULATION_SPEED)
        )
        rest = np.ones(len(qo), bool)
        rest[1:] &= slow
        rest[:-1] &= slow
        return rest

    def settled(
        self,
        qo: np.ndarray,
        final: np.ndarray,
        held: np.ndarray,
        time: np.ndarray,
        hold: float,
        let_go: bool,
    ) -> float | None:
        """The final milestone, *settled*: the trial ends as the reference ends. The object is at rest
        (:meth:`at_rest`) within the ``SETTLE_*`` tolerances of the reference's final configuration
        (:meth:`near_final`), and the hand touches it as the reference's last frame says: not at all
        where the reference has let go (``let_go``), still holding it where the reference ends held. All
        three must hold on every sample of the trial's last ``hold`` seconds or more, so an object
        set down and knocked off later, or carried away after the hand-off, does not count.

        Unlike :meth:`milestones` (conditions that hold *while held*, anywhere in the trial), this
        one is about the end of the trial and may ask for the hand *off* the object; it is not one of
        the milestones that make a trial ``completed``.

        Args:
            qo: (N, n_o) the plant's object configuration over the trial.
            final: (n_o,) the reference's final object configuration.
            held: (N,) bool, whether any hand link touches the object.
            time: (N,) sample times (s).
            hold: minimum duration (s) of the final run.
            let_go: whether the reference ends without contact (the hand must be off the object).

        Returns:
            The instant (s) from which the object stays settled to the end of the trial, or ``None``
            when it is not settled for the last ``hold`` seconds.
        """
        held = np.asarray(held, bool)
        contact = ~held if let_go else held
        ok = self.near_final(qo, final) & self.at_rest(qo, time) & contact
        return sustained_to_end(ok, time, hold)

    def lift(self, qo: np.ndarray) -> np.ndarray:
        """(N,) height of the (first) free body above its first position (m)."""
        z = self.layout.position(qo)[:, 2]
        return z - z[0]

    def tilt(self, qo: np.ndarray) -> np.ndarray:
        """(N,) angle between the (first) free body's z axis and world z (rad)."""
        q = self.layout.quaternion(qo)
        w, x, y = q[:, 0], q[:, 1], q[:, 2]
        z = q[:, 3]
        zz = 1.0 - 2.0 * (x * x + y * y)  # world-z component of the body's z axis
        zz /= w * w + x * x + y * y + z * z
        return np.arccos(np.clip(zz, -1.0, 1.0))

    def start_object_qpos(self, reference_qo: np.ndarray) -> np.ndarray:
        """(n_o,) where a trial puts the object at t = 0, given the reference's first configuration
        ``reference_qo`` (n_o,); the reference's own, unless a task moves it (the paper's apple)."""
        return np.array(reference_qo, dtype=float, copy=True)

    def initial_object_qpos(self, model: mujoco.MjModel) -> np.ndarray:
        """(n_o,) the object configuration of the model's default pose (``qpos0``)."""
        return model.qpos0[self.layout.qpos_indices(model)].copy()
