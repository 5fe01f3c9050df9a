"""The planning problem, bound once: scene, reference track, spline, sampler space and cost.

:meth:`Problem.build` slows the reference and samples it on the planner's grid
(:class:`~contactmpc.control.track.ReferenceTrack`), chooses the spline (``M`` control points over the
slowed reference), fits the sampler space to the reference hand curves (its nominal control points
``theta0``) and resolves the cost's sensor addresses. A planner is then bound to the problem with
:meth:`~contactmpc.control.planners.base.Planner.bind`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from contactmpc.control.cost import TrackingCost
from contactmpc.control.release import has_free_body
from contactmpc.control.samplers import SplineSpace
from contactmpc.control.track import ReferenceTrack
from contactmpc.reference.bspline import UniformBSpline
from contactmpc.reference.data import Reference
from contactmpc.scene import Scene


@dataclass
class Problem:
    """Everything a planner plans for.

    Attributes:
        scene: the hand + task models and their index.
        track: the slowed reference on the planner's grid.
        spline: the B-spline over control time (``M`` control points).
        space: the sampler space, fitted to the reference.
        cost: the running cost, bound to scene and track.
        theta0: (M, d) the reference's own control points in the space's coordinates.
        duration: control time a trial simulates (s).
        noise_std: (d,) the sampling noise per column of ``theta``, or (M, d) per control point (a
            space with a ``root_window`` or a release ``window``); ``None``: the space's ``noise_std``.
        last_contact: control time (s) of the reference's last expected contact where it lets go
            (``None``: it ends held, or expects none).
        first_contact: control time (s) of the reference's first expected contact (``None``: it
            expects none).
        release_theta: (M, d) the nominal the planner's committed control points go back to at the
            last contact (a release schedule with ``reset``: its release nominal, the reference's own
            where it sets no ``open`` / ``pause`` / ``backoff``); ``theta0`` is then the reference's
            own, so that the release nominal changes nothing before the last contact. ``None``: no
            reset.
        reference: the demonstration the track was built from (:meth:`stepped` builds it again).
        padding: control time the track holds its last frame past the reference's end (s).
    """

    scene: Scene
    track: ReferenceTrack
    spline: UniformBSpline
    space: SplineSpace
    cost: TrackingCost
    theta0: np.ndarray
    duration: float
    noise_std: np.ndarray | None = None
    last_contact: float | None = None
    release_theta: np.ndarray | None = None
    first_contact: float | None = None
    reference: Reference | None = None
    padding: float = 0.0

    @classmethod
    def build(
        cls,
        scene: Scene,
        reference: Reference,
        space: SplineSpace,
        cost: TrackingCost,
        horizon: float,
        num_control_points: int | None = None,
        duration: float | None = None,
    ) -> Problem:
        """Bind a reference, a sampler space and a cost to a scene.

        Args:
            scene: the composed hand + task.
            reference: the demonstration (validated).
            space: the sampler space (fitted here).
            cost: the running cost (bound here).
            horizon: the planner's horizon (s): the track is padded by it.
            num_control_points: control points per curve ``M``; ``None`` takes ``reference.meta``'s
                suggestion (``num_control_points``) or 4 per second of slowed reference.
            duration: control time to simulate (s); ``None`` = the slowed reference's duration.
        """
        task = scene.task
        release = space.release.for_object(has_free_body(scene.planner_model, scene.index))
        if release is not space.release:  # articulated_only on a free object: a space of its own with it
            space = copy.copy(space)
            space.release = release
        padding = horizon + max(0.0, (duration or 0.0) - reference.duration * task.time_scale) + 0.1
        track = ReferenceTrack.build(reference, task.layout, task.time_scale, scene.planner_timestep, padding)
        if num_control_points is None:
            num_control_points = reference.meta.get("num_control_points") or max(
                8, int(round(4 * track.duration))
            )
        spline = UniformBSpline(int(num_control_points), (0.0, track.duration))
        ranges = scene.plant_model.actuator_ctrlrange[scene.index.actuators]
        expected = np.flatnonzero(track.contact_active.any(axis=1))
        first_contact = float(expected[0] * track.dt) if expected.size else None
        # the reference lets go where its track ends without contact (else there is no release)
        lets_go = expected.size and expected[-1] < len(track.contact_active) - 1
        last_contact = float(expected[-1] * track.dt) if lets_go else None
        direction = None
        if space.release.backoff > 0.0 and last_contact is not None:
            direction = release_direction(scene, track, int(expected[-1]))

        def fit(until: float | None) -> np.ndarray:
            return space.fit(
                spline,
                track.hand_times,
                reference.hand_qpos,
                ranges,
                scene.hand.num_root,
                meta=reference.meta,
                last_contact=until,
                release_direction=direction,
            )

        theta0 = fit(last_contact)
        release_theta = None
        if space.release.reset and last_contact is not None:
            # the release nominal takes over at the last contact; until then the reference's own
            release_theta, theta0 = theta0, fit(None)
        cost.bind(scene, track, reference)
        return cls(
            scene=scene,
            track=track,
            spline=spline,
            space=space,
            cost=cost,
            theta0=theta0,
            duration=float(track.duration if duration is None else duration),
            noise_std=space.point_noise_std(spline, first_contact, last_contact),
            last_contact=last_contact,
            release_theta=release_theta,
            first_contact=first_contact,
            reference=reference,
            padding=padding,
        )

    def stepped(self, timestep: float) -> Problem:
        """This problem planned on a model stepped at ``timestep`` (s): the scene's planning model compiled
        at that step (:meth:`~contactmpc.scene.Scene.stepped`), the track sampled on its grid and a copy of
        the cost bound to them. The spline, the sampler space, the nominal control points and the
        contact times are in control time and stay as they are.

        Raises:
            ValueError: a problem built without its reference.
        """
        if self.reference is None:
            raise ValueError("Problem.stepped needs the reference the problem was built from")
        scene = self.scene.stepped(timestep)
        task = scene.task
        track = ReferenceTrack.build(self.reference, task.layout, task.time_scale, timestep, self.padding)
        cost = copy.copy(self.cost)
        cost.bind(scene, track, self.reference)
        return replace(self, scene=scene, track=track, cost=cost)


def release_direction(scene: Scene, track: ReferenceTrack, step: int) -> np.ndarray:
    """The way out at the reference's last expected contact: the world unit vector from the centroid of
    the expected contact points to the palm (the first contact link), with the hand and the object
    posed as the reference has them at grid step ``step``.

    Args:
        scene: the composed hand + task (its planning model is posed, in a scratch ``MjData``).
        track: the slowed reference.
        step: grid index of the last expected contact.

    Returns:
        (3,) unit vector.
    """
    m, idx = scene.planner_model, scene.index
    d = mujoco.MjData(m)
    d.qpos[idx.hand_qpos] = track.hand_qpos[track.frame[step]]
    d.qpos[idx.object_qpos] = track.object_qpos[step]
    mujoco.mj_kinematics(m, d)
    active = np.flatnonzero(track.contact_active[step])
    bodies = idx.object_bodies[track.contact_object_body[step, active]]
    points = d.xpos[bodies] + np.einsum(
        "kij,kj->ki", d.xmat[bodies].reshape(-1, 3, 3), track.contact_object_point[step, active]
    )
    away = d.xpos[idx.link_bodies[0]] - points.mean(axis=0)
    norm = np.linalg.norm(away)
    if norm < 1e-9:
        raise ValueError("release direction: the palm sits on the centroid of the expected contacts")
    return away / norm
