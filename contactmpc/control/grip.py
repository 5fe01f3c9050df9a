"""A firmer grip (not the paper's): the fingers' targets pressed into the object where the reference
expects their contact.

The hand's fingers are position-controlled (the authors' gain is 1 N·m/rad), so how hard a finger
presses on the object is the gain times how far its target lies inside the object. The reference's
finger poses were retargeted to touch the object, not to squeeze it: at its targets a finger that
touches barely presses, and a held object slips out as the hand lifts, turns or sets it down. A
:class:`Grip` adds ``squeeze`` radians to every flexion joint of a finger (``hand.flexion_joints``: the
joints that close it) while the reference expects that finger in contact, ramped in over ``ramp``
seconds from the finger's first expected contact and out over ``ramp`` seconds before its last, so
the finger is relaxed again where the reference lets go. With ``during="carried"`` a finger squeezes only
while the reference also has the object lifted (``lift`` above where it starts), so the fingers close
on the object as the reference approaches it unchanged, and press only once the grasp is to carry it;
with ``during="touched"`` only from the plan that finds the finger on the object. The offset is part of
the policy: the planner's rollouts and the plant both get it
(:meth:`~contactmpc.control.planners.base.Planner.targets`), so the planner plans with the grip the plant
will have (``planned=False``: the plant alone).
"""

from __future__ import annotations

from typing import Annotated

import numpy as np

from contactmpc.validate import ConfigError, Ge, Gt, OneOf, checked


def trapezoids(active: np.ndarray, ramp: int, bridge: int) -> np.ndarray:
    """Weights in [0, 1] per step: 0 off a run of ``active`` steps, rising over ``ramp`` steps from a
    run's start and falling over ``ramp`` steps to its end (a run shorter than ``2 ramp`` peaks below 1);
    gaps of at most ``bridge`` steps between two runs count as active.

    Args:
        active: (N,) bool.
        ramp: steps of the rise and of the fall (>= 1).
        bridge: the longest gap (steps) that is filled.

    Returns:
        (N,) float weights.
    """
    active = np.asarray(active, bool).copy()
    on = np.flatnonzero(active)
    if on.size > 1:
        for a, b in zip(on[:-1], on[1:], strict=True):
            if 1 < b - a <= bridge + 1:
                active[a:b] = True
    n = len(active)
    rise, fall = np.zeros(n), np.zeros(n)
    level = 0.0
    for k in range(n):  # steps since the run started, capped
        level = min(level + 1.0, float(ramp)) if active[k] else 0.0
        rise[k] = level
    level = 0.0
    for k in range(n - 1, -1, -1):  # steps until the run ends, capped
        level = min(level + 1.0, float(ramp)) if active[k] else 0.0
        fall[k] = level
    return np.minimum(rise, fall) / float(ramp)


class Grip:
    """Squeeze the fingers the reference expects in contact (see the module's docstring).

    Args:
        squeeze: radians added to each flexion joint's target of a finger at full grip.
        ramp: seconds (control time) over which the squeeze grows after a finger's first expected
            contact, and falls before its last.
        bridge: gaps in a finger's expected contact up to this long (s) count as contact (the
            reference's contacts flicker as a finger rolls on the object).
        during: ``contact``: wherever the reference expects the finger's contact; ``carried``: only
            where the reference also has the object's (first) free body more than ``lift`` above its
            first position (an object without a free body, the doorknob, is never squeezed);
            ``touched``: as ``contact``, but a finger squeezes only from the plan at which it is found
            touching the object (in the measured state, while the reference expects its contact), its
            squeeze ramped in from there: a finger that has not reached the object is not curled.
        lift: metres (``during="carried"``).
        planned: the planner's rollouts get the offset too (they plan with the grip the plant will
            have); ``False``: the plant's targets only, a grip the planner does not know of.
    """

    @checked
    def __init__(
        self,
        squeeze: Annotated[float, Ge(0)] = 0.1,
        ramp: Annotated[float, Gt(0)] = 0.3,
        bridge: Annotated[float, Ge(0)] = 0.5,
        during: Annotated[str, OneOf("contact", "carried", "touched")] = "contact",
        lift: Annotated[float, Ge(0)] = 0.01,
        planned: bool = True,
    ) -> None:
        self.planned = bool(planned)
        self.squeeze = float(squeeze)
        self.ramp = float(ramp)
        self.bridge = float(bridge)
        self.during = during
        self.lift = float(lift)

    def __repr__(self) -> str:
        fields = ("squeeze", "ramp", "bridge", "during", "lift", "planned")
        return f"Grip({', '.join(f'{k}={getattr(self, k)!r}' for k in fields)})"

    def carried(self, layout, object_qpos: np.ndarray) -> np.ndarray:
        """(N,) bool: whether the object's (first) free body is more than :attr:`lift` above its first
        position in ``object_qpos`` (N, n_o) (a task's ``layout``); all false without a free body."""
        if not layout.free_columns:
            return np.zeros(len(object_qpos), bool)
        z = layout.position(np.asarray(object_qpos, float))[:, 2]
        return z - z[0] > self.lift

    def fingers(self, hand) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per finger that has flexion joints, ``(links, columns)``: the indices of its contact links
        among ``hand.link_names`` and of its flexion joints among the hand's joints (root DOFs first,
        then ``hand.finger_joints``). A flexion joint ``<finger>j<i>`` closes the finger whose contact
        links are named ``<finger>_*``.

        Raises:
            ConfigError: a flexion joint whose finger has no contact link.
        """
        links = tuple(hand.link_names)
        num_root = len(hand.root_joints)
        out: dict[str, tuple[list[int], list[int]]] = {}
        for joint in hand.flexion_joints:
            finger = joint.rsplit("j", 1)[0]
            if finger not in out:
                mine = [i for i, name in enumerate(links) if name.startswith(finger + "_")]
                if not mine:
                    raise ConfigError(
                        f"planner.grip: {type(hand).__name__}'s flexion joint {joint} has no contact link "
                        f"named {finger}_*"
                    )
                out[finger] = (mine, [])
            out[finger][1].append(num_root + hand.finger_joints.index(joint))
        return [(np.array(a), np.array(b)) for a, b in out.values()]

    def weights(
        self,
        fingers: list[tuple[np.ndarray, np.ndarray]],
        contact_active: np.ndarray,
        dt: float,
        carried: np.ndarray | None = None,
    ) -> np.ndarray:
        """(N, F) each finger's share of the squeeze (0 to 1) at each step of a grid.

        Args:
            fingers: :meth:`fingers`.
            contact_active: (N, L) the reference's expected contacts per grid step, over the hand's links.
            dt: the grid's step (s).
            carried: (N,) bool, where the reference carries the object (:meth:`carried`); needed with
                ``during="carried"``.
        """
        contact_active = np.asarray(contact_active, bool)
        ramp = max(1, int(round(self.ramp / dt)))
        bridge = int(round(self.bridge / dt))
        out = np.zeros((len(contact_active), len(fingers)))
        for f, (links, _) in enumerate(fingers):
            active = contact_active[:, links].any(axis=1)
            if self.during == "carried":
                active = active & np.asarray(carried, bool)
            out[:, f] = trapezoids(active, ramp, bridge)
        return out

    def masks(self, fingers: list[tuple[np.ndarray, np.ndarray]], num_joints: int) -> np.ndarray:
        """(F, J) what a finger at full squeeze adds to the hand's joint targets."""
        out = np.zeros((len(fingers), num_joints))
        for f, (_, columns) in enumerate(fingers):
            out[f, columns] = self.squeeze
        return out

    def tables(
        self, hand, contact_active: np.ndarray, dt: float, carried: np.ndarray | None = None
    ) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray, np.ndarray]:
        """The grip on a grid: ``(fingers, weights, masks)``, its :meth:`fingers`, their (N, F)
        :meth:`weights` and their (F, J) :meth:`masks` over the hand's joints (root DOFs first, then
        ``hand.finger_joints``); ``weights @ masks`` is what it adds to the joint targets (with
        ``during="touched"``, before the touch gates it).

        Args:
            hand: the hand (``root_joints``, ``finger_joints``, ``flexion_joints``, ``link_names``).
            contact_active: (N, L) the reference's expected contacts per grid step, over
                ``hand.link_names``.
            dt: the grid's step (s).
            carried: (N,) bool, where the reference carries the object (:meth:`carried`); needed with
                ``during="carried"``.

        Raises:
            ConfigError: a flexion joint whose finger has no contact link, or contacts over another
                number of links than the hand's.
        """
        contact_active = np.asarray(contact_active, bool)
        if contact_active.shape[1] != len(hand.link_names):
            raise ConfigError(
                f"planner.grip: the reference's contacts are over {contact_active.shape[1]} links, the hand "
                f"{type(hand).__name__} has {len(hand.link_names)}"
            )
        fingers = self.fingers(hand)
        masks = self.masks(fingers, len(hand.root_joints) + len(hand.finger_joints))
        return fingers, self.weights(fingers, contact_active, dt, carried), masks
