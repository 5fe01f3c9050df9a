"""The object configuration ``q_o`` of a task and what is measured on it.

``q_o`` is the concatenation of the qpos of a declared list of object joints: a free joint contributes
7 entries (position, unit quaternion w x y z), a hinge or slide joint one angle/offset each. Which
column means what is known in one place, :class:`ObjectLayout`: it resolves the columns' qpos, qvel
and sensor addresses, measures errors between configurations, interpolates between two of them and
resamples a trajectory of them in time.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation, Slerp

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


def tilt_angle(qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    """The angle between the world's vertical as each orientation's body sees it: how far ``qa`` is tilted
    from ``qb``, leaving out any turn about the vertical (a bottle spun about its upright axis is not
    tilted, whichever of its axes is up).

    Args:
        qa: (..., 4) quaternions, w x y z.
        qb: (..., 4) quaternions, w x y z.

    Returns:
        (...,) angle in [0, pi].
    """

    def up(q: np.ndarray) -> np.ndarray:  # R(q)^T z, a unit vector: the third row of the rotation matrix
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)
        w, x, y, z = np.moveaxis(q, -1, 0)
        return np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1)

    cos = np.sum(up(np.asarray(qa, float)) * up(np.asarray(qb, float)), axis=-1)
    return np.arccos(np.clip(cos, -1.0, 1.0))


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
