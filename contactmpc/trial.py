"""The closed loop: plant stepping at 1 ms, replanning every ``replan_period``, logging.

Synchronous and seeded: at every replan time the planner runs on the plant's current state, then
the plant advances with joint targets from the committed splines evaluated at every physics step.
The same scene, reference, config and seed give the same log, bit for bit.

With a planning latency L (``planner.latency`` or ``planner.latency_model``, MuJoCo MPC's loop
simulated), the plan computed from the state at t takes effect at t + L; until then the plant follows
the previous plan. Plans start every ``max(replan_period, L)``: with L the longer, the next plan
starts from the state at t + L, when the last one takes effect (continuous replanning). L = 0 is the
synchronous loop, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Annotated

import mujoco
import numpy as np
from tqdm.auto import tqdm

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners.base import Planner
from contactmpc.control.problem import Problem
from contactmpc.control.samplers import SplineSpace
from contactmpc.perturbations import Perturbation, PerturbationDraw
from contactmpc.reference.data import Reference
from contactmpc.scene import Scene
from contactmpc.validate import ConfigError, Ge, Gt, checked

TIMING_TOLERANCE = 1e-9  # s: how far a period may be from a whole number of plant steps


class PlantDiverged(RuntimeError):
    """The plant simulation went unstable (MuJoCo warning or non-finite state).

    Attributes:
        time: the control time of the last replan before it went unstable (s), or ``None``.
        log: the trial's log up to that replan (set by :meth:`Trial.run`), or ``None``.
    """

    def __init__(self, message: str, time: float | None = None) -> None:
        super().__init__(message)
        self.time = time
        self.log: TrialLog | None = None


@dataclass
class TrialLog:
    """Per-step log of a trial, one row per replan period.

    Attributes:
        time: (N,) control time (s).
        qpos: (N, nq) the plant's full configuration (for rendering the trial afterwards).
        hand_qpos: (N, J) plant hand configuration.
        hand_target: (N, J) joint targets sent to the actuators.
        object_qpos: (N, n_o) plant object configuration.
        expected_object_qpos: (N, n_o) reference object configuration at that time.
        contacts: (N, L) links touching the object.
        expected_contacts: (N, L) links expected in contact by the reference.
        object_position_error / object_rotation_error / object_articulation_error: (N,).
        cost_<term>: (N,) each cumulative cost term of the committed sample (``cost_object``,
            ``cost_contact``, ``cost_velocity`` for :class:`~contactmpc.control.cost.TrackingCost`).
        plan_seconds: (N,) wall time of the planning iteration.
        num_diverged: (N,) diverged rollouts of the iteration.
    """

    columns: dict[str, list] = field(default_factory=dict)

    def append(self, **row) -> None:
        for k, v in row.items():
            self.columns.setdefault(k, []).append(np.array(v, copy=True))

    def arrays(self) -> dict[str, np.ndarray]:
        """The log as a dict of stacked arrays."""
        return {k: np.stack(v) for k, v in self.columns.items()}


def check_timing(
    plant_timestep: float, planner_timestep: float, horizon: float, replan_period: float, latency: float
) -> None:
    """Refuse timing a loop can only round: each value must be what the loop will really use.

    ``planner_timestep``, ``replan_period`` and ``latency`` must be whole multiples of the plant step
    (within :data:`TIMING_TOLERANCE`; ``latency`` may be 0), and the horizon at least one planning step.

    Raises:
        ConfigError: one line naming the values.
    """
    for name, value in (
        ("scene.planner_timestep", planner_timestep),
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
            f"(scene.planner_timestep = {planner_timestep:g} s)"
        )


def check_planner_timing(scene: Scene, planner: Planner) -> None:
    """:func:`check_timing` of a planner's horizon, replan period and fixed latency on a scene."""
    check_timing(
        scene.plant_model.opt.timestep,
        scene.planner_timestep,
        planner.horizon,
        planner.replan_period,
        planner.latency,
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
        self.draw: PerturbationDraw | None = None
        self.seed = int(seed)
        self.progress = progress
        plant_dt = scene.plant_model.opt.timestep
        check_planner_timing(scene, planner)
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
        draw, prng, m, d = self.start_plant()
        rng = np.random.default_rng(self.seed)
        dt = m.opt.timestep
        per_plan = int(round(self.replan_interval / dt))
        lag = int(round(self.latency / dt))  # plant steps on the previous plan after each replan
        n_steps = int(round(self.duration / dt))
        first = int(round(self.start_time / dt))  # the first step: the loop's clock starts there
        nstate = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        state = np.empty(nstate)
        earlier = None  # the state of one replan period earlier (draw.delay)
        pending = sorted(float(v) for v in snapshots)
        self.snapshots: dict[float, np.ndarray] = {}
        log = TrialLog()
        offsets = np.arange(per_plan) * dt
        bar = tqdm(
            total=n_steps - first,
            desc=f"{scene.task.name}",
            unit="step",
            disable=not self.progress,
            leave=False,
        )
        try:
            for k in range(first, n_steps, per_plan):
                t = k * dt
                mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
                state[0] = t  # rollouts run on the control clock
                while pending and t >= pending[0] - 1e-9:
                    self.snapshots[pending.pop(0)] = state.copy()
                seen = draw.observe(scene, state, prng)
                if draw.delay:
                    seen, earlier = (seen if earlier is None else earlier), seen.copy()
                if lag:  # the previous plan's targets until this one takes effect
                    previous = planner.targets(t + offsets[:lag])
                info = planner.plan(t, seen, rng)
                if not lag:
                    targets = planner.targets(t + offsets)
                elif lag < per_plan:
                    targets = np.concatenate([previous, planner.targets(t + offsets[lag:])])
                else:  # continuous replanning: this plan takes effect when the next one starts
                    targets = previous
                self._log(log, d, t, targets[0], info)
                for j in range(min(per_plan, n_steps - k)):
                    self.step_plant(m, d, draw, targets[j], t + j * dt, t + (j + 1) * dt)
                self.check_plant(d, t, (k + min(per_plan, n_steps - k)) * dt)
                bar.update(min(per_plan, n_steps - k))
        except PlantDiverged as err:
            err.log = log  # what happened until then, for the record
            raise
        finally:
            bar.close()
        return log

    def expected_log(self) -> tuple[np.ndarray, np.ndarray]:
        """The instants the whole trial logs (one per replan) and the links expected in contact there:
        ``(time (N,), expected_contacts (N, L))``, as :meth:`run`'s log has them."""
        dt = self.scene.plant_model.opt.timestep
        per_plan = int(round(self.replan_interval / dt))
        time = np.arange(int(round(self.start_time / dt)), int(round(self.duration / dt)), per_plan) * dt
        return time, self.track.contact_active[[self.track.index(t) for t in time]]

    # --- the plant, shared with the wall-clock loop (contactmpc.online) -------------------------
    def start_plant(self) -> tuple[PerturbationDraw, np.random.Generator, mujoco.MjModel, mujoco.MjData]:
        """Draw the perturbation (:attr:`draw`) and make the plant at its start: the hand at the committed
        policy's first targets, the object at the task's start (moved by the draw); with
        :attr:`start_time`, the hand at the policy's targets then and the object at the reference's
        configuration then (the task's start offset and the draw's applied as at t = 0), at rest.

        Returns:
            ``(draw, prng, model, data)``: the draw, its generator (observation noise), the plant model
            (the scene's own unless the draw changes it) and its data.
        """
        scene = self.scene
        prng = Perturbation.generator(self.seed)
        draw = self.draw = self.perturbation.draw(prng, self.duration, self.seed)
        m = draw.plant_model(scene)  # the scene's plant itself unless the draw changes it
        d = mujoco.MjData(m)
        hand0 = self.planner.targets(np.array([self.start_time]))[0]
        qo = self.reference.object_qpos[0]
        if self.start_time:  # the reference's object where the trial starts
            qo = self.track.object_qpos[self.track.index(self.start_time)]
        qo0 = draw.initial_object_qpos(scene, scene.task.start_object_qpos(qo))
        scene.reset(d, hand_qpos=hand0, object_qpos=qo0)
        return draw, prng, m, d

    def step_plant(
        self,
        m: mujoco.MjModel,
        d: mujoco.MjData,
        draw: PerturbationDraw,
        target: np.ndarray,
        t0: float,
        t1: float,
    ) -> None:
        """One physics step from control time ``t0`` to ``t1`` under joint ``target`` (J,), with the
        draw's pushes on the object."""
        d.ctrl[self.scene.index.actuators] = target
        force = draw.push_force(t0, t1, m.opt.timestep) if draw.push_times else None
        if force is None:
            mujoco.mj_step(m, d)
            return
        pushed = int(self.scene.index.object_bodies[0])
        d.xfrc_applied[pushed, :3] = force
        mujoco.mj_step(m, d)
        d.xfrc_applied[pushed, :3] = 0.0

    @staticmethod
    def check_plant(d: mujoco.MjData, t0: float, t1: float) -> None:
        """Raise :class:`PlantDiverged` if the plant went unstable between control times ``t0`` and ``t1``
        (a MuJoCo warning or a non-finite configuration; 1 us)."""
        if d.warning.number.any() or not np.isfinite(d.qpos).all():
            # MuJoCo resets a diverged plant (d.time restarts): name the control time
            raise PlantDiverged(f"plant diverged between t={t0:.3f}s and t={t1:.3f}s", t0)

    def _log(self, log: TrialLog, d: mujoco.MjData, t: float, target: np.ndarray, info) -> None:
        scene, tr = self.scene, self.track
        i = tr.index(t)
        qo = scene.object_qpos(d)
        err = scene.task.layout.error(qo, tr.object_qpos[i])
        log.append(
            time=t,
            qpos=d.qpos,
            hand_qpos=scene.hand_qpos(d),
            hand_target=target,
            object_qpos=qo,
            expected_object_qpos=tr.object_qpos[i],
            contacts=scene.link_contacts(d),
            expected_contacts=tr.contact_active[i],
            object_position_error=err.position,
            object_rotation_error=err.rotation,
            object_articulation_error=err.articulation,
            **{f"cost_{name}": value for name, value in info.terms.items()},
            best_cost=info.best_cost,
            nominal_cost=info.nominal_cost,
            plan_seconds=info.seconds,
            num_diverged=info.num_diverged,
        )
