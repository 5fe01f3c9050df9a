r"""The lowest layer of synthesis: rigid poses, wrist angles and a private kinematic copy of the scene.

:class:`Kinematics` is a private copy of a scene's model with one extra mocap *probe* sphere (used to
measure the signed distance of a point to a geom's surface); it sets configurations (respecting the
joint equalities that slave one object joint to another, e.g. the door's latch bolt to the knob), and
answers pose, distance and contact queries with MuJoCo's own collision filtering.

The wrist is three slides and three hinges on ``hand_root`` with :math:`R = R_x(r_x) R_y(r_y) R_z(r_z)`
(intrinsic XYZ Euler angles); :func:`wrist_angles` picks, of the equivalent angle triples, the one
closest to the previous frame, so curves stay continuous.

Everything here is deterministic: no random initialisation, no wall-clock dependence.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from contactmpc.scene import Scene, SceneIndex

__all__ = ["Contacts", "Kinematics", "Pose", "SynthesisError", "wrist_angles"]

_PROBE = "synthesis_probe"
_PROBE_RADIUS = 1e-5


class SynthesisError(RuntimeError):
    """A demonstration that cannot be synthesised or fails a quality gate; one line, naming the cause."""

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(str(message).split()))


# ------------------------------------------------------------------------------------------- poses
@dataclass(frozen=True)
class Pose:
    """A rigid transform: ``x_world = pos + rot.apply(x_local)``.

    Attributes:
        pos: (3,) translation (m).
        rot: rotation.
    """

    pos: np.ndarray
    rot: Rotation

    def __mul__(self, other: Pose) -> Pose:
        return Pose(self.pos + self.rot.apply(other.pos), self.rot * other.rot)

    def inv(self) -> Pose:
        """The inverse transform."""
        r = self.rot.inv()
        return Pose(-r.apply(self.pos), r)

    def apply(self, points: np.ndarray) -> np.ndarray:
        """(..., 3) local points → world."""
        return self.pos + self.rot.apply(points)

    def interpolate(self, other: Pose, s: float) -> Pose:
        """Linear position and geodesic (slerp) rotation from ``self`` (s = 0) to ``other`` (s = 1)."""
        delta = (self.rot.inv() * other.rot).as_rotvec()
        return Pose((1.0 - s) * self.pos + s * other.pos, self.rot * Rotation.from_rotvec(s * delta))

    def translated(self, offset: np.ndarray) -> Pose:
        """The same rotation at ``pos + offset`` (offset in the world frame)."""
        return Pose(self.pos + np.asarray(offset, float), self.rot)


def wrist_angles(rot: Rotation, reference: np.ndarray) -> np.ndarray:
    r"""Wrist hinge angles :math:`(r_x, r_y, r_z)` with :math:`R = R_x R_y R_z`, closest to ``reference``.

    Of the two Euler triples of a rotation, :math:`(a, b, c)` and :math:`(a + \pi, \pi - b, c + \pi)`,
    each shifted by multiples of :math:`2\pi`, the one nearest to ``reference`` is returned, so a
    sequence converted frame by frame (each frame's reference = the previous result) is continuous.

    Args:
        rot: the root rotation.
        reference: (3,) angles to stay close to (rad).

    Returns:
        (3,) angles (rad).

    Raises:
        SynthesisError: at (or near) gimbal lock, :math:`|\cos r_y| < 0.02`, where the angles are
            ill-defined.
    """
    reference = np.asarray(reference, float)
    mat = rot.as_matrix()
    # R[0, 2] = sin(ry) for R = Rx Ry Rz; decompose by hand (scipy warns at gimbal lock).
    sy = float(np.clip(mat[0, 2], -1.0, 1.0))
    cy = math.sqrt(max(0.0, 1.0 - sy * sy))
    if cy < 0.02:
        raise SynthesisError(f"wrist rotation at gimbal lock (ry = {math.degrees(math.asin(sy)):.1f} deg)")
    a = np.array(
        [math.atan2(-mat[1, 2], mat[2, 2]), math.asin(sy), math.atan2(-mat[0, 1], mat[0, 0])], dtype=float
    )
    best, best_err = a, np.inf
    for cand in (a, np.array([a[0] + math.pi, math.pi - a[1], a[2] + math.pi])):
        shifted = cand + 2.0 * math.pi * np.round((reference - cand) / (2.0 * math.pi))
        err = float(np.sum((shifted - reference) ** 2))
        if err < best_err:
            best, best_err = shifted, err
    return best


# -------------------------------------------------------------------------------------- kinematics
class Kinematics:
    """A private copy of a scene's model for kinematic and collision queries.

    The copy adds one mocap body carrying a tiny non-colliding sphere (a *probe*) used to measure the
    signed distance of a point to a geom's surface; everything else (bodies, geoms, names, contact
    filtering) is the scene's. Geom margins of the copy are changed freely by :meth:`contacts`.

    Args:
        scene: the scene (hand + task).

    Attributes:
        model, data: the copy and its data.
        num_root: number of root (wrist) DOFs of the hand, the first entries of a hand configuration.
        hand_qpos_adr: (J,) qpos addresses of the hand joints, in the hand's joint order.
        object_qpos_adr: (n_o,) qpos addresses of ``q_o``.
        root_body: body id of the hand root; ``root_offset`` (3,) its world position at zero wrist.
        link_bodies, link_geoms: (L,) body ids and collision geom ids of the hand links.
        link_of_geom: (ngeom,) index of the hand link owning each geom, -1 if none.
        object_bodies: (B,) body ids of ``task.object_bodies``.
        object_of_geom: (ngeom,) index into ``object_bodies`` of the object body owning each geom (a
            descendant body, e.g. the door's bolt, belongs to its nearest listed ancestor), -1 if none.
        object_geoms: (G_o,) colliding object geoms; ``env_geoms``: colliding geoms of neither.
    """

    def __init__(self, scene: Scene) -> None:
        spec = scene.spec.copy()
        probe = spec.worldbody.add_body(name=_PROBE, mocap=True)
        probe.add_geom(
            name=_PROBE,
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            size=[_PROBE_RADIUS, 0, 0],
            contype=0,
            conaffinity=0,
            group=5,
        )
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.hand = scene.hand
        self.task = scene.task
        m = self.model
        index = SceneIndex.resolve(m, scene.hand, scene.task)
        self.num_root = scene.hand.num_root
        self.hand_qpos_adr = index.hand_qpos
        self.object_qpos_adr = index.object_qpos
        self.root_body = index.root_body
        self.root_offset = m.body_pos[self.root_body].copy()
        self.link_names = tuple(scene.hand.link_names)
        self.link_bodies = index.link_bodies
        self.link_geoms = index.link_geoms
        self.link_of_geom = index.link_of_geom
        self.object_bodies = index.object_bodies
        owner = -np.ones(m.nbody, dtype=int)
        for b in range(1, m.nbody):  # parents precede children in MuJoCo's body order
            hit = np.flatnonzero(self.object_bodies == b)
            owner[b] = hit[0] if hit.size else owner[m.body_parentid[b]]
        self.object_of_geom = owner[m.geom_bodyid]
        collides = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
        self.object_geoms = np.flatnonzero(collides & (self.object_of_geom >= 0))
        self.env_geoms = np.flatnonzero(collides & (self.object_of_geom < 0) & (self.link_of_geom < 0))
        self.probe_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, _PROBE)
        # Joints slaved to an object joint by a joint equality (e.g. the door's latch bolt to the knob):
        # q1 = q1_0 + sum_i c_i (q2 - q2_0)^i, applied by set() so the kinematics respect the coupling.
        self._couplings = []
        for e in range(m.neq):
            if m.eq_type[e] != mujoco.mjtEq.mjEQ_JOINT or not m.eq_active0[e] or m.eq_obj2id[e] < 0:
                continue
            a1, a2 = m.jnt_qposadr[m.eq_obj1id[e]], m.jnt_qposadr[m.eq_obj2id[e]]
            self._couplings.append((a1, m.qpos0[a1], a2, m.qpos0[a2], m.eq_data[e, :5].copy()))
        self._margin: float | None = None
        self._fromto = np.zeros(6)
        self._is_plane = m.geom_type == int(mujoco.mjtGeom.mjGEOM_PLANE)

    # -- names
    def body_id(self, name: str) -> int:
        """Body id of ``name``; SynthesisError when missing."""
        i = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if i < 0:
            raise SynthesisError(f"body {name!r} not in the scene")
        return i

    def geom_id(self, name: str) -> int:
        """Geom id of ``name``; SynthesisError when missing."""
        i = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, name)
        if i < 0:
            raise SynthesisError(f"geom {name!r} not in the scene")
        return i

    def object_geoms_of(self, body: str, subtree: bool = False) -> np.ndarray:
        """Colliding object geoms of body ``body`` and its unlisted descendants (with ``subtree``: of
        every descendant)."""
        root = self.body_id(body)
        if root not in self.object_bodies:
            raise SynthesisError(f"body {body!r} is not one of the task's object bodies")
        if not subtree:
            index = int(np.flatnonzero(self.object_bodies == root)[0])
            return self.object_geoms[self.object_of_geom[self.object_geoms] == index]
        m = self.model
        inside = np.zeros(m.nbody, bool)
        inside[root] = True
        for b in range(root + 1, m.nbody):  # parents precede children
            inside[b] = inside[m.body_parentid[b]]
        return self.object_geoms[inside[m.geom_bodyid[self.object_geoms]]]

    # -- state
    def set(self, hand_qpos: np.ndarray, object_qpos: np.ndarray) -> None:
        """Set a configuration and run forward kinematics (positions of bodies and geoms)."""
        self.data.qpos[self.hand_qpos_adr] = hand_qpos
        self.data.qpos[self.object_qpos_adr] = object_qpos
        for a1, q10, a2, q20, coef in self._couplings:
            dq = self.data.qpos[a2] - q20
            self.data.qpos[a1] = q10 + sum(c * dq**i for i, c in enumerate(coef))
        mujoco.mj_kinematics(self.model, self.data)

    def body_pose(self, body: int) -> Pose:
        """World pose of body ``body`` (its body frame, as the frame sensors report it)."""
        return Pose(
            self.data.xpos[body].copy(), Rotation.from_matrix(self.data.xmat[body].reshape(3, 3).copy())
        )

    def root_pose(self) -> Pose:
        """World pose of the hand root."""
        return self.body_pose(self.root_body)

    def wrist_qpos(self, pose: Pose, reference: np.ndarray) -> np.ndarray:
        """(num_root,) wrist joint values putting the hand root at ``pose``.

        The wrist of :class:`~contactmpc.hands.base.FloatingHand`: three slides (the root's offset from
        its zero), then three hinges (:func:`wrist_angles`, closest to those of ``reference``).
        """
        hinges = wrist_angles(pose.rot, reference[3 : self.num_root])
        return np.concatenate([pose.pos - self.root_offset, hinges])

    # -- distances
    def distance(self, geom1: int, geom2: int, distmax: float = 0.3) -> tuple[float, np.ndarray]:
        """Signed distance between two geoms (negative: penetration) and the (6,) segment from the
        nearest point of ``geom1`` to that of ``geom2`` (zeros when farther than ``distmax``)."""
        self._fromto[:] = 0.0
        dist = mujoco.mj_geomDistance(self.model, self.data, geom1, geom2, distmax, self._fromto)
        return float(dist), self._fromto.copy()

    def point_distance(self, point: np.ndarray, geoms: Sequence[int], distmax: float = 0.3) -> float:
        """Signed distance of a world point to the nearest surface of ``geoms`` (negative inside).

        Uses the probe sphere, whose world position is written straight into ``geom_xpos`` (the
        kinematics of the rest of the model are untouched).
        """
        self.data.geom_xpos[self.probe_geom] = point
        best = np.inf
        for g in geoms:
            d = mujoco.mj_geomDistance(self.model, self.data, self.probe_geom, int(g), distmax, None)
            best = min(best, d + _PROBE_RADIUS)
        return float(best)

    def collision_pairs(self, geoms_a: Sequence[int], geoms_b: Sequence[int]) -> np.ndarray:
        """(n, 2) geom pairs ``(a, b)`` that MuJoCo's collision filtering would test.

        Filtering as in MuJoCo: different weld bodies (a body without joints is welded to its parent),
        contype/conaffinity compatible, not parent and child (unless one is the world), not excluded;
        each unordered pair once.
        """
        m = self.model
        excluded = set(int(v) for v in m.exclude_signature)
        out, seen = [], set()
        for a in geoms_a:
            for b in geoms_b:
                a, b = int(a), int(b)
                key = (min(a, b), max(a, b))
                if a == b or key in seen:
                    continue
                ba, bb = int(m.geom_bodyid[a]), int(m.geom_bodyid[b])
                wa, wb = int(m.body_weldid[ba]), int(m.body_weldid[bb])
                if wa == wb:
                    continue
                if not (
                    m.geom_contype[a] & m.geom_conaffinity[b] or m.geom_contype[b] & m.geom_conaffinity[a]
                ):
                    continue
                pa, pb = int(m.body_weldid[m.body_parentid[wa]]), int(m.body_weldid[m.body_parentid[wb]])
                if wa != 0 and wb != 0 and (wa == pb or wb == pa):
                    continue
                if (min(ba, bb) << 16) + max(ba, bb) in excluded:
                    continue
                seen.add(key)
                out.append((a, b))
        return np.asarray(out, dtype=int).reshape(-1, 2)

    def pair_distances(self, pairs: np.ndarray, distmax: float) -> np.ndarray:
        """(n,) signed distances of geom ``pairs`` (n, 2), capped at ``distmax``.

        Pairs whose bounding spheres are farther apart than ``distmax`` are not queried.
        """
        m, d = self.model, self.data
        out = np.full(len(pairs), distmax)
        if not len(pairs):
            return out
        ga, gb = pairs[:, 0], pairs[:, 1]
        gap = (
            np.linalg.norm(d.geom_xpos[ga] - d.geom_xpos[gb], axis=1) - m.geom_rbound[ga] - m.geom_rbound[gb]
        )
        plane = self._is_plane[ga] | self._is_plane[gb]
        near = np.flatnonzero(plane | (gap < distmax))
        dist = mujoco.mj_geomDistance
        out[near] = [dist(m, d, a, b, distmax, None) for a, b in pairs[near].tolist()]
        return out

    def contacts(self, margin: float) -> Contacts:
        """All contacts of the current configuration closer than ``margin`` (MuJoCo's own filtering).

        Args:
            margin: detection distance (m), applied to every geom of the private model.
        """
        if self._margin != margin:
            self.model.geom_margin[:] = margin
            self.model.geom_gap[:] = 0.0
            self._margin = margin
        mujoco.mj_collision(self.model, self.data)
        n = self.data.ncon
        con = self.data.contact
        dist = con.dist[:n].copy()
        keep = dist <= margin
        normal = con.frame[:n, :3].copy()
        pos = con.pos[:n].copy()
        return Contacts(
            geom1=con.geom1[:n][keep].copy(),
            geom2=con.geom2[:n][keep].copy(),
            dist=dist[keep],
            point1=(pos - 0.5 * dist[:, None] * normal)[keep],
            point2=(pos + 0.5 * dist[:, None] * normal)[keep],
        )


@dataclass(frozen=True)
class Contacts:
    """Contacts of one configuration, each array over contacts ``(n, ...)``.

    Attributes:
        geom1, geom2: (n,) geom ids.
        dist: (n,) signed distance (negative: penetration).
        point1, point2: (n, 3) world points on the surfaces of ``geom1`` and ``geom2``.
    """

    geom1: np.ndarray
    geom2: np.ndarray
    dist: np.ndarray
    point1: np.ndarray
    point2: np.ndarray
