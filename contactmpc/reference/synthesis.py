r"""Synthesised demonstrations: grasp solving, phase timelines and per-link contact summaries.

A demonstration (see :mod:`contactmpc.reference.demos`) is described by

* a **grasp problem** solved once, in the frame of one object body, by bounded least squares
  (``scipy.optimize.least_squares``, bounds = the hand's joint ranges) over the 22 hand DOFs:
  designated links onto the object (signed distances from ``mj_geomDistance``), no penetration of the
  object, the fixtures or the hand itself (every geom pair MuJoCo's own filtering would test, as a
  smooth softplus penalty), and a regulariser towards a natural finger pose (:func:`solve_grasp`);
* open fingers for approach and release, solved so that the approach along ``approach_offset`` and
  the straight joint-space close into the grasp are collision-free (:func:`solve_preshape`);
* a list of **phases** (approach, reach, close, moves of the object, open, retreat) whose object
  keyframes are interpolated with a minimum-jerk profile.

While the hand holds the object it *rides* with it: with :math:`T_b(q_o)` the pose of the grasp body
and :math:`G = T_b(q_o^*)^{-1} T_r^*` the grasp offset of the hand root (solved at :math:`q_o^*`),

.. math::  T_r(t) = T_b(q_o(t))\, G, \qquad q_\text{fingers}(t) = q_\text{fingers}^*.

A grasp may also be re-solved at several values of one object articulation (the stapler's press);
:class:`GraspSchedule` then interpolates offset and fingers between them.

The wrist is three slides and three hinges on ``hand_root`` with :math:`R = R_x(r_x) R_y(r_y) R_z(r_z)`
(intrinsic XYZ Euler angles); :func:`wrist_angles` picks, of the equivalent angle triples, the one
closest to the previous frame, so curves stay continuous.

Per frame and link the contact is summarised as in the paper (§II-A, :func:`summarise_contacts`): the
link is *active* when its collision geom lies within ``contact_threshold`` of an object geom; its
link-local point is the mean of the link-side points of its contacts with that geom (MuJoCo's collision
with a margin, so a flat patch yields several points), in the link body frame; the object-local point
is the mean of the corresponding object-side points, in the frame of the object body owning the geom.

Everything here is deterministic: no random initialisation, no wall-clock dependence.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import mujoco
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from contactmpc.reference.bspline import UniformBSpline
from contactmpc.reference.data import Reference

if TYPE_CHECKING:
    from contactmpc.scene import Scene
    from contactmpc.tasks.base import Task

__all__ = [
    "SYNTHESIS_VERSION",
    "Approach",
    "Close",
    "ContactTarget",
    "Demonstration",
    "Grasp",
    "GraspProblem",
    "GraspSchedule",
    "Kinematics",
    "Move",
    "Open",
    "Phase",
    "Pose",
    "Reach",
    "Retreat",
    "SynthesisError",
    "interpolate_object_qpos",
    "min_jerk",
    "object_quat_index",
    "solve_grasp",
    "suggest_num_control_points",
    "summarise_contacts",
    "synthesize",
    "wrist_angles",
]

SYNTHESIS_VERSION = 1
"""Bumped whenever synthesis changes its output (callers cache references by it)."""

_PROBE = "synthesis_probe"
_PROBE_RADIUS = 1e-5


class SynthesisError(RuntimeError):
    """A demonstration that cannot be synthesised or fails a quality gate; one line, naming the cause."""

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(str(message).split()))


def min_jerk(s: np.ndarray | float) -> np.ndarray:
    r"""Minimum-jerk profile :math:`10 s^3 - 15 s^4 + 6 s^5` of ``s`` clipped to [0, 1] (zero velocity
    and acceleration at both ends)."""
    s = np.clip(np.asarray(s, dtype=float), 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


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


def object_quat_index(task: Task) -> int | None:
    """Column of the first free joint's quaternion (w x y z) in ``q_o``, or None without a free joint."""
    col = 0
    for joint in task.object_joints:
        if joint.kind == "free":
            return col + 3
        col += 1  # hinge or slide
    return None


def interpolate_object_qpos(task: Task, qa: np.ndarray, qb: np.ndarray, s: float) -> np.ndarray:
    """Object configuration between ``qa`` (s = 0) and ``qb`` (s = 1).

    Free joints: linear position and slerp of the quaternion; hinges and slides: linear.

    Returns:
        (n_o,) the configuration (quaternion with the sign of ``qa``'s).
    """
    qa, qb = np.asarray(qa, float), np.asarray(qb, float)
    out = (1.0 - s) * qa + s * qb
    col = 0
    for joint in task.object_joints:
        if joint.kind == "free":
            ra = Rotation.from_quat(qa[col + 3 : col + 7], scalar_first=True)
            rb = Rotation.from_quat(qb[col + 3 : col + 7], scalar_first=True)
            rot = ra * Rotation.from_rotvec(s * (ra.inv() * rb).as_rotvec())
            quat = rot.as_quat(scalar_first=True)
            if np.dot(quat, qa[col + 3 : col + 7]) < 0:
                quat = -quat
            out[col + 3 : col + 7] = quat
            col += 7
        else:
            col += 1
    return out


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
        hand_qpos_adr: (22,) qpos addresses of the hand joints, in the hand's joint order.
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
        self.hand_qpos_adr = scene.hand.qpos_adr(m)
        self.object_qpos_adr = scene.task.qo_qpos_indices(m)
        self.root_body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, scene.hand.ROOT_BODY)
        self.root_offset = m.body_pos[self.root_body].copy()
        self.link_names = tuple(scene.hand.link_names)
        self.link_bodies = scene.hand.link_body_ids(m)
        self.link_geoms = scene.hand.link_geom_ids(m)
        self.link_of_geom = scene.hand.geom_link_index(m)
        self.object_bodies = np.array([self.body_id(n) for n in scene.task.object_bodies], dtype=int)
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
        """(6,) wrist joint values putting the hand root at ``pose`` (hinges closest to ``reference[3:]``)."""
        return np.concatenate([pose.pos - self.root_offset, wrist_angles(pose.rot, reference[3:6])])

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


# ------------------------------------------------------------------------------------------- grasp
@dataclass(frozen=True)
class ContactTarget:
    """One hand link the grasp must bring onto the object.

    Attributes:
        link: hand link (body) name; its collision geom is ``f"{link}_col"``.
        weight: weight of the distance residual (1 = one unit per mm).
        gap: target signed distance to the object (m); slightly negative = a light squeeze.
        geoms: object geom names this link should touch; None: the problem's ``target_geoms``.
        toward: optional (3,) point in the grasp body's frame that the link geom's centre is drawn
            to (shapes *where* on the object the link lands).
        toward_weight: weight of that attraction (1 = one unit per cm).
    """

    link: str
    weight: float = 1.0
    gap: float = -0.0004
    geoms: tuple[str, ...] | None = None
    toward: tuple[float, float, float] | None = None
    toward_weight: float = 0.3


@dataclass(frozen=True)
class GraspProblem:
    """A whole-hand grasp to solve by bounded least squares.

    Residuals (each scaled to be ~1 at a tolerable error): target links onto the object (``gap``),
    optional attraction of target links to object points, hand–object penetration beyond
    ``allowed_penetration``, hand–obstacle (table, fixtures, non-target object geoms) and hand–hand
    distances below ``clearance`` / ``self_clearance``, and a regulariser pulling the fingers to
    ``natural`` (and the wrist to ``initial``).

    Attributes:
        body: object body the grasp is expressed in (the hand rides with it).
        object_qpos: (n_o,) object configuration at which the grasp is solved.
        initial: (22,) initial guess (wrist in world, fingers).
        targets: the links to bring into contact.
        target_geoms: object geom names the hand may touch (None: every colliding object geom of
            ``body`` and its descendants, e.g. the stapler's base and arm); other geoms are obstacles.
        natural: (16,) natural finger pose of the regulariser (None: ``initial``'s fingers).
        natural_weight: per rad of finger deviation.
        wrist_weight: per rad of wrist hinge deviation from ``initial`` (keeps the hand's orientation).
        wrist_position_weight: per cm of wrist slide deviation from ``initial``.
        allowed_penetration: hand–object penetration (m) tolerated before the penalty starts.
        clearance: distance (m) the hand keeps from obstacles.
        self_clearance: distance (m) between hand links (MuJoCo's own self-collision filtering).
        max_nfev: budget of residual evaluations.
    """

    body: str
    object_qpos: np.ndarray
    initial: np.ndarray
    targets: tuple[ContactTarget, ...]
    target_geoms: tuple[str, ...] | None = None
    natural: np.ndarray | None = None
    natural_weight: float = 0.3
    wrist_weight: float = 0.0
    wrist_position_weight: float = 0.0
    allowed_penetration: float = 0.0008
    clearance: float = 0.002
    self_clearance: float = 0.0005
    max_nfev: int = 400


@dataclass(frozen=True)
class Grasp:
    """A solved grasp.

    Attributes:
        hand_qpos: (22,) hand configuration at ``object_qpos`` (world wrist).
        object_qpos: (n_o,) object configuration it was solved at.
        body: grasp body name; ``offset``: the hand root's pose in that body's frame.
        target_distance: (n_targets,) signed distance of each target link to the object (m).
        max_penetration: deepest hand–object penetration (m, >= 0).
        min_clearance: smallest hand–obstacle distance (m; negative = penetration).
        cost: final least-squares cost.
        evaluations: residual evaluations used by the solver.
    """

    hand_qpos: np.ndarray
    object_qpos: np.ndarray
    body: str
    offset: Pose
    target_distance: np.ndarray
    max_penetration: float
    min_clearance: float
    cost: float
    evaluations: int = 0

    @property
    def fingers(self) -> np.ndarray:
        """(16,) finger joint angles."""
        return self.hand_qpos[6:]


class _GraspResidual:
    """Residual vector of a :class:`GraspProblem` (fixed size, see there for the terms)."""

    _CONTACT_SCALE = 1e-3  # m per unit
    _TOWARD_SCALE = 1e-2
    _PENALTY_SCALE = 2e-4
    _TARGET_DISTMAX = 0.3
    _SMOOTH = 5e-5  # softplus width of the penalties (m): smooth residuals keep Gauss-Newton steps useful

    def __init__(self, kin: Kinematics, problem: GraspProblem) -> None:
        self.kin = kin
        self.problem = problem
        self.object_qpos = np.asarray(problem.object_qpos, float)
        body_geoms = kin.object_geoms_of(problem.body, subtree=True)
        if problem.target_geoms is None:
            self.allowed = body_geoms
        else:
            self.allowed = np.array([kin.geom_id(n) for n in problem.target_geoms], dtype=int)
        self.body = kin.body_id(problem.body)
        self.target_link = []
        target_pairs, target_index = [], []
        for i, t in enumerate(problem.targets):
            if t.link not in kin.link_names:
                raise SynthesisError(f"grasp target link {t.link!r} is not a hand link")
            link = kin.link_names.index(t.link)
            self.target_link.append(link)
            geoms = self.allowed if t.geoms is None else np.array([kin.geom_id(n) for n in t.geoms])
            target_pairs += [(kin.link_geoms[link], int(g)) for g in geoms]
            target_index += [i] * len(geoms)
        self.target_pairs = np.asarray(target_pairs, dtype=int).reshape(-1, 2)
        order = np.argsort(np.asarray(target_index), kind="stable")
        self.target_pairs = self.target_pairs[order]
        self.target_start = np.searchsorted(np.asarray(target_index)[order], np.arange(len(problem.targets)))
        self.toward = [
            (k, np.asarray(t.toward, float), t.toward_weight)
            for k, t in enumerate(problem.targets)
            if t.toward is not None
        ]
        self.natural = np.asarray(
            problem.initial[6:] if problem.natural is None else problem.natural, dtype=float
        )
        self.is_allowed = np.zeros(kin.model.ngeom, bool)
        self.is_allowed[self.allowed] = True
        self.is_obstacle = np.zeros(kin.model.ngeom, bool)
        self.is_obstacle[kin.env_geoms] = True
        self.is_obstacle[kin.object_geoms] = True
        self.is_obstacle[self.allowed] = False
        self.margin = max(problem.clearance, problem.self_clearance) + 0.002
        self.num_links = len(kin.link_names)
        hand = kin.link_geoms
        others = np.flatnonzero(self.is_allowed | self.is_obstacle)
        self.pairs = np.concatenate([kin.collision_pairs(hand, others), kin.collision_pairs(hand, hand)])
        second = self.pairs[:, 1]
        self.pair_kind = np.where(
            kin.link_of_geom[second] >= 0, 2, np.where(self.is_allowed[second], 0, 1)
        )  # 0: hand-object, 1: hand-obstacle, 2: hand-hand

    def state(self, x: np.ndarray) -> None:
        self.kin.set(x, self.object_qpos)

    def target_distances(self) -> np.ndarray:
        """(n_targets,) signed distance of each target link to its nearest target geom."""
        dist = self.kin.pair_distances(self.target_pairs, self._TARGET_DISTMAX)
        return np.minimum.reduceat(dist, self.target_start)

    def penalties(self) -> tuple[np.ndarray, float, float]:
        """(n_pairs,) penalties (one per geom pair), max hand-object penetration, min obstacle distance."""
        p = self.problem
        dist = self.kin.pair_distances(self.pairs, self.margin)
        kind = self.pair_kind
        limit = np.where(
            kind == 0, -p.allowed_penetration, np.where(kind == 1, p.clearance, p.self_clearance)
        )
        pen = self._SMOOTH * np.logaddexp(0.0, (limit - dist) / self._SMOOTH)
        obj, obst = dist[kind == 0], dist[kind == 1]
        max_pen = float(max(0.0, -obj.min())) if obj.size else 0.0
        min_clear = float(obst.min()) if obst.size and obst.min() < self.margin else np.inf
        return pen / self._PENALTY_SCALE, max_pen, min_clear

    def __call__(self, x: np.ndarray) -> np.ndarray:
        p = self.problem
        self.state(x)
        parts = []
        dist = self.target_distances()
        weights = np.array([t.weight for t in p.targets])
        gaps = np.array([t.gap for t in p.targets])
        parts.append(weights * (dist - gaps) / self._CONTACT_SCALE)
        if self.toward:
            d = self.kin.data
            pos, mat = d.xpos[self.body], d.xmat[self.body].reshape(3, 3)
            for k, point, weight in self.toward:
                centre = d.geom_xpos[self.kin.link_geoms[self.target_link[k]]]
                parts.append(weight * (centre - pos - mat @ point) / self._TOWARD_SCALE)
        parts.append(self.penalties()[0])
        parts.append(p.natural_weight * (x[6:] - self.natural))
        if p.wrist_weight > 0:
            parts.append(p.wrist_weight * (x[3:6] - p.initial[3:6]))
        if p.wrist_position_weight > 0:
            parts.append(p.wrist_position_weight * (x[:3] - p.initial[:3]) / self._TOWARD_SCALE)
        return np.concatenate(parts)


def solve_grasp(kin: Kinematics, problem: GraspProblem, ranges: np.ndarray) -> Grasp:
    """Solve a grasp by bounded least squares over the 22 hand DOFs.

    Args:
        kin: kinematics of the scene.
        problem: the grasp problem.
        ranges: (22, 2) joint limits (the bounds).

    Returns:
        The grasp (its offset expressed in the frame of ``problem.body``).
    """
    lo, hi = np.asarray(ranges, float).T
    span = hi - lo
    x0 = np.clip(np.asarray(problem.initial, float), lo + 1e-6 * span, hi - 1e-6 * span)
    fun = _GraspResidual(kin, problem)
    x_scale = np.concatenate([np.full(3, 0.02), np.full(3, 0.2), np.full(16, 0.3)])
    sol = least_squares(
        fun,
        x0,
        bounds=(lo, hi),
        x_scale=x_scale,
        diff_step=1e-6,
        max_nfev=problem.max_nfev,
        method="trf",
    )
    x = sol.x
    fun.state(x)
    dist = fun.target_distances()
    _, max_pen, min_clear = fun.penalties()
    root = kin.root_pose()
    body = kin.body_pose(fun.body)
    return Grasp(
        hand_qpos=x.copy(),
        object_qpos=fun.object_qpos.copy(),
        body=problem.body,
        offset=body.inv() * root,
        target_distance=dist,
        max_penetration=float(max_pen),
        min_clearance=float(min_clear),
        cost=float(sol.cost),
        evaluations=int(sol.nfev),
    )


_FLEXION = np.array([1, 2, 3, 5, 6, 7, 9, 10, 11, 14, 15])
"""Finger-vector indices of the flexion joints (1-3 of each long finger, 2-3 of the thumb)."""


def solve_preshape(
    kin: Kinematics,
    problem: GraspProblem,
    grasp: Grasp,
    approach_offset: np.ndarray,
    finger_ranges: np.ndarray,
    initial: np.ndarray | None = None,
    standoff: float = 0.008,
    approach_steps: int = 4,
    close_steps: int = 6,
    regulariser: float = 0.05,
    max_nfev: int = 200,
) -> np.ndarray:
    """Open fingers for the approach to a grasp, such that approaching and closing are collision-free.

    Bounded least squares over the 16 finger joints ``x``:

    * approach: with the wrist at the grasp pose shifted by ``k / (approach_steps - 1) *
      approach_offset``, every finger link keeps ``standoff`` from the object;
    * close: along the straight joint-space path from ``x`` to the grasp's fingers (sampled at
      ``close_steps`` interior points, wrist at the grasp pose) no finger link penetrates the object by
      more than ``problem.allowed_penetration``;
    * everywhere: ``problem.clearance`` from obstacles and ``problem.self_clearance`` between links;
    * a small regulariser keeps ``x`` close to the grasp (a short close).

    Args:
        kin: kinematics of the scene.
        problem: the grasp problem (object configuration, obstacles, clearances).
        grasp: the solved grasp.
        approach_offset: (3,) world offset of the pre-grasp wrist from the grasp wrist.
        finger_ranges: (16, 2) joint limits.
        initial: (16,) initial guess (default: the grasp's fingers).
        standoff: distance (m) of every finger link from the object while approaching.
        approach_steps: wrist poses sampled along the approach.
        close_steps: interior points sampled along the close.
        regulariser: weight per rad of deviation from the grasp fingers.
        max_nfev: budget of residual evaluations.

    Returns:
        (16,) finger joint angles.
    """
    res = _GraspResidual(kin, problem)
    kin.set(grasp.hand_qpos, res.object_qpos)
    wrist = kin.root_pose()
    wrists = [
        kin.wrist_qpos(
            wrist.translated(k / max(approach_steps - 1, 1) * approach_offset), grasp.hand_qpos[:6]
        )
        for k in range(approach_steps)
    ]
    # The palm does not move with the fingers: leave its pairs out.
    moving = res.pairs[:, 0] != kin.link_geoms[kin.link_names.index("palm")]
    pairs, kind = res.pairs[moving], res.pair_kind[moving]
    obstacle, selfc = problem.clearance, problem.self_clearance
    approach_limit = np.where(kind == 0, standoff, np.where(kind == 1, obstacle, selfc))
    close_limit = np.where(kind == 0, -problem.allowed_penetration, np.where(kind == 1, obstacle, selfc))
    margin = max(standoff, problem.clearance) + 0.002
    fractions = np.arange(1, close_steps + 1) / (close_steps + 1)
    smooth = _GraspResidual._SMOOTH

    def fun(x: np.ndarray) -> np.ndarray:
        parts = []
        for w in wrists:
            kin.set(np.concatenate([w, x]), res.object_qpos)
            parts.append(approach_limit - kin.pair_distances(pairs, margin))
        for f in fractions:
            kin.set(np.concatenate([wrists[0], (1.0 - f) * x + f * grasp.fingers]), res.object_qpos)
            parts.append(close_limit - kin.pair_distances(pairs, margin))
        pen = smooth * np.logaddexp(0.0, np.concatenate(parts) / smooth)
        return np.concatenate([pen / 1e-3, regulariser * (x - grasp.fingers)])

    lo, hi = np.asarray(finger_ranges, float).T
    span = hi - lo
    x0 = grasp.fingers if initial is None else np.asarray(initial, float)
    x0 = np.clip(x0, lo + 1e-6 * span, hi - 1e-6 * span)
    sol = least_squares(
        fun, x0, bounds=(lo, hi), x_scale=0.3, diff_step=1e-6, max_nfev=max_nfev, method="trf"
    )
    return sol.x.copy()


@dataclass(frozen=True)
class GraspSchedule:
    """Grasps solved at several values of one object coordinate, interpolated linearly between them
    (offset position linearly, offset rotation by slerp, fingers linearly).

    Attributes:
        grasps: the grasps (all in the frame of the same body).
        column: index into ``q_o`` of the coordinate (None: a single grasp).
        values: (K,) the coordinate of each grasp, strictly increasing.
        initial: index of the grasp the hand closes into (at the object's initial configuration).
    """

    grasps: tuple[Grasp, ...]
    column: int | None = None
    values: np.ndarray = field(default_factory=lambda: np.zeros(1))
    initial: int = 0

    def at(self, object_qpos: np.ndarray) -> tuple[Pose, np.ndarray]:
        """Offset of the hand root in the grasp body's frame and (16,) fingers at ``object_qpos``."""
        if self.column is None or len(self.grasps) == 1:
            g = self.grasps[0]
            return g.offset, g.fingers.copy()
        v = float(np.clip(object_qpos[self.column], self.values[0], self.values[-1]))
        i = int(np.clip(np.searchsorted(self.values, v, side="right") - 1, 0, len(self.values) - 2))
        s = (v - self.values[i]) / (self.values[i + 1] - self.values[i])
        a, b = self.grasps[i], self.grasps[i + 1]
        return a.offset.interpolate(b.offset, s), (1.0 - s) * a.fingers + s * b.fingers

    @property
    def first(self) -> Grasp:
        """The grasp at the object's configuration when the hand closes."""
        return self.grasps[self.initial]


# ------------------------------------------------------------------------------------------ phases
@dataclass
class _Context:
    """What a phase needs: the scene's kinematics, the grasp and the state where the phase starts."""

    kin: Kinematics
    task: Task
    body: int
    schedule: GraspSchedule
    home: np.ndarray  # (22,)
    preshape: np.ndarray  # (16,)
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

    def sample(self, s: float, ctx: _Context) -> tuple[Pose, np.ndarray, np.ndarray]:
        """Root pose, (16,) fingers and (n_o,) object configuration at progress ``s``."""
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
        qo = interpolate_object_qpos(ctx.task, ctx.object_qpos, target, float(min_jerk(s)))
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


# ---------------------------------------------------------------------------------------- contacts
def summarise_contacts(
    kin: Kinematics, hand_qpos: np.ndarray, object_qpos: np.ndarray, threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-frame, per-link contact summary of a kinematic motion.

    A link is active in a frame when its collision geom lies within ``threshold`` of an object geom
    (signed distance, ``mj_geomDistance``). Its link point is the mean of the link-side points of
    MuJoCo's contacts (collision with a margin, so a flat patch yields several points) between the
    link and its nearest object geom, in the link body frame; its object point is the mean of the
    object-side points, in the frame of the object body owning that geom. When the collision yields
    no contact for the pair, the nearest points of the distance query are used. Inactive frames repeat
    the points of the nearest active frame of the link (zeros for a link never in contact), so the
    curves stay continuous.

    Args:
        kin: kinematics of the scene.
        hand_qpos: (T, 22) hand configurations.
        object_qpos: (T, n_o) object configurations.
        threshold: contact distance (m).

    Returns:
        ``active (T, L) bool``, ``link_point (T, L, 3)``, ``object_point (T, L, 3)``,
        ``object_body (T, L) int``.
    """
    num_t, num_l = len(hand_qpos), len(kin.link_bodies)
    active = np.zeros((num_t, num_l), bool)
    link_pt = np.zeros((num_t, num_l, 3))
    obj_pt = np.zeros((num_t, num_l, 3))
    obj_body = np.zeros((num_t, num_l), dtype=np.int64)
    pairs = kin.collision_pairs(kin.link_geoms, kin.object_geoms)
    pair_link = kin.link_of_geom[pairs[:, 0]]
    distmax = 2.0 * threshold + 1e-3
    for t in range(num_t):
        kin.set(hand_qpos[t], object_qpos[t])
        dist = kin.pair_distances(pairs, distmax)
        close = dist <= threshold
        if not close.any():
            continue
        con = kin.contacts(threshold + 5e-4)
        for link in np.unique(pair_link[close]):
            mine = np.flatnonzero(pair_link == link)
            g_link, g_obj = pairs[mine[np.argmin(dist[mine])]]
            hit_ab = (con.geom1 == g_link) & (con.geom2 == g_obj)
            hit_ba = (con.geom1 == g_obj) & (con.geom2 == g_link)
            if hit_ab.any() or hit_ba.any():
                p_link = np.concatenate([con.point1[hit_ab], con.point2[hit_ba]]).mean(axis=0)
                p_obj = np.concatenate([con.point2[hit_ab], con.point1[hit_ba]]).mean(axis=0)
            else:
                _, fromto = kin.distance(int(g_link), int(g_obj), distmax)
                p_link, p_obj = fromto[:3], fromto[3:]
            body = int(kin.object_of_geom[g_obj])
            active[t, link] = True
            link_pt[t, link] = kin.body_pose(kin.link_bodies[link]).inv().apply(p_link)
            obj_pt[t, link] = kin.body_pose(kin.object_bodies[body]).inv().apply(p_obj)
            obj_body[t, link] = body
    # Fill inactive frames from the nearest active frame of the same link.
    frames = np.arange(num_t)
    for link in range(num_l):
        on = np.flatnonzero(active[:, link])
        if on.size == 0:
            continue
        pos = np.clip(np.searchsorted(on, frames), 0, on.size - 1)
        prev = on[np.clip(pos - 1, 0, on.size - 1)]
        nxt = on[pos]
        nearest = np.where(np.abs(prev - frames) <= np.abs(nxt - frames), prev, nxt)
        off = ~active[:, link]
        link_pt[off, link] = link_pt[nearest[off], link]
        obj_pt[off, link] = obj_pt[nearest[off], link]
        obj_body[off, link] = obj_body[nearest[off], link]
    return active, link_pt, obj_pt, obj_body


def suggest_num_control_points(
    time: np.ndarray, hand_qpos: np.ndarray, tol_slide: float = 0.003, tol_angle: float = 0.05
) -> int:
    """Smallest M (cubic, clamped, uniform) fitting every hand curve within tolerance.

    Args:
        time: (T,) seconds.
        hand_qpos: (T, 22) curves.
        tol_slide: max error of the wrist slides (m).
        tol_angle: max error of the angles (rad).

    Returns:
        M, at most ``T // 2``.
    """
    tol = np.concatenate([np.full(3, tol_slide), np.full(hand_qpos.shape[1] - 3, tol_angle)])
    upper = max(4, len(time) // 2)
    for m in range(4, upper + 1):
        spline = UniformBSpline(m, (float(time[0]), float(time[-1])))
        fit = spline.evaluate(spline.fit(time, hand_qpos), time)
        if np.all(np.abs(fit - hand_qpos).max(axis=0) <= tol):
            return m
    return upper


# ----------------------------------------------------------------------------------- demonstration
class Demonstration:
    """Base class of a task's synthetic demonstration.

    Subclasses define :meth:`grasp_problem` (the grasp at the object's initial configuration),
    :meth:`phases` and optionally :meth:`regrasp_values` (re-solve the grasp along one object
    coordinate). :meth:`synthesize` turns them into a :class:`~contactmpc.reference.Reference` (gates
    are applied by :func:`contactmpc.reference.demos.synthesize`).

    Attributes:
        rate: samples per second of demonstration time.
        contact_threshold: link–object distance (m) under which a contact is expected.
        approach_offset: (3,) world offset of the pre-grasp pose from the grasp pose (m); the hand
            also backs off along it (in the grasp body's frame) in :class:`Retreat`.
        open_fraction: how far the pre-shape's initial guess opens the grasp's flexion (0 to 1).
        preshape_standoff: distance (m) of the open fingers from the object during the approach.
        regrasp_weight: regulariser of a regrasp towards its neighbour (per rad, per cm).
        regrasp_tolerance: extra penetration (m) between two regrasps that triggers a midpoint one.
        regrasp_refinements: rounds of midpoint regrasps.
    """

    rate: float = 50.0
    contact_threshold: float = 0.001
    approach_offset: tuple[float, float, float] = (0.0, 0.0, 0.06)
    open_fraction: float = 0.5
    preshape_standoff: float = 0.008
    regrasp_weight: float = 10.0
    regrasp_tolerance: float = 0.0003
    regrasp_refinements: int = 3

    def grasp_problem(self, scene: Scene, kin: Kinematics) -> GraspProblem:
        """The grasp at the object's initial configuration."""
        raise NotImplementedError

    def regrasp_values(self, scene: Scene) -> tuple[int, tuple[float, ...], np.ndarray | None] | None:
        """Re-solve the grasp along one object coordinate: ``(column of q_o, values, object_qpos)``.

        ``values[0]`` is the coordinate's value in the initial grasp; each further value is solved
        warm-started from the previous, at ``object_qpos`` (None: the initial grasp's) with the
        column set to the value, e.g. with the object lifted clear of the table. None: one grasp.
        """
        return None

    def phases(self, scene: Scene) -> list[Phase]:
        """The phases, in order."""
        raise NotImplementedError

    def preshape(self, scene: Scene, kin: Kinematics, problem: GraspProblem, grasp: Grasp) -> np.ndarray:
        """(16,) open fingers for approach and release: :func:`solve_preshape` started from the grasp's
        fingers with their flexion opened by ``open_fraction``."""
        fingers = grasp.fingers.copy()
        fingers[_FLEXION] *= 1.0 - self.open_fraction
        return solve_preshape(
            kin,
            problem,
            grasp,
            np.asarray(self.approach_offset, float),
            scene.hand.finger_ranges,
            initial=fingers,
            standoff=self.preshape_standoff,
        )

    # ---------------------------------------------------------------------------------------
    def solve(self, scene: Scene, kin: Kinematics, problem: GraspProblem) -> GraspSchedule:
        """Solve the grasp, and the regrasps along :meth:`regrasp_values`.

        Each regrasp is warm-started from the previous one (riding with the body) and regularised
        towards it. Then every interval whose interpolated hand penetrates the object or itself by
        more than ``regrasp_tolerance`` beyond its end grasps is split by one more regrasp at its
        midpoint (up to ``regrasp_refinements`` rounds).
        """
        ranges = scene.hand.joint_ranges
        first = solve_grasp(kin, problem, ranges)
        regrasp = self.regrasp_values(scene)
        if regrasp is None:
            return GraspSchedule((first,))
        column, values, where = regrasp
        base = np.asarray(first.object_qpos if where is None else where, float)
        body = kin.body_id(problem.body)
        check = _GraspResidual(kin, problem)
        inside = check.pair_kind != 1  # hand-object and hand-hand pairs

        def at(value: float) -> np.ndarray:
            qo = base.copy()
            qo[column] = value
            return qo

        def hand(offset: Pose, fingers: np.ndarray, qo: np.ndarray, reference: np.ndarray) -> np.ndarray:
            kin.set(first.hand_qpos, qo)
            wrist = kin.body_pose(body) * offset
            return np.concatenate([kin.wrist_qpos(wrist, reference[:6]), fingers])

        def regrasp(qo: np.ndarray, init: np.ndarray) -> Grasp:
            step = dataclasses.replace(
                problem,
                object_qpos=qo,
                initial=init,
                natural=init[6:],
                natural_weight=self.regrasp_weight,
                wrist_weight=self.regrasp_weight,
                wrist_position_weight=self.regrasp_weight,
            )
            return solve_grasp(kin, step, ranges)

        def schedule(chain: list[Grasp]) -> GraspSchedule:
            order = np.argsort(np.asarray([g.object_qpos[column] for g in chain]), kind="stable")
            return GraspSchedule(
                tuple(chain[i] for i in order),
                column=column,
                values=np.asarray([chain[i].object_qpos[column] for i in order], float),
                initial=int(np.flatnonzero(order == 0)[0]),
            )

        chain = [first]
        for v in values[1:]:
            prev = chain[-1]
            chain.append(regrasp(at(v), hand(prev.offset, prev.fingers, at(v), prev.hand_qpos)))
        for _ in range(self.regrasp_refinements):
            sched = schedule(chain)
            grasps, added = sched.grasps, []
            for a, b in zip(grasps[:-1], grasps[1:], strict=True):
                va, vb = a.object_qpos[column], b.object_qpos[column]
                deepest = 0.0
                for f in (0.25, 0.5, 0.75):
                    qo = at((1 - f) * va + f * vb)
                    kin.set(hand(*sched.at(qo), qo, a.hand_qpos), qo)
                    dist = kin.pair_distances(check.pairs[inside], check.margin)
                    deepest = max(deepest, -float(dist.min()))
                if deepest - max(a.max_penetration, b.max_penetration) > self.regrasp_tolerance:
                    qo = at(0.5 * (va + vb))
                    added.append(regrasp(qo, hand(*sched.at(qo), qo, a.hand_qpos)))
            if not added:
                break
            chain += added
        return schedule(chain)

    def synthesize(self, scene: Scene) -> tuple[Reference, dict]:
        """Build the reference (without gates) and a dict of diagnostics (grasps, timings)."""
        kin = Kinematics(scene)
        task = scene.task
        problem = self.grasp_problem(scene, kin)
        schedule = self.solve(scene, kin, problem)
        first = schedule.first
        kin.set(task.hand_home, first.object_qpos)
        body_id = kin.body_id(first.body)
        body0 = kin.body_pose(body_id)
        initial_qo = task.initial_object_qpos(kin.model)
        preshape = self.preshape(scene, kin, problem, first)
        kin.set(task.hand_home, initial_qo)
        home_wrist = kin.root_pose()
        ctx = _Context(
            kin=kin,
            task=task,
            body=body_id,
            schedule=schedule,
            home=task.hand_home.copy(),
            preshape=preshape,
            approach_offset=body0.rot.inv().apply(np.asarray(self.approach_offset, float)),
            object_qpos=initial_qo,
            wrist=home_wrist,
            fingers=task.hand_home[6:].copy(),
        )
        phases = self.phases(scene)
        frames = [max(1, round(p.duration * self.rate)) for p in phases]
        num_t = sum(frames) + 1
        wrists: list[Pose] = []
        fingers = np.zeros((num_t, 16))
        objects = np.zeros((num_t, task.qo_dim))
        phase_meta, keyframes = [], [{"time": 0.0, "object_qpos": initial_qo.tolist()}]
        k = 0
        for i, (phase, n) in enumerate(zip(phases, frames, strict=True)):
            last = i == len(phases) - 1
            for j in range(n + 1 if last else n):
                w, f, qo = phase.sample(j / n, ctx)
                wrists.append(w)
                fingers[k], objects[k] = f, qo
                k += 1
            w, f, qo = phase.sample(1.0, ctx)
            start = (k - (n + 1 if last else n)) / self.rate
            phase_meta.append(
                {"name": phase.name, "start": start, "end": start + n / self.rate, "holding": phase.holding}
            )
            keyframes.append({"time": start + n / self.rate, "object_qpos": np.asarray(qo).tolist()})
            ctx.wrist, ctx.fingers, ctx.object_qpos = w, np.asarray(f, float), np.asarray(qo, float)
        hand = np.zeros((num_t, 22))
        prev = task.hand_home[:6]
        for t, w in enumerate(wrists):
            hand[t, :6] = kin.wrist_qpos(w, prev)
            prev = hand[t, :6]
        hand[:, 6:] = fingers
        time = np.arange(num_t) / self.rate
        active, link_pt, obj_pt, obj_body = summarise_contacts(kin, hand, objects, self.contact_threshold)
        meta = {
            "source": "synthetic",
            "generator": f"{type(self).__module__}.{type(self).__name__}",
            "version": SYNTHESIS_VERSION,
            "units": "m, rad, s",
            "time_scale": task.time_scale,
            "sample_rate": self.rate,
            "object_quat_index": object_quat_index(task),
            "num_control_points": suggest_num_control_points(time, hand),
            "contact_threshold": self.contact_threshold,
            "grasp_body": first.body,
            "phases": phase_meta,
            "keyframes": keyframes,
        }
        ref = Reference(
            time=time,
            hand_qpos=hand,
            object_qpos=objects,
            contact_active=active,
            contact_link_point=link_pt,
            contact_object_point=obj_pt,
            contact_object_body=obj_body,
            link_names=np.array(scene.hand.link_names),
            joint_names=np.array(scene.hand.joint_names),
            object_bodies=np.array(task.object_bodies),
            task=task.name,
            meta=meta,
        )
        info = {
            "grasps": [
                {
                    "object_qpos": g.object_qpos.tolist(),
                    "target_distance_mm": (1e3 * g.target_distance).round(2).tolist(),
                    "max_penetration_mm": round(1e3 * g.max_penetration, 3),
                    "min_clearance_mm": round(1e3 * g.min_clearance, 3)
                    if np.isfinite(g.min_clearance)
                    else None,
                    "cost": g.cost,
                }
                for g in schedule.grasps
            ]
        }
        return ref, info


def synthesize(scene: Scene, *, gates: bool = True) -> Reference:
    """Synthesise, check and return the reference motion of ``scene.task``.

    Deterministic: the same scene gives bit-identical arrays.

    Args:
        scene: the scene (hand + task); the task's ``name`` selects the demo in
            :data:`contactmpc.reference.demos.DEMOS`.
        gates: run the quality gates (:func:`~contactmpc.reference.gates.check_gates`) before returning.

    Returns:
        The validated reference; ``meta["gates"]`` holds the gate report and ``meta["grasps"]`` the
        solver's diagnostics of each grasp.

    Raises:
        SynthesisError: no demo for the task, or a gate failed (one line naming the gate and value).
    """
    # demos and gates build on this module: import them here, not at the top.
    from contactmpc.reference.demos import DEMOS
    from contactmpc.reference.gates import check_gates, gate_report

    demo = DEMOS.get(scene.task.name)
    if demo is None:
        known = sorted(DEMOS)
        raise SynthesisError(f"no synthetic demonstration for task {scene.task.name!r} (known: {known})")
    ref, info = demo.synthesize(scene)
    ref.meta["grasps"] = info["grasps"]
    ref.validate(scene.hand.joint_names, scene.hand.link_names)
    if gates:
        report = gate_report(scene, ref)
        ref.meta["gates"] = report
        check_gates(report, task=scene.task.name)
    return ref
