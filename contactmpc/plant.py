"""The plant of a trial: the simulated hand and object the controller acts on.

:class:`Plant` holds what both closed loops share, the synchronous :meth:`contactmpc.trial.Trial.run` and
the wall-clock :class:`contactmpc.online.OnlineLoop`: the perturbation drawn from the trial's seed, the
plant's model and data (:meth:`Plant.start`), its full state as the planner is given it
(:meth:`Plant.state`, :meth:`Plant.observe`), one physics step under joint targets with the draw's pushes
(:meth:`Plant.step`), the divergence check (:meth:`Plant.check`) and the log's row (:meth:`Plant.log`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from contactmpc.control.planners.base import PlanInfo
from contactmpc.control.track import ReferenceTrack
from contactmpc.perturbations import Perturbation, PerturbationDraw
from contactmpc.scene import Scene


def warnings(model: mujoco.MjModel, data: mujoco.MjData) -> str:
    """The MuJoCo warnings ``data`` has raised, as ``" (mjWARN_BADQACC at DOF 7 (its joint))"``: each
    warning's name and what MuJoCo reported with it (the DOF and its joint, for a bad qpos, qvel or qacc);
    ``""`` without any."""
    said, per_dof = [], ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")
    for name, kind in mujoco.mjtWarning.__members__.items():
        if name == "mjNWARNING" or not data.warning[int(kind)].number:
            continue
        info = int(data.warning[int(kind)].lastinfo)
        if name in per_dof and 0 <= info < model.nv:
            joint = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(model.dof_jntid[info]))
            said.append(f"{name} at DOF {info} ({joint})")
        else:
            said.append(f"{name} ({info})")
    return f" ({', '.join(said)})" if said else ""


class PlantDiverged(RuntimeError):
    """The plant simulation went unstable (MuJoCo warning or non-finite state).

    Attributes:
        time: the control time of the last replan before it went unstable (s), or ``None``.
        log: the trial's log up to that replan (set by :meth:`~contactmpc.trial.Trial.run`), or ``None``.
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
        prediction_position_error / prediction_rotation_error: (N,) with ``planner.compensate_latency``:
            the free object's errors from where the last plan predicted it (NaN without a prediction).
    """

    columns: dict[str, list] = field(default_factory=dict)

    def append(self, **row) -> None:
        for k, v in row.items():
            self.columns.setdefault(k, []).append(np.array(v, copy=True))

    def arrays(self) -> dict[str, np.ndarray]:
        """The log as a dict of stacked arrays."""
        return {k: np.stack(v) for k, v in self.columns.items()}


class Plant:
    """The simulated plant of one trial.

    Args:
        scene: the composed hand + task (its plant model, unless the draw changes it).
        track: the reference on the control clock (the log's expected object pose and contacts).
        perturbation: plant-only changes, drawn from ``seed`` at :meth:`start`.
        seed: the trial's seed.
        duration: the trial's control time (s): the span the draw's pushes fall in.

    Attributes:
        draw: the perturbation's draw (``None`` until :meth:`start`).
        prng: the draw's generator, which goes on to draw the observation noise.
        model: the plant's model: the scene's own unless the draw changes it.
        data: the plant's data.
    """

    def __init__(
        self, scene: Scene, track: ReferenceTrack, perturbation: Perturbation, seed: int, duration: float
    ) -> None:
        self.scene, self.track, self.perturbation = scene, track, perturbation
        self.seed, self.duration = int(seed), float(duration)
        self.draw: PerturbationDraw | None = None
        self.prng: np.random.Generator | None = None
        self.model: mujoco.MjModel | None = None
        self.data: mujoco.MjData | None = None

    def start(self, hand_qpos: np.ndarray, object_qpos: np.ndarray) -> None:
        """Draw the perturbation and make the plant at its start: the hand at ``hand_qpos`` (J,), the
        object at ``object_qpos`` (n_o,) moved by the draw."""
        scene = self.scene
        self.prng = Perturbation.generator(self.seed)
        self.draw = self.perturbation.draw(self.prng, self.duration, self.seed)
        self.model = self.draw.plant_model(scene)  # the scene's plant itself unless the draw changes it
        self.data = mujoco.MjData(self.model)
        qo0 = self.draw.initial_object_qpos(scene, object_qpos)
        scene.reset(self.data, hand_qpos=hand_qpos, object_qpos=qo0)

    @property
    def timestep(self) -> float:
        """The plant's physics step (s)."""
        return self.model.opt.timestep

    def state_size(self) -> int:
        """Length of :meth:`state`'s array (``mjSTATE_FULLPHYSICS``)."""
        return mujoco.mj_stateSize(self.model, mujoco.mjtState.mjSTATE_FULLPHYSICS)

    def state(self, t: float, out: np.ndarray | None = None) -> np.ndarray:
        """The plant's full physics state (``mjSTATE_FULLPHYSICS``) with its time set to control time
        ``t`` (rollouts run on the control clock), written into ``out`` if given."""
        state = np.empty(self.state_size()) if out is None else out
        mujoco.mj_getState(self.model, self.data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        state[0] = t
        return state

    def observe(self, state: np.ndarray) -> np.ndarray:
        """The state as the planner is given it: with the draw's observation noise."""
        return self.draw.observe(self.scene, state, self.prng)

    def step(self, target: np.ndarray, t0: float, t1: float) -> None:
        """One physics step from control time ``t0`` to ``t1`` under joint ``target`` (J,), with the
        draw's pushes on the object."""
        m, d, draw = self.model, self.data, self.draw
        d.ctrl[self.scene.index.actuators] = target
        force = draw.push_force(t0, t1, m.opt.timestep) if draw.push_times else None
        if force is None:
            mujoco.mj_step(m, d)
            return
        pushed = int(self.scene.index.object_bodies[0])
        d.xfrc_applied[pushed, :3] = force
        mujoco.mj_step(m, d)
        d.xfrc_applied[pushed, :3] = 0.0

    def check(self, t0: float, t1: float) -> None:
        """Raise :class:`PlantDiverged` if the plant went unstable between control times ``t0`` and ``t1``
        (a MuJoCo warning or a non-finite configuration)."""
        d = self.data
        if d.warning.number.any() or not np.isfinite(d.qpos).all():
            # MuJoCo resets a diverged plant (d.time restarts): name the control time, and the warning
            said = warnings(self.model, d)
            raise PlantDiverged(f"plant diverged between t={t0:.3f}s and t={t1:.3f}s{said}", t0)

    def log(
        self, log: TrialLog, t: float, target: np.ndarray, info: PlanInfo, reference_time: float | None = None
    ) -> None:
        """Append the row of control time ``t`` to ``log``: the plant's state, the joint ``target`` (J,)
        sent, the reference there and the tracking errors, and what the planning iteration in use did.
        With ``reference_time`` (a paced reference, ``planner.pace_lag``) the reference is read there, and
        the row has it (``reference_time``)."""
        scene, tr, d = self.scene, self.track, self.data
        i = tr.index(t if reference_time is None else reference_time)
        paced = {} if reference_time is None else {"reference_time": reference_time}
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
            **paced,
            **_plan_columns(info),
        )


def _plan_columns(info: PlanInfo) -> dict[str, float]:
    """A log row's columns of the planning iteration ``info``: the committed sample's cost terms
    (``cost_<term>``), the best and the nominal cost, its wall time and its diverged rollouts; with a
    prediction for its time (``planner.compensate_latency``), the free object's errors from it
    (``prediction_position_error``, m; ``prediction_rotation_error``, rad)."""
    columns = {
        **{f"cost_{name}": value for name, value in info.terms.items()},
        "best_cost": info.best_cost,
        "nominal_cost": info.nominal_cost,
        "plan_seconds": info.seconds,
        "num_diverged": info.num_diverged,
    }
    if info.prediction is not None:
        columns["prediction_position_error"], columns["prediction_rotation_error"] = info.prediction
    return columns
