"""The reference as the controller sees it: slowed down and sampled on the planner's time grid.

The demonstration's own time ``tau`` maps to control time ``t = time_scale * tau``. A
:class:`ReferenceTrack` resamples the expected object configuration and the per-link expected
contacts on a uniform grid of step ``dt`` (the planning model's timestep) covering the slowed
reference plus one horizon of padding (the last frame held), so that the cost of a rollout that
starts at grid index ``i`` reads plain slices ``[i, i + H)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactmpc.reference.data import Reference
from contactmpc.tasks.base import ObjectLayout


@dataclass
class ReferenceTrack:
    """The slowed reference on the planner's grid.

    Attributes:
        dt: grid step (s), the planning model's timestep.
        time_scale: slow-down factor of the demonstration.
        duration: control-time duration of the slowed reference (s).
        hand_times: (T,) control times of the reference frames.
        hand_qpos: (T, J) reference hand configurations.
        object_qpos: (N, n_o) expected object configuration per grid step.
        contact_active: (N, L) expected contacts per grid step.
        contact_link_point: (N, L, 3) link-local contact points.
        contact_object_point: (N, L, 3) object-local contact points.
        contact_object_body: (N, L) index into the task's object bodies.
        frame: (N,) the reference frame each grid step takes its contacts from.
    """

    dt: float
    time_scale: float
    duration: float
    hand_times: np.ndarray
    hand_qpos: np.ndarray
    object_qpos: np.ndarray
    contact_active: np.ndarray
    contact_link_point: np.ndarray
    contact_object_point: np.ndarray
    contact_object_body: np.ndarray
    frame: np.ndarray

    @classmethod
    def build(
        cls,
        reference: Reference,
        layout: ObjectLayout,
        time_scale: float,
        dt: float,
        padding: float,
    ) -> ReferenceTrack:
        """Resample ``reference`` slowed by ``time_scale`` on a grid of step ``dt``.

        Args:
            reference: the demonstration.
            layout: the task's ``q_o`` layout.
            time_scale: slow-down factor (control time = ``time_scale`` x demonstration time).
            dt: grid step (s).
            padding: extra control time after the end, holding the last frame (s); one horizon.
        """
        t_ref = (reference.time - reference.time[0]) * time_scale
        duration = float(t_ref[-1])
        n = int(np.ceil((duration + padding) / dt)) + 1
        grid = np.arange(n) * dt
        # Contacts: the frame at or before each grid time (they are per-frame summaries).
        frame = np.clip(np.searchsorted(t_ref, grid + 1e-9, side="right") - 1, 0, len(t_ref) - 1)
        return cls(
            dt=dt,
            time_scale=time_scale,
            duration=duration,
            hand_times=t_ref,
            hand_qpos=reference.hand_qpos,
            object_qpos=layout.resample(t_ref, reference.object_qpos, grid),
            contact_active=reference.contact_active[frame],
            contact_link_point=reference.contact_link_point[frame],
            contact_object_point=reference.contact_object_point[frame],
            contact_object_body=reference.contact_object_body[frame],
            frame=frame,
        )

    @property
    def num_steps(self) -> int:
        """Number of grid steps (including the padding)."""
        return len(self.object_qpos)

    def index(self, t: float) -> int:
        """Grid index of control time ``t`` (rounded to the nearest step, clipped to the grid)."""
        return int(np.clip(round(t / self.dt), 0, self.num_steps - 1))

    def window(self, t: float, steps: int) -> slice:
        """The grid slice of ``steps`` steps starting at time ``t`` (clipped to the grid)."""
        i = self.index(t)
        return slice(i, min(i + steps, self.num_steps))
