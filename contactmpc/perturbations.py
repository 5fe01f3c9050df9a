"""Plant-only perturbations of a trial (the ``perturbation`` config group), drawn from the trial's seed.

A :class:`Perturbation` says how far the plant may differ from the model the planner keeps: the object's
initial pose, its mass, friction and size, the finger servos' gains, pushes on the object, noise on the
object state the planner is given, and a planning delay. :meth:`Perturbation.draw` turns it into one
:class:`PerturbationDraw` from its own generator seeded by the trial's seed (``(seed, 1)``), so the
planner's random stream is the same with and without a perturbation, the same seed draws the same
values, and a trial with nothing to draw (``perturbation=none``, every width zero) runs bit for bit as
without one. The drawn values go into the trial's record (``perturbation``).

The planner's model is never changed: :meth:`PerturbationDraw.plant_model` returns a changed *copy* of
the plant (the scene's own models are left alone), and only the plant's initial state, forces and the
planner's view of the state are touched by the loop (:class:`~contactmpc.trial.Trial`).
"""

from __future__ import annotations

import copy
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Annotated

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from contactmpc.validate import ConfigError, Ge, Le, OneOf, checked

if TYPE_CHECKING:
    from contactmpc.scene import Scene

__all__ = ["Perturbation", "PerturbationDraw"]

_SEED_STREAM = 1  # the draw's generator is default_rng((seed, 1)); the planner's is default_rng(seed)


@dataclass(frozen=True)
class PerturbationDraw:
    """One trial's drawn perturbation (all identities when nothing is drawn).

    Attributes:
        object_offset: (3,) world offset of the object's initial position (m); free objects only.
        object_yaw: turn of the object's initial orientation about world z (rad); free objects only.
        mass_scale: factor on the object bodies' masses and inertias.
        friction_scale: factor on the object geoms' sliding friction.
        size_scale: factor on the object geoms' sizes and positions (and their meshes), about each body.
        gain_scale: factor on the finger servos' position gains.
        push_times: (K,) control times of the pushes on the object (s).
        push_impulses: (K, 3) world impulse of each push (N s), applied over one physics step.
        observation_noise: standard deviation of the noise on the object configuration the planner is
            given (m for positions and slides, rad for angles).
        delay: the planner is given the state of one replan period earlier.
        seed: the generator's seed, ``(seed, 1)``.
    """

    object_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    object_yaw: float = 0.0
    mass_scale: float = 1.0
    friction_scale: float = 1.0
    size_scale: float = 1.0
    gain_scale: float = 1.0
    push_times: tuple[float, ...] = ()
    push_impulses: tuple[tuple[float, float, float], ...] = ()
    observation_noise: float = 0.0
    delay: bool = False
    seed: tuple[int, int] = (0, _SEED_STREAM)

    @property
    def changes_model(self) -> bool:
        """Whether the plant model differs from the scene's."""
        return (self.mass_scale, self.friction_scale, self.size_scale, self.gain_scale) != (
            1.0,
            1.0,
            1.0,
            1.0,
        )

    def record(self) -> dict:
        """The draw as JSON-ready values (for the trial's record)."""
        out = asdict(self)
        out["object_offset"] = list(self.object_offset)
        out["push_times"] = list(self.push_times)
        out["push_impulses"] = [list(p) for p in self.push_impulses]
        out["seed"] = list(self.seed)
        return out

    # --- the plant ----------------------------------------------------------------------------
    def plant_model(self, scene: Scene) -> mujoco.MjModel:
        """The plant of this draw: ``scene.plant_model`` itself when nothing changes, else a changed copy.

        Raises:
            ValueError: a size scale on a scene whose object geoms cannot be scaled.
        """
        if not self.changes_model:
            return scene.plant_model
        if self.size_scale != 1.0:
            model = self._scaled_plant(scene)
        else:
            model = copy.copy(scene.plant_model)
        idx = scene.index
        bodies = np.flatnonzero(idx.object_body_mask)  # the same body ids in a recompiled copy
        model.body_mass[bodies] *= self.mass_scale
        model.body_inertia[bodies] *= self.mass_scale
        geoms = np.flatnonzero(np.isin(model.geom_bodyid, bodies))
        model.geom_friction[geoms, 0] *= self.friction_scale
        fingers = idx.actuators[scene.hand.num_root :]
        model.actuator_gainprm[fingers, 0] *= self.gain_scale
        model.actuator_biasprm[fingers, 1] *= self.gain_scale  # position servo: bias = -kp q
        return model

    def _scaled_plant(self, scene: Scene) -> mujoco.MjModel:
        spec = scene.spec.copy()
        model = scene.plant_model
        names = {model.body(int(b)).name for b in np.flatnonzero(scene.index.object_body_mask)}
        s = self.size_scale
        meshes: set[str] = set()
        for body in spec.bodies:
            if body.name not in names:
                continue
            for geom in body.geoms:
                geom.pos = [s * v for v in geom.pos]
                if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
                    meshes.add(geom.meshname)
                elif geom.type != mujoco.mjtGeom.mjGEOM_PLANE:
                    geom.size = [s * v for v in geom.size]
                if not np.isnan(geom.fromto[0]):
                    geom.fromto = [s * v for v in geom.fromto]
        for mesh in spec.meshes:
            if mesh.name in meshes:
                mesh.scale = [s * v for v in mesh.scale]
        spec.option.timestep = scene.plant_model.opt.timestep
        return spec.compile()

    def initial_object_qpos(self, scene: Scene, qo: np.ndarray) -> np.ndarray:
        """(n_o,) the object's initial configuration moved by the drawn offset and yaw (free objects)."""
        out = np.array(qo, dtype=float, copy=True)
        layout = scene.task.layout
        if layout.quat_index is None or (not any(self.object_offset) and self.object_yaw == 0.0):
            return out
        c = layout.free_columns[0]
        out[c : c + 3] += self.object_offset
        turned = Rotation.from_euler("z", self.object_yaw) * Rotation.from_quat(
            out[c + 3 : c + 7], scalar_first=True
        )
        out[c + 3 : c + 7] = turned.as_quat(scalar_first=True)
        return out

    # --- the loop -----------------------------------------------------------------------------
    def push_force(self, t0: float, t1: float, dt: float) -> np.ndarray | None:
        """(3,) world force for the physics step ``[t0, t1)``: the pushes whose time falls in it, each
        impulse spread over the step ``dt``; None when there is none."""
        hits = [i for i, tp in enumerate(self.push_times) if t0 <= tp < t1]
        if not hits:
            return None
        return np.sum([self.push_impulses[i] for i in hits], axis=0) / dt

    def observe(self, scene: Scene, state: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The state the planner is given: ``state`` (mjSTATE_FULLPHYSICS: time, qpos, ...) with noise of
        ``observation_noise`` on the object configuration (positions and slides additively, free-body
        orientations by a random rotation of that angle spread). Unchanged (same array) without noise."""
        if self.observation_noise == 0.0:
            return state
        out = state.copy()
        adr = 1 + scene.index.object_qpos  # qpos starts after time in the full-physics state
        layout = scene.task.layout
        sigma = self.observation_noise
        for c in layout.free_columns:
            out[adr[c : c + 3]] += rng.normal(0.0, sigma, 3)
            q = Rotation.from_quat(out[adr[c + 3 : c + 7]], scalar_first=True)
            out[adr[c + 3 : c + 7]] = (Rotation.from_rotvec(rng.normal(0.0, sigma, 3)) * q).as_quat(
                scalar_first=True
            )
        for c in layout.articulation_columns:
            out[adr[c]] += rng.normal(0.0, sigma)
        return out


def support(model: mujoco.MjModel, position: np.ndarray) -> tuple[str, float] | None:
    """What an object at ``position`` stands on: the highest static, colliding box or plane with a
    level top at or below ``position`` whose footprint holds it, and how far the position is from the
    footprint's nearest edge (m; ``inf`` for an unbounded plane). ``None`` when nothing holds it.

    Args:
        model: the plant model.
        position: (3,) world position (e.g. a free object's initial position).
    """
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    best: tuple[float, str, float] | None = None  # (top height, name, reach)
    box, plane = int(mujoco.mjtGeom.mjGEOM_BOX), int(mujoco.mjtGeom.mjGEOM_PLANE)
    for g in range(model.ngeom):
        static = model.body_weldid[model.geom_bodyid[g]] == 0
        collides = model.geom_contype[g] or model.geom_conaffinity[g]
        kind = int(model.geom_type[g])
        if not (static and collides and kind in (box, plane)):
            continue
        frame = data.geom_xmat[g].reshape(3, 3)
        if frame[2, 2] < 0.999:  # not level
            continue
        size = model.geom_size[g]
        top = data.geom_xpos[g][2] + (size[2] if kind == box else 0.0)
        if top > position[2] + 1e-6:
            continue
        local = frame.T @ (position - data.geom_xpos[g])
        half = [np.inf if kind == plane and v == 0 else v for v in size[:2]]
        reach = min(half[0] - abs(local[0]), half[1] - abs(local[1]))
        if reach >= 0 and (best is None or top > best[0]):
            best = (top, model.geom(g).name, float(reach))
    return None if best is None else best[1:]


class Perturbation:
    """How far the plant may differ from the planner's model; every width 0 (the default) is none.

    Scales are drawn uniformly in ``[1 - w, 1 + w]`` for a half-width ``w`` (``scale_draw="uniform"``),
    or set to its edge, ``1 + w`` (``"high"``) or ``1 - w`` (``"low"``), when an experiment asks how large
    an error a method survives.

    Args:
        object_offset: distance (m) of the object's initial position from the reference's, horizontal, in
            a uniformly drawn direction (free objects; an articulated object is not moved).
        object_yaw: largest turn (rad) of the object's initial orientation about world z, drawn uniformly
            in ``[-object_yaw, object_yaw]``.
        mass_scale: half-width of the factor on the object's masses and inertias.
        friction_scale: half-width of the factor on the object geoms' sliding friction.
        size_scale: half-width of the factor on the object's geoms (and meshes) about their bodies.
        gain_scale: half-width of the factor on the finger servos' position gains.
        pushes: number of pushes on the object, at uniform times in ``[0, duration)``.
        push_impulse: impulse of each push (N s), horizontal, in a uniformly drawn direction.
        observation_noise: standard deviation of the noise on the object configuration the planner is
            given (m, rad), drawn afresh at every replan.
        delay: give the planner the state of one replan period earlier.
        scale_draw: how a scale's factor is drawn from its half-width ``w``: ``uniform`` in
            ``[1 - w, 1 + w]``, or exactly ``1 + w`` (``high``) or ``1 - w`` (``low``), drawing no number.
    """

    @checked
    def __init__(
        self,
        object_offset: Annotated[float, Ge(0)] = 0.0,
        object_yaw: Annotated[float, Ge(0)] = 0.0,
        mass_scale: Annotated[float, Ge(0), Le(0.99)] = 0.0,
        friction_scale: Annotated[float, Ge(0), Le(0.99)] = 0.0,
        size_scale: Annotated[float, Ge(0), Le(0.99)] = 0.0,
        gain_scale: Annotated[float, Ge(0), Le(0.99)] = 0.0,
        pushes: Annotated[int, Ge(0)] = 0,
        push_impulse: Annotated[float, Ge(0)] = 0.0,
        observation_noise: Annotated[float, Ge(0)] = 0.0,
        delay: bool = False,
        scale_draw: Annotated[str, OneOf("uniform", "high", "low")] = "uniform",
    ) -> None:
        self.object_offset = float(object_offset)
        self.object_yaw = float(object_yaw)
        self.mass_scale = float(mass_scale)
        self.friction_scale = float(friction_scale)
        self.size_scale = float(size_scale)
        self.gain_scale = float(gain_scale)
        self.pushes = int(pushes)
        self.push_impulse = float(push_impulse)
        self.observation_noise = float(observation_noise)
        self.delay = bool(delay)
        self.scale_draw = scale_draw

    def check(self, scene: Scene, object_qpos: np.ndarray) -> None:
        """Refuse what the plant cannot physically take: an object offset on a task without a free
        object (it would be ignored), or one that puts the object beyond the edge of what it stands on.
        (A scale's half-width is at most 0.99, so no mass, friction or size reaches 0.)

        Args:
            scene: the scene.
            object_qpos: (n_o,) the object's configuration at the start of the trial.

        Raises:
            ConfigError: one line naming the value and the support.
        """
        if self.object_offset == 0.0:
            return
        task = scene.task
        if task.layout.quat_index is None:
            raise ConfigError(
                f"perturbation.object_offset = {self.object_offset:g} m moves a free object, and task "
                f"'{task.name}' has none"
            )
        c = task.layout.free_columns[0]
        found = support(scene.plant_model, np.asarray(object_qpos[c : c + 3], dtype=float))
        if found is not None and self.object_offset > found[1]:
            raise ConfigError(
                f"perturbation.object_offset = {self.object_offset:g} m takes the object of task "
                f"'{task.name}' off its support: geom '{found[0]}' ends {found[1]:.3f} m from its start"
            )

    @staticmethod
    def generator(seed: int) -> np.random.Generator:
        """The perturbation's generator of a trial (separate from the planner's)."""
        return np.random.default_rng((int(seed), _SEED_STREAM))

    def draw(self, rng: np.random.Generator, duration: float, seed: int = 0) -> PerturbationDraw:
        """Draw one trial's perturbation. A zero width draws nothing (its identity) and takes no numbers
        from ``rng``, so ``Perturbation()`` draws the identity and leaves ``rng`` untouched.

        Args:
            rng: :meth:`generator` of the trial's seed.
            duration: the trial's control time (s), for the push times.
            seed: the trial's seed (recorded).
        """

        def scale(width: float) -> float:
            if self.scale_draw == "high":
                return 1.0 + width
            if self.scale_draw == "low":
                return 1.0 - width
            return float(rng.uniform(1.0 - width, 1.0 + width)) if width > 0 else 1.0

        offset = (0.0, 0.0, 0.0)
        if self.object_offset > 0:
            a = rng.uniform(0.0, 2.0 * np.pi)
            offset = (self.object_offset * float(np.cos(a)), self.object_offset * float(np.sin(a)), 0.0)
        yaw = float(rng.uniform(-self.object_yaw, self.object_yaw)) if self.object_yaw > 0 else 0.0
        mass, friction, size, gain = (
            scale(w) for w in (self.mass_scale, self.friction_scale, self.size_scale, self.gain_scale)
        )
        times: tuple[float, ...] = ()
        impulses: tuple[tuple[float, float, float], ...] = ()
        if self.pushes > 0 and self.push_impulse > 0:
            times = tuple(sorted(float(t) for t in rng.uniform(0.0, duration, self.pushes)))
            angles = rng.uniform(0.0, 2.0 * np.pi, self.pushes)
            impulses = tuple(
                (self.push_impulse * float(np.cos(a)), self.push_impulse * float(np.sin(a)), 0.0)
                for a in angles
            )
        return PerturbationDraw(
            object_offset=offset,
            object_yaw=yaw,
            mass_scale=mass,
            friction_scale=friction,
            size_scale=size,
            gain_scale=gain,
            push_times=times,
            push_impulses=impulses,
            observation_noise=self.observation_noise,
            delay=self.delay,
            seed=(int(seed), _SEED_STREAM),
        )
