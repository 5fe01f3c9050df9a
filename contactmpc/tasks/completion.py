"""The completion rules of a task: milestones reached while the hand holds the object, and the final
one, *settled* (the object left at rest where the reference leaves it).

:class:`TaskCompletion` is a base of :class:`~contactmpc.tasks.base.Task`: a task names its milestone
conditions (:meth:`TaskCompletion.conditions`) and may set its own tolerances; the rule that makes a
condition a milestone (:func:`sustained`) and the final milestone (:meth:`TaskCompletion.settled`,
:func:`sustained_to_end`) are the same for every task.
"""

from __future__ import annotations

import numpy as np

from contactmpc.tasks.layout import ObjectLayout


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


class TaskCompletion:
    """How a trial of a task is scored (a base of :class:`~contactmpc.tasks.base.Task`, which sets
    :attr:`layout`)."""

    layout: ObjectLayout

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
