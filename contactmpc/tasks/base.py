"""Task base class: the fixtures and objects of one manipulation task, and its object configuration.

A task adds its table/fixtures and its object bodies to a ``mujoco.MjSpec``. Its object configuration
``q_o`` is the concatenation of the qpos of a declared list of object joints: a free joint contributes
7 entries (position, unit quaternion w x y z), a hinge or slide joint one angle/offset each.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

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


class Task:
    """Base class of a manipulation task.

    Subclasses set ``name``, ``object_joints`` (the ``q_o`` layout), ``object_bodies`` (bodies that get
    frame sensors; contact points are expressed in one of them) and implement :meth:`add_objects`.

    Args:
        hand_home: (22,) initial hand configuration (wrist x y z rx ry rz, then 16 finger joints).
        time_scale: slow-down factor applied to the demonstration before control (paper: 5-10).
        reference_path: optional user-supplied reference ``.npz``; ``None`` synthesises one.
    """

    name: str = "task"
    object_joints: tuple[ObjectJoint, ...] = ()
    object_bodies: tuple[str, ...] = ()
    table_height: float = 0.0
    # Default free camera for renders: see contactmpc.render.make_camera.
    view: dict = {"lookat": (0.0, 0.0, 0.06), "distance": 0.75, "azimuth": 135.0, "elevation": -25.0}

    def __init__(
        self,
        hand_home: list[float] | np.ndarray,
        time_scale: float = 5.0,
        reference_path: str | None = None,
    ) -> None:
        self.hand_home = np.asarray(hand_home, dtype=float)
        if self.hand_home.shape != (22,):
            raise ValueError(f"task {self.name}: hand_home must have 22 entries, got {self.hand_home.shape}")
        if time_scale <= 0:
            raise ValueError(f"task {self.name}: time_scale must be positive, got {time_scale}")
        self.time_scale = float(time_scale)
        self.reference_path = reference_path

    # --- scene -------------------------------------------------------------------------------
    def add_to(self, spec: mujoco.MjSpec) -> None:
        """Add the task's fixtures, objects and object frame sensors to ``spec``."""
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

        for j in self.object_joints:
            if j.kind != "free":  # articulation angles come back in sensordata as well
                spec.add_sensor(
                    name=f"{j.name}_pos",
                    type=mujoco.mjtSensor.mjSENS_JOINTPOS,
                    objtype=mujoco.mjtObj.mjOBJ_JOINT,
                    objname=j.name,
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

    # --- object configuration ---------------------------------------------------------------
    @property
    def qo_dim(self) -> int:
        """Length of ``q_o``."""
        return sum(JOINT_WIDTH[j.kind] for j in self.object_joints)

    def qo_qpos_indices(self, model: mujoco.MjModel) -> np.ndarray:
        """(n_o,) indices into ``qpos`` that make up ``q_o``, resolved by joint name."""
        return self._joint_indices(model, model.jnt_qposadr, JOINT_WIDTH)

    def qo_dof_indices(self, model: mujoco.MjModel) -> np.ndarray:
        """(nv_o,) indices into ``qvel`` of the object joints."""
        return self._joint_indices(model, model.jnt_dofadr, DOF_WIDTH)

    def _joint_indices(self, model: mujoco.MjModel, address: np.ndarray, width: dict[str, int]) -> np.ndarray:
        idx = []
        for j in self.object_joints:
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            if jid < 0:
                raise ValueError(f"task {self.name}: object joint {j.name!r} not in the model")
            idx.extend(range(address[jid], address[jid] + width[j.kind]))
        return np.asarray(idx, dtype=int)

    def object_error(self, qo_a: np.ndarray, qo_b: np.ndarray) -> ObjectError:
        """Errors between object configurations, vectorised over leading axes.

        Args:
            qo_a: (..., n_o) object configurations.
            qo_b: (..., n_o) object configurations (broadcastable to ``qo_a``).

        Returns:
            :class:`ObjectError` with arrays of shape (...,).
        """
        qo_a, qo_b = np.broadcast_arrays(np.asarray(qo_a, float), np.asarray(qo_b, float))
        shape = qo_a.shape[:-1]
        pos = np.zeros(shape)
        rot = np.zeros(shape)
        art = np.zeros(shape)
        col = 0
        for j in self.object_joints:
            if j.kind == "free":
                pos = pos + np.linalg.norm(qo_a[..., col : col + 3] - qo_b[..., col : col + 3], axis=-1)
                rot = rot + quat_angle(qo_a[..., col + 3 : col + 7], qo_b[..., col + 3 : col + 7])
            else:
                art = art + (qo_a[..., col] - qo_b[..., col]) ** 2
            col += JOINT_WIDTH[j.kind]
        return ObjectError(position=pos, rotation=rot, articulation=np.sqrt(art))

    # --- completion -------------------------------------------------------------------------
    def milestones(self, qo: np.ndarray, expected: np.ndarray) -> dict[str, bool]:
        """The task's milestones, judged on a trial's object trajectory.

        Args:
            qo: (N, n_o) the plant's object configuration over the trial.
            expected: (N, n_o) the reference's object configuration at the same times.

        Returns:
            Milestone name -> reached. The task is completed when all are reached.
        """
        raise NotImplementedError

    def completed(self, qo: np.ndarray, expected: np.ndarray) -> bool:
        """Whether every milestone of :meth:`milestones` was reached."""
        return all(self.milestones(qo, expected).values())

    @staticmethod
    def lift(qo: np.ndarray) -> np.ndarray:
        """(N,) height of a free body (columns 0:3 of ``q_o``) above its first position (m)."""
        return qo[:, 2] - qo[0, 2]

    @staticmethod
    def tilt(qo: np.ndarray) -> np.ndarray:
        """(N,) angle between a free body's z axis (quaternion in columns 3:7) and world z (rad)."""
        w, x, y = qo[:, 3], qo[:, 4], qo[:, 5]
        z = qo[:, 6]
        zz = 1.0 - 2.0 * (x * x + y * y)  # world-z component of the body's z axis
        zz /= w * w + x * x + y * y + z * z
        return np.arccos(np.clip(zz, -1.0, 1.0))

    def initial_object_qpos(self, model: mujoco.MjModel) -> np.ndarray:
        """(n_o,) the object configuration of the model's default pose (``qpos0``)."""
        return model.qpos0[self.qo_qpos_indices(model)].copy()
