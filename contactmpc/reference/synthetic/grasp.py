r"""Grasps: a whole-hand grasp solved once by bounded least squares, open fingers for the approach,
and a schedule of grasps re-solved along one object coordinate.

* A **grasp problem** (:class:`GraspProblem`) is solved once, in the frame of one object body, by
  bounded least squares (``scipy.optimize.least_squares``, bounds = the hand's joint ranges) over the
  hand's DOFs: designated links onto the object (signed distances from ``mj_geomDistance``), no
  penetration of the object, the fixtures or the hand itself (every geom pair MuJoCo's own filtering
  would test, as a smooth softplus penalty), and a regulariser towards a natural finger pose
  (:func:`solve_grasp`). The solved :class:`Grasp` keeps the grasp offset of the hand root,
  :math:`G = T_b(q_o^*)^{-1} T_r^*` (:math:`T_b` the pose of the grasp body, solved at :math:`q_o^*`).
* Open fingers for approach and release are solved so that the approach along ``approach_offset`` and
  the straight joint-space close into the grasp are collision-free (:func:`solve_preshape`).

A grasp may also be re-solved at several values of one object articulation (the stapler's press);
:class:`GraspSchedule` then interpolates offset and fingers between them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from contactmpc.reference.synthetic.kinematics import Kinematics, Pose, SynthesisError

__all__ = [
    "ContactTarget",
    "Grasp",
    "GraspProblem",
    "GraspSchedule",
    "solve_grasp",
    "solve_preshape",
]


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
        initial: (J,) initial guess (wrist in world, fingers).
        targets: the links to bring into contact.
        target_geoms: object geom names the hand may touch (None: every colliding object geom of
            ``body`` and its descendants, e.g. the stapler's base and arm); other geoms are obstacles.
        natural: (num_fingers,) natural finger pose of the regulariser (None: ``initial``'s fingers).
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
        hand_qpos: (J,) hand configuration at ``object_qpos`` (world wrist).
        object_qpos: (n_o,) object configuration it was solved at.
        num_root: root (wrist) DOFs at the start of ``hand_qpos``; the fingers follow.
        body: grasp body name; ``offset``: the hand root's pose in that body's frame.
        target_distance: (n_targets,) signed distance of each target link to the object (m).
        max_penetration: deepest hand–object penetration (m, >= 0).
        min_clearance: smallest hand–obstacle distance (m; negative = penetration).
        cost: final least-squares cost.
        evaluations: residual evaluations used by the solver.
    """

    hand_qpos: np.ndarray
    object_qpos: np.ndarray
    num_root: int
    body: str
    offset: Pose
    target_distance: np.ndarray
    max_penetration: float
    min_clearance: float
    cost: float
    evaluations: int = 0

    @property
    def fingers(self) -> np.ndarray:
        """(num_fingers,) finger joint angles."""
        return self.hand_qpos[self.num_root :]


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
            problem.initial[kin.num_root :] if problem.natural is None else problem.natural, dtype=float
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
        n = self.kin.num_root  # wrist: slides [:3], hinges [3:n]; fingers [n:]
        parts.append(p.natural_weight * (x[n:] - self.natural))
        if p.wrist_weight > 0:
            parts.append(p.wrist_weight * (x[3:n] - p.initial[3:n]))
        if p.wrist_position_weight > 0:
            parts.append(p.wrist_position_weight * (x[:3] - p.initial[:3]) / self._TOWARD_SCALE)
        return np.concatenate(parts)


def solve_grasp(kin: Kinematics, problem: GraspProblem, ranges: np.ndarray) -> Grasp:
    """Solve a grasp by bounded least squares over the hand's DOFs.

    Args:
        kin: kinematics of the scene.
        problem: the grasp problem.
        ranges: (J, 2) joint limits (the bounds).

    Returns:
        The grasp (its offset expressed in the frame of ``problem.body``).
    """
    lo, hi = np.asarray(ranges, float).T
    span = hi - lo
    x0 = np.clip(np.asarray(problem.initial, float), lo + 1e-6 * span, hi - 1e-6 * span)
    fun = _GraspResidual(kin, problem)
    n = kin.num_root  # wrist slides (m), wrist hinges (rad), fingers
    x_scale = np.concatenate([np.full(3, 0.02), np.full(n - 3, 0.2), np.full(len(x0) - n, 0.3)])
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
        num_root=kin.num_root,
        body=problem.body,
        offset=body.inv() * root,
        target_distance=dist,
        max_penetration=float(max_pen),
        min_clearance=float(min_clear),
        cost=float(sol.cost),
        evaluations=int(sol.nfev),
    )


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

    Bounded least squares over the finger joints ``x``:

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
        finger_ranges: (num_fingers, 2) joint limits.
        initial: (num_fingers,) initial guess (default: the grasp's fingers).
        standoff: distance (m) of every finger link from the object while approaching.
        approach_steps: wrist poses sampled along the approach.
        close_steps: interior points sampled along the close.
        regulariser: weight per rad of deviation from the grasp fingers.
        max_nfev: budget of residual evaluations.

    Returns:
        (num_fingers,) finger joint angles.
    """
    res = _GraspResidual(kin, problem)
    kin.set(grasp.hand_qpos, res.object_qpos)
    wrist = kin.root_pose()
    wrists = [
        kin.wrist_qpos(
            wrist.translated(k / max(approach_steps - 1, 1) * approach_offset),
            grasp.hand_qpos[: kin.num_root],
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
        """Offset of the hand root in the grasp body's frame and the fingers at ``object_qpos``."""
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
