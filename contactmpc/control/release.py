"""The release schedule: what the hand does where the reference lets go of the object (not the paper's).

The paper's method follows the reference to its end. Where the reference lets go (its last expected
contact comes before its end), a :class:`ReleaseSchedule` given to the sampler space
(``sampler.release``; ``None``: the paper's method) changes the nominal the planner samples around
after that last contact, and how:

- ``pause``: the nominal wrist waits at its pose of the last contact before it follows the reference's
  retreat (:func:`paused`), so the hand opens before it withdraws;
- ``hold``: the nominal wrist stands still from that long before the last contact (and the pause that
  much longer), so the hand does not move the object it is letting go of;
- ``open`` / ``open_to``: the nominal fingers open to the approach's pre-shape or the flat hand
  (:func:`opened`);
- ``backoff`` / ``backoff_window``: the nominal wrist backs off from the expected contacts
  (:func:`backed_off`);
- ``reset``: the planner's committed control points go back to that nominal at the last contact;
- ``noise``: the sampling noise after the last contact, as a fraction of the space's;
- ``window``: the wrist is also sampled around the last contact;
- ``retract``: the hand lets go by a law of its measured state instead of the plans
  (:func:`retraction`): the grip's squeeze dropped, each contact point moved off along its normal (and
  with ``retract_away`` the wrist moved off the object);
- ``articulated_only``: the hold and the retraction only on an object that moves on joints.

Every option at its default leaves the paper's method as it is.
"""

from __future__ import annotations

import copy
from typing import Annotated

import mujoco
import numpy as np

from contactmpc.validate import ConfigError, Ge, Gt, OneOf, checked


def time_window(name: str, window: tuple[float, float] | None) -> tuple[float, float] | None:
    """``(start, end)`` as floats, or ``None``; refused unless start < end (``name`` names the key)."""
    if window is None:
        return None
    if len(window) != 2 or not window[0] < window[1]:
        raise ConfigError(f"{name} must be (start, end) with start < end, got {window}")
    return float(window[0]), float(window[1])


def paused(times: np.ndarray, curves: np.ndarray, at: float, pause: float) -> np.ndarray:
    """Curves that stop at time ``at`` for ``pause`` seconds and then go on as before, that much later.

    Args:
        times: (T,) increasing sample times (s).
        curves: (T, k) values at those times.
        at: when to stop (s).
        pause: how long (s).

    Returns:
        (T, k): ``curves(t)`` before ``at``, ``curves(at)`` on ``[at, at + pause]``, ``curves(t - pause)``
        after (linear interpolation between samples); the last ``pause`` seconds of the curves are cut.
    """
    times = np.asarray(times, float)
    source = np.where(times <= at, times, np.maximum(at, times - pause))
    return np.stack([np.interp(source, times, c) for c in np.asarray(curves, float).T], axis=-1)


def opened(
    times: np.ndarray, curves: np.ndarray, at: float, duration: float, target: np.ndarray | None = None
) -> np.ndarray:
    """Curves that leave their course at time ``at`` and go, linearly over ``duration`` seconds, to their
    first sample's values (or ``target``'s), and stay there.

    Args:
        times: (T,) increasing sample times (s).
        curves: (T, k) values at those times.
        at: when to leave (s).
        duration: how long the way back takes (s).
        target: (k,) where the curves go; ``None``: their first sample.

    Returns:
        (T, k) curves.
    """
    curves = np.asarray(curves, float)
    times = np.asarray(times, float)
    start = np.array([np.interp(at, times, c) for c in curves.T])
    goal = curves[0] if target is None else np.asarray(target, float)
    w = np.clip((times - at) / duration, 0.0, 1.0)[:, None]
    out = (1.0 - w) * start + w * goal
    return np.where((times > at)[:, None], out, curves)


def backed_off(
    times: np.ndarray, curves: np.ndarray, offset: np.ndarray, start: float, end: float
) -> np.ndarray:
    """Curves shifted by ``offset``, the shift growing linearly from 0 at ``start`` to all of it at
    ``end`` (s) and kept afterwards.

    Args:
        times: (T,) sample times (s).
        curves: (T, k) values at those times.
        offset: (k,) the full shift.
        start, end: when the shift begins and when it is complete (s), ``start < end``.

    Returns:
        (T, k) curves.
    """
    w = np.clip((np.asarray(times, float) - start) / (end - start), 0.0, 1.0)[:, None]
    return np.asarray(curves, float) + w * np.asarray(offset, float)


RETRACT_WAIT = 0.5  # s after the fingers' retraction before the wrist moves off (``retract``)
RETRACT_MOVE = 2.0  # s over which the wrist moves off the object (``retract``)


def has_free_body(model: mujoco.MjModel, index) -> bool:
    """Whether any of the object's bodies (``index.object_bodies``) hangs on a free joint."""
    for body in np.asarray(index.object_bodies, int):
        first, count = model.body_jntadr[body], model.body_jntnum[body]
        if count and (model.jnt_type[first : first + count] == mujoco.mjtJoint.mjJNT_FREE).any():
            return True
    return False


def retraction(
    model: mujoco.MjModel, data: mujoco.MjData, index, distance: float, margin: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How the hand lets go of the object it touches in ``data`` (``mj_forward`` done): where it is, how
    its fingers retract and which way its wrist leaves.

    Each hand-object contact point is to move ``distance`` metres away from the object along the contact
    normal; the finger joints' change that does it for all of them at once is the damped least-squares
    solution through the contact points' Jacobians (the wrist still). The wrist's way off is from the
    object's (first) body toward the hand's root; on an object without a free body (an articulation)
    with its joints' directions of motion at that body taken out, so the hand that moves off does not
    drag the object along its joint.

    Args:
        model, data: the planning model and a state of it.
        index: the scene's :class:`~contactmpc.scene.SceneIndex`.
        distance: metres each contact point retracts.
        margin: metres: a hand geom this close to an object geom without touching it counts as a
            contact too, at its nearest point, along the line to the object's (``mj_geomDistance``); a
            link resting on the object at a hair's breadth in this model may touch it in another (the
            plant's). 0: the model's contacts only.

    Returns:
        ``(q, dq, away)``: (J,) the hand's measured joint configuration; (J,) the change of its targets
        that retracts the fingers (zero on the wrist); (3,) the unit direction the wrist leaves along.
    """
    q = data.qpos[index.hand_qpos].copy()
    fingers = np.asarray(index.hand_dof)[6:]
    on_object = np.asarray(index.object_body_mask, bool)
    points = []  # (hand body, point, unit normal into the object)
    touching = set()
    for i in range(data.ncon):
        c = data.contact[i]
        b1, b2 = int(model.geom_bodyid[c.geom1]), int(model.geom_bodyid[c.geom2])
        if on_object[b1] == on_object[b2]:
            continue
        touching.add((c.geom1, c.geom2) if on_object[b2] else (c.geom2, c.geom1))
        into_object = np.array(c.frame[:3]) * (1.0 if on_object[b2] else -1.0)  # frame: geom1 to geom2
        points.append((b1 if on_object[b2] else b2, np.array(c.pos), into_object))
    if margin > 0.0:
        points += _near(model, data, index, margin, touching)
    rows, rhs = [], []
    for hand_body, point, into_object in points:
        jacp = np.zeros((3, model.nv))
        mujoco.mj_jac(model, data, jacp, None, point, hand_body)
        rows.append(jacp[:, fingers])
        rhs.append(-distance * into_object)
    dq = np.zeros(len(q))
    if rows:
        J, b = np.vstack(rows), np.concatenate(rhs)
        dq[6:] = J.T @ np.linalg.solve(J @ J.T + 1e-4 * np.eye(len(b)), b)
    body = int(index.object_bodies[0])
    away = data.xpos[index.root_body] - data.xpos[body]
    if len(index.object_dof) and not (model.jnt_type[model.body_jntadr[body]] == mujoco.mjtJoint.mjJNT_FREE):
        jacp = np.zeros((3, model.nv))
        mujoco.mj_jac(model, data, jacp, None, data.xpos[body], body)
        motion = jacp[:, np.asarray(index.object_dof)]
        u, sigma, _ = np.linalg.svd(motion, full_matrices=False)
        basis = u[:, sigma > 1e-9]  # the directions the object's joints move its body along
        away = away - basis @ (basis.T @ away)
    norm = np.linalg.norm(away)
    return q, dq, (away / norm if norm > 1e-9 else np.zeros(3))


def _near(model: mujoco.MjModel, data: mujoco.MjData, index, margin: float, touching: set) -> list:
    """(:func:`retraction`'s ``margin``) ``(hand body, point, unit normal into the object)`` of each pair of
    a hand geom (the root body's subtree) and an object geom that may collide, not already in ``touching``
    (``(hand geom, object geom)`` pairs), whose surfaces are closer than ``margin`` but apart: the hand
    geom's nearest point and the direction to the object's."""
    on_object = np.asarray(index.object_body_mask, bool)
    body = model.geom_bodyid
    collides = (model.geom_contype | model.geom_conaffinity) > 0
    hand = np.flatnonzero(collides & (model.body_rootid[body] == model.body_rootid[index.root_body]))
    objects = np.flatnonzero(collides & on_object[body])
    out, fromto = [], np.zeros(6)
    for g in hand:
        for o in objects:
            if (g, o) in touching:
                continue
            if not (
                model.geom_contype[g] & model.geom_conaffinity[o]
                or model.geom_contype[o] & model.geom_conaffinity[g]
            ):
                continue
            dist = mujoco.mj_geomDistance(model, data, int(g), int(o), margin, fromto)
            gap = fromto[3:] - fromto[:3]
            if 0.0 <= dist < margin and np.linalg.norm(gap) > 1e-9:
                out.append((int(body[g]), fromto[:3].copy(), gap / np.linalg.norm(gap)))
    return out


class ReleaseSchedule:
    """What the sampler's nominal and noise do after the reference's last expected contact.

    Only where the reference lets go (its track ends without contact); a reference that ends held is
    planned as without a schedule. Every default is the paper's method.

    Args:
        pause: seconds (control time) the nominal wrist waits at its pose of the reference's last
            expected contact before it follows the reference's retreat (the rest of the retreat that
            much later), while the fingers open on the reference's schedule: open, then withdraw.
            0: the reference's wrist as it is.
        hold: seconds (control time) before the reference's last expected contact from which the
            nominal wrist already stands still: it waits at its pose ``hold`` seconds before the last
            contact for ``hold + pause`` seconds and then goes on as the reference's, that much later;
            with ``reset``, the committed wrist control points go to that nominal at that time (the
            fingers still at the last contact). Where the demonstration's hand slides along the object
            while it lets go (the paper doorknob's, about 1 cm/s along the slide in its last 2 s), a
            grip that does not slip would carry the object with it. 0: the wrist moves until the last
            contact.
        open: seconds (control time) over which the nominal fingers go, from the reference's pose at
            the last expected contact, to the open pose (``open_to``), and stay there; 0: the
            reference's fingers.
        open_to: the open pose: ``approach``, the reference's first pose (the open hand of the
            approach; on the paper apple it still encloses the object); ``flat``, every finger joint at
            0 clipped to its range (the Allegro's straight fingers, the thumb least opposed).
        backoff: metres the nominal wrist moves along the release direction (from the centroid of the
            expected contacts to the palm, at the reference's last expected contact: away from the
            object, given by the problem), growing over ``backoff_window`` and kept while the wrist
            follows the reference's retreat; 0: none.
        backoff_window: ``(start, end)`` seconds after the last expected contact over which the
            back-off grows.
        reset: at the first replan at or after the reference's last expected contact, the planner's
            committed control points whose support meets the rest of the trial go to the release
            nominal (with ``open`` / ``pause`` / ``backoff`` if set, else the reference's own): the
            drift that warm-started sampling accumulated during the task (the grip its samples walked
            into) is dropped, and the hand lets go as that nominal does. Until then the nominal is the
            reference's own (the refit of an opened or paused nominal moves it a little everywhere,
            ~1e-12 rad, which changes whole trials), so with ``reset`` alone a trial is the paper
            method's bit for bit before the last contact. ``False``: the committed control points
            carry on.
        noise: the sampling noise on the control points whose support lies after the reference's last
            expected contact, as a fraction of the space's. 0 holds the release nominal there (with
            ``reset``: the hand does what the release nominal does, a schedule rather than a search);
            1: the same noise as before the release.
        window: ``(start, end)`` seconds relative to the last expected contact: sample the wrist on the
            control points whose support meets that interval too (the hand may move around the object
            it lets go of); ``None``: only the space's ``root_window``. Without a ``root_window`` the
            wrist is sampled only there.
        blend: seconds over which ``reset`` takes the committed control points to the release nominal:
            each reset control point moves from where the plans left it toward the nominal by a weight
            that grows from 0 at the last expected contact to 1 ``blend`` seconds after it, at the
            point's Greville abscissa, so the grip the plans walked into eases into the opening instead
            of jumping to it (on the apple the jump rolls the object the hand just set down); 0 (the
            default): the nominal at once.
        retract: metres each finger's contact point moves off the object (needs ``reset``): from the
            first plan at or after the reference's last expected contact, the hand's targets no longer
            come from the plans but from the state that plan starts from (:func:`retraction`): every
            joint at its measured angle (the squeeze of the grip dropped, the wrist held), each finger
            in contact retracting its contact point this far along the contact normal over
            ``retract_time`` (and, with ``retract_away``, :data:`RETRACT_WAIT` later, the wrist moving
            off the object over :data:`RETRACT_MOVE`). Where the object has nothing to stop it (the authors'
            frictionless doorknob slide), fingers that open on a schedule or a search pinch and drag it
            as they go. 0 (the default): the plans' release.
        retract_time: seconds over which the fingers retract.
        retract_away: metres the wrist moves off the object after the fingers' retraction; 0 (the
            default): the wrist stays where it was measured (a wrist that moves off can sweep a finger
            still hooked behind the object across it).
        retract_again: at every plan after the retraction began, the hand-object contacts found in that
            plan's state are retracted in turn, from the targets then (a finger that still rests on the
            object, or has come back onto it, is moved off too; with ``retract_away``, the wrist's move off
            starts again from there); ``False``: once, at the release.
        retract_margin: metres: a finger this close to the object counts as touching it, for the
            retraction and for ``retract_again`` (:func:`retraction`'s ``margin``): a link that rests on
            the object in the plant at a hair's breadth may be just apart in the planning model, where
            the contacts are read, and would be left there. 0 (the default): the planning model's
            contacts only.
        articulated_only: the wrist's ``hold`` and the ``retract`` options act only on an object without
            a free body, one that moves on joints (the paper doorknob's knob on its slide); a free object
            is let go as without them (:meth:`for_object`). On the authors' frictionless slide a knob
            let go moving never stops, so the hand is taken off it by a rule rather than by the plans; a
            free object set down on a table is held by the table, and the plans, pricing its pose,
            keep it upright while the fingers open, where a hand held still may leave a leaning object
            to fall against it. ``False`` (the default): on every object.
    """

    @checked
    def __init__(
        self,
        pause: Annotated[float, Ge(0)] = 0.0,
        hold: Annotated[float, Ge(0)] = 0.0,
        open: Annotated[float, Ge(0)] = 0.0,
        open_to: Annotated[str, OneOf("approach", "flat")] = "approach",
        backoff: Annotated[float, Ge(0)] = 0.0,
        backoff_window: tuple[float, float] = (0.5, 1.5),
        reset: bool = False,
        noise: Annotated[float, Ge(0)] = 1.0,
        window: tuple[float, float] | None = None,
        blend: Annotated[float, Ge(0)] = 0.0,
        retract: Annotated[float, Ge(0)] = 0.0,
        retract_time: Annotated[float, Gt(0)] = 1.0,
        retract_away: Annotated[float, Ge(0)] = 0.0,
        retract_again: bool = False,
        retract_margin: Annotated[float, Ge(0)] = 0.0,
        articulated_only: bool = False,
    ) -> None:
        self.pause = float(pause)
        self.hold = float(hold)
        if self.hold > 0.0 and not reset:
            raise ConfigError("sampler.release.hold needs sampler.release.reset (the wrist is reset to it)")
        self.open = float(open)
        self.open_to = open_to
        self.backoff = float(backoff)
        self.backoff_window = time_window("sampler.release.backoff_window", backoff_window)
        self.reset = bool(reset)
        self.noise = float(noise)
        self.blend = float(blend)
        self.window = time_window("sampler.release.window", window)
        self.retract = float(retract)
        if self.retract > 0.0 and not reset:
            raise ConfigError("sampler.release.retract needs sampler.release.reset (it acts at the release)")
        self.retract_time = float(retract_time)
        self.retract_away = float(retract_away)
        self.retract_again = bool(retract_again)
        self.retract_margin = float(retract_margin)
        self.articulated_only = bool(articulated_only)

    def __repr__(self) -> str:
        fields = (
            "pause",
            "hold",
            "open",
            "open_to",
            "backoff",
            "backoff_window",
            "reset",
            "noise",
            "window",
            "blend",
            "retract",
            "retract_time",
            "retract_away",
            "retract_again",
            "retract_margin",
            "articulated_only",
        )
        return f"ReleaseSchedule({', '.join(f'{k}={getattr(self, k)!r}' for k in fields)})"

    def for_object(self, free: bool) -> ReleaseSchedule:
        """The schedule a problem uses on its object: this one, or with ``articulated_only`` on a ``free``
        object (one with a free body), a copy without the wrist's ``hold`` and the retraction."""
        if not (self.articulated_only and free):
            return self
        out = copy.copy(self)
        out.hold, out.retract, out.retract_again, out.retract_margin = 0.0, 0.0, False, 0.0
        return out

    def root_nominal(
        self,
        times: np.ndarray,
        root: np.ndarray,
        last_contact: float | None,
        direction: np.ndarray | None,
    ) -> np.ndarray:
        """The nominal wrist curves: ``root`` (T, R) held from ``hold`` before ``last_contact``, paused
        and backed off after it (``None``: the reference ends held, ``root`` as it is).

        Args:
            times: (T,) control times of the reference frames.
            root: (T, R) the reference's wrist DOFs; the first three are slides along world x, y, z.
            last_contact: control time (s) of the reference's last expected contact where it lets go.
            direction: (3,) world unit vector to back off along; required with ``backoff``.

        Raises:
            ValueError: ``backoff`` without a direction.
        """
        if self.hold > 0.0 and last_contact is not None:
            root = paused(times, root, last_contact - self.hold, self.hold + self.pause)
        elif self.pause > 0.0 and last_contact is not None:
            root = paused(times, root, last_contact, self.pause)
        if self.backoff > 0.0 and last_contact is not None:
            if direction is None:
                raise ValueError("sampler.release.backoff needs the release direction (the problem's)")
            offset = np.zeros(root.shape[1])
            offset[:3] = self.backoff * np.asarray(direction, float)
            start, end = (last_contact + w for w in self.backoff_window)
            root = backed_off(times, root, offset, start, end)
        return root

    def opens(self, last_contact: float | None) -> bool:
        """Whether the nominal fingers open (``open`` set and the reference lets go)."""
        return self.open > 0.0 and last_contact is not None

    def finger_nominal(
        self, times: np.ndarray, fingers: np.ndarray, last_contact: float, finger_ranges: np.ndarray
    ) -> np.ndarray:
        """The nominal finger curves (T, F) opening from ``last_contact`` (see :meth:`opens`).

        Args:
            times: (T,) control times of the reference frames.
            fingers: (T, F) the reference's finger joints.
            last_contact: control time (s) of the reference's last expected contact.
            finger_ranges: (F, 2) the finger actuators' ranges (the flat hand is 0 clipped to them).
        """
        target = None
        if self.open_to == "flat":
            target = np.clip(0.0, *np.asarray(finger_ranges).T)
        return opened(times, fingers, last_contact, self.open, target)

    def retracted(
        self, times: np.ndarray, start: float, q: np.ndarray, dq: np.ndarray, away: np.ndarray
    ) -> np.ndarray:
        """(N, J) the hand's targets at control ``times`` (N,) of a retraction (``retract``) that began at
        control time ``start`` from :func:`retraction`'s ``q``, ``dq`` and ``away``."""
        since = np.asarray(times, float)[:, None] - start
        out = q + np.clip(since / self.retract_time, 0.0, 1.0) * dq
        off = np.clip((since - self.retract_time - RETRACT_WAIT) / RETRACT_MOVE, 0.0, 1.0)
        out[:, :3] += off * self.retract_away * np.asarray(away, float)
        return out
