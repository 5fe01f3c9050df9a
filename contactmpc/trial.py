"""The closed loop: plant stepping at 1 ms, replanning every ``replan_period``, logging.

Synchronous and seeded: at every replan time the planner runs on the plant's current state, then
the plant advances with joint targets from the committed splines evaluated at every physics step.
The same scene, reference, config and seed give the same log, bit for bit.

With a planning latency L (``planner.latency`` or ``planner.latency_model``, MuJoCo MPC's loop
simulated), the plan computed from the state at t takes effect at t + L; until then the plant follows
the previous plan. Plans start every ``max(replan_period, L)``: with L the longer, the next plan
starts from the state at t + L, when the last one takes effect (continuous replanning). L = 0 is the
synchronous loop, bit for bit. With ``planner.compensate_latency`` (``compensation=predict``) the plan
computed at t starts from the state predicted at t + L instead (:meth:`Planner.predict
<contactmpc.control.planners.base.Planner.predict>`), its window starting there. With
``planner.latency_per_plan`` each plan is charged its own L (:meth:`Planner.latency_at
<contactmpc.control.planners.base.Planner.latency_at>`: the grasp's dearer plans longer than the later
ones), and the next plan starts ``max(replan_period, L)`` after it (:meth:`Trial.schedule`).
"""

from __future__ import annotations

from typing import Annotated

import numpy as np
from tqdm.auto import tqdm

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners.base import Planner
from contactmpc.control.problem import Problem
from contactmpc.control.samplers import SplineSpace
from contactmpc.perturbations import Perturbation, PerturbationDraw
from contactmpc.plant import Plant, PlantDiverged, TrialLog
from contactmpc.reference.data import Reference
from contactmpc.scene import Scene
from contactmpc.validate import ConfigError, Ge, Gt, checked

__all__ = ["Plant", "PlantDiverged", "Trial", "TrialLog", "check_planner_timing", "check_timing"]

TIMING_TOLERANCE = 1e-9  # s: how far a period may be from a whole number of plant steps


def check_timing(
    plant_timestep: float,
    planner_timestep: float,
    horizon: float,
    replan_period: float,
    latency: float,
    step_name: str = "scene.planner_timestep",
) -> None:
    """Refuse timing a loop can only round: each value must be what the loop will really use.

    ``planner_timestep``, ``replan_period`` and ``latency`` must be whole multiples of the plant step
    (within :data:`TIMING_TOLERANCE`; ``latency`` may be 0), and the horizon at least one planning step.
    ``step_name``: the planning step's name in the message.

    Raises:
        ConfigError: one line naming the values.
    """
    for name, value in (
        (step_name, planner_timestep),
        ("planner.replan_period", replan_period),
        ("planner.latency", latency),
    ):
        steps = round(value / plant_timestep)
        if value < 0 or (steps < 1 and value != 0) or abs(value - steps * plant_timestep) > TIMING_TOLERANCE:
            raise ConfigError(
                f"{name} = {value:g} s is not a whole number of plant steps "
                f"(scene.plant_timestep = {plant_timestep:g} s): the loop would round it to "
                f"{max(steps, 1) * plant_timestep:g} s"
            )
    if horizon < planner_timestep - TIMING_TOLERANCE:
        raise ConfigError(
            f"planner.horizon = {horizon:g} s is shorter than one planning step "
            f"({step_name} = {planner_timestep:g} s)"
        )


def check_planner_timing(scene: Scene, planner: Planner) -> None:
    """:func:`check_timing` of a planner's horizon, replan period and fixed latency on a scene (and on
    the planner's second planning model, ``planner.switch_timestep``, where it has one)."""
    steps = [("scene.planner_timestep", scene.planner_timestep)]
    if planner.switch_timestep is not None:
        steps.append(("planner.switch_timestep", planner.switch_timestep))
    for name, step in steps:
        check_timing(
            scene.plant_model.opt.timestep,
            step,
            planner.horizon,
            planner.replan_period,
            planner.latency,
            step_name=name,
        )


class Trial:
    """One closed-loop trial of a planner on a task.

    Args:
        scene: the composed hand + task.
        reference: the demonstration (validated).
        space: the sampler space.
        cost: the running cost.
        planner: the planner.
        seed: seed of the trial's random generator.
        num_control_points: control points per curve M; ``None`` takes ``reference.meta``'s
            suggestion (``num_control_points``) or 4 per second of slowed reference.
        duration: simulated control time (s); ``None`` = the slowed reference's duration.
        progress: show a progress bar.
        perturbation: plant-only changes drawn from the seed (:mod:`contactmpc.perturbations`);
            ``None`` is none. The draw is :attr:`draw` once :meth:`run` has started.
        start_time: control time (s) the trial starts at (a whole number of plant steps, before
            ``duration``): the plant starts at the reference's state there (the hand at the committed
            policy's targets at that time, the object at the reference's configuration, at rest) and
            the loop's clock starts there; 0: the whole trial.
    """

    @checked
    def __init__(
        self,
        scene: Scene,
        reference: Reference,
        space: SplineSpace,
        cost: TrackingCost,
        planner: Planner,
        seed: Annotated[int, Ge(0)],
        num_control_points: int | None = None,
        duration: Annotated[float, Gt(0)] | None = None,
        progress: bool = True,
        perturbation: Perturbation | None = None,
        start_time: Annotated[float, Ge(0)] = 0.0,
    ) -> None:
        self.scene, self.reference, self.planner = scene, reference, planner
        self.start_time = float(start_time)
        self.perturbation = Perturbation() if perturbation is None else perturbation
        self.plant: Plant | None = None
        self.seed = int(seed)
        self.progress = progress
        plant_dt = scene.plant_model.opt.timestep
        check_planner_timing(scene, planner)
        if planner.pace_lag is not None and scene.task.layout.free_columns:
            # a paced reference may fall pace_budget behind control time (only on a free object: it never
            # waits on one that moves on joints alone, so the trial there is the unpaced one)
            slowed = reference.duration * scene.task.time_scale
            budgets = 1 if planner.pace_grasp is None else 2  # (the grasp's wait has a budget of its own)
            duration = (slowed if duration is None else duration) + budgets * planner.pace_budget
            if planner.pace_retry is not None:  # (a grasp tried again: the rewinds' budget)
                duration += planner.pace_retry_budget
        self.problem = Problem.build(
            scene, reference, space, cost, planner.horizon, num_control_points, duration
        )
        self.track = self.problem.track
        self.spline = self.problem.spline
        self.duration = self.problem.duration
        self.perturbation.check(scene, scene.task.start_object_qpos(reference.object_qpos[0]))
        planner.bind(self.problem)
        self.latency = planner.latency_for(plant_dt)  # a modelled one lies on the plant's grid
        self.replan_interval = max(planner.replan_period, self.latency)
        if self.start_time:
            if abs(self.start_time - round(self.start_time / plant_dt) * plant_dt) > TIMING_TOLERANCE:
                raise ConfigError(f"start_time = {self.start_time:g} s is not a whole number of plant steps")
            if self.start_time >= self.duration:
                raise ConfigError(
                    f"start_time = {self.start_time:g} s is not before the trial's end ({self.duration:g} s)"
                )

    def run(self, snapshots: tuple[float, ...] = ()) -> TrialLog:
        """Simulate the closed loop for ``duration`` seconds of control time.

        Args:
            snapshots: control times at which to keep the plant's full state (``mjSTATE_FULLPHYSICS``,
                time set to the control clock) in :attr:`snapshots`: at the first replan at or after
                each.

        Returns:
            The per-replan log.

        Raises:
            PlantDiverged: if the plant becomes unstable.
        """
        scene, planner = self.scene, self.planner
        plant = self.start_plant()
        rng = np.random.default_rng(self.seed)
        dt = plant.timestep
        n_steps = int(round(self.duration / dt))
        state = np.empty(plant.state_size())
        first = int(round(self.start_time / dt))  # the first step: the loop's clock starts there
        earlier = None  # the state of one replan period earlier (draw.delay)
        pending = sorted(float(v) for v in snapshots)
        self.snapshots: dict[float, np.ndarray] = {}
        log = TrialLog()
        bar = tqdm(
            total=n_steps - first,
            desc=f"{scene.task.name}",
            unit="step",
            disable=not self.progress,
            leave=False,
        )
        try:
            # lag: plant steps on the previous plan after each replan
            for k, lag, per_plan in self.schedule():
                t = k * dt
                offsets = np.arange(per_plan) * dt
                plant.state(t, out=state)  # rollouts run on the control clock
                while pending and t >= pending[0] - 1e-9:
                    self.snapshots[pending.pop(0)] = state.copy()
                seen = plant.observe(state)
                if plant.draw.delay:
                    seen, earlier = (seen if earlier is None else earlier), seen.copy()
                if lag:  # the previous plan's targets until this one takes effect
                    previous = planner.targets(t + offsets[:lag])
                at = planner.reference_time(t) if planner.pace_lag is not None else None
                info = planner.plan(t, seen, rng, ahead=lag * dt)
                if not lag:
                    targets = planner.targets(t + offsets)
                elif lag < per_plan:
                    targets = np.concatenate([previous, planner.targets(t + offsets[lag:])])
                else:  # continuous replanning: this plan takes effect when the next one starts
                    targets = previous
                plant.log(log, t, targets[0], info, at)
                for j in range(min(per_plan, n_steps - k)):
                    plant.step(targets[j], t + j * dt, t + (j + 1) * dt)
                plant.check(t, (k + min(per_plan, n_steps - k)) * dt)
                bar.update(min(per_plan, n_steps - k))
        except PlantDiverged as err:
            err.log = log  # what happened until then, for the record
            raise
        finally:
            bar.close()
        return log

    def schedule(self) -> list[tuple[int, int, int]]:
        """The trial's replans, ``(plant step it starts at, its latency, plant steps until the next)``
        each: every ``replan_interval`` at :attr:`latency`, or with ``planner.latency_per_plan`` each
        plan at its own latency (:meth:`Planner.latency_at
        <contactmpc.control.planners.base.Planner.latency_at>`), the next ``max(replan_period, latency)``
        later. A function of the config alone (the plan's control time), so known before the trial runs."""
        dt = self.scene.plant_model.opt.timestep
        first, n_steps = int(round(self.start_time / dt)), int(round(self.duration / dt))
        planner = self.planner
        if not planner.latency_per_plan:
            per_plan = int(round(self.replan_interval / dt))
            lag = int(round(self.latency / dt))
            return [(k, lag, per_plan) for k in range(first, n_steps, per_plan)]
        replan = int(round(planner.replan_period / dt))
        plans, k = [], first
        while k < n_steps:
            lag = int(round(planner.latency_at(k * dt, dt) / dt))
            plans.append((k, lag, max(replan, lag)))
            k += max(replan, lag)
        return plans

    def expected_log(self) -> tuple[np.ndarray, np.ndarray]:
        """The instants the whole trial logs (one per replan, :meth:`schedule`) and the links expected in
        contact there: ``(time (N,), expected_contacts (N, L))``, as :meth:`run`'s log has them (a paced
        reference's as if it never waited: how long it will wait is known only as the trial runs)."""
        dt = self.scene.plant_model.opt.timestep
        time = np.array([k for k, _, _ in self.schedule()], float) * dt
        return time, self.track.contact_active[[self.track.index(t) for t in time]]

    # --- the plant, shared with the wall-clock loop (contactmpc.online) -------------------------
    @property
    def draw(self) -> PerturbationDraw | None:
        """The perturbation's draw, once :meth:`run` (or :meth:`start_plant`) has started."""
        return None if self.plant is None else self.plant.draw

    def start_plant(self) -> Plant:
        """Make the trial's :class:`~contactmpc.plant.Plant` (:attr:`plant`) and start it: the perturbation
        drawn from the seed, the hand at the committed policy's first targets, the object at the task's
        start (moved by the draw); with :attr:`start_time`, the hand at the policy's targets then and
        the object at the reference's configuration then (the task's start offset and the draw applied
        as at t = 0), at rest."""
        scene = self.scene
        plant = self.plant = Plant(scene, self.track, self.perturbation, self.seed, self.duration)
        hand0 = self.planner.targets(np.array([self.start_time]))[0]
        qo = self.reference.object_qpos[0]
        if self.start_time:  # the reference's object where the trial starts
            qo = self.track.object_qpos[self.track.index(self.start_time)]
        plant.start(hand0, scene.task.start_object_qpos(qo))
        return plant
