"""Test helpers: a simple hand-made reference for a scene, and a toy point-mass planning problem."""

from __future__ import annotations

from types import SimpleNamespace

import mujoco
import numpy as np

from contactmpc.control.problem import Problem
from contactmpc.control.rollout import RolloutEngine
from contactmpc.reference import Reference
from contactmpc.reference.bspline import UniformBSpline


def static_reference(scene, duration: float = 1.0, frames: int = 26, active_links: int = 8) -> Reference:
    """A reference that holds the object still while the fingers flex a little.

    The first ``active_links`` links expect contact at their origins with the object's origin, so the
    contact term is non-zero and varies with the hand.
    """
    hand = scene.hand
    t = np.linspace(0.0, duration, frames)
    hq = np.tile(scene.task.hand_home, (frames, 1))
    fingers, ranges = slice(hand.num_root, None), hand.finger_ranges
    hq[:, fingers] += 0.3 * np.sin(np.pi * t / duration)[:, None] * np.linspace(0.2, 1.0, hand.num_fingers)
    hq[:, fingers] = np.clip(hq[:, fingers], ranges[:, 0], ranges[:, 1])
    qo = np.tile(scene.task.initial_object_qpos(scene.plant_model), (frames, 1))
    L = len(hand.link_names)
    active = np.zeros((frames, L), bool)
    active[:, :active_links] = True
    return Reference(
        time=t,
        hand_qpos=hq,
        object_qpos=qo,
        contact_active=active,
        contact_link_point=np.zeros((frames, L, 3)),
        contact_object_point=np.zeros((frames, L, 3)),
        contact_object_body=np.zeros((frames, L), np.int64),
        link_names=np.array(hand.link_names),
        joint_names=np.array(hand.joint_names),
        object_bodies=np.array(scene.task.object_bodies),
        task=scene.task.name,
        meta={"source": "test", "object_quat_index": scene.task.layout.quat_index},
    )


POINT_MASS = """
<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="mass">
      <joint name="x" type="slide" axis="1 0 0" damping="2"/>
      <joint name="y" type="slide" axis="0 1 0" damping="2"/>
      <geom type="sphere" size="0.02" mass="0.1"/>
    </body>
  </worldbody>
  <actuator>
    <position joint="x" kp="20" ctrlrange="-1 1"/>
    <position joint="y" kp="20" ctrlrange="-1 1"/>
  </actuator>
  <sensor><framepos objtype="body" objname="mass"/></sensor>
</mujoco>
"""


class _GoalCost:
    """Squared distance of the point mass (sensordata columns 0:2) to a goal, one term per step."""

    terms = ("goal",)

    def __init__(self, goal: np.ndarray) -> None:
        self.goal = goal

    def __call__(self, sensordata: np.ndarray, window: slice) -> dict[str, np.ndarray]:
        return {"goal": np.sum((sensordata[..., :2] - self.goal) ** 2, axis=-1)}


class PointMassProblem:
    """A toy planning problem: spline targets for a damped point mass that should reach ``goal``.

    It offers the attributes the planner base class uses (duck-typed scene, track, space, cost).
    """

    def __init__(self, goal=(0.3, -0.2), horizon: float = 1.0, sigma: float = 0.3, num_points: int = 6):
        model = mujoco.MjModel.from_xml_string(POINT_MASS)
        self.model = model
        self.goal = np.asarray(goal)
        self.scene = SimpleNamespace(planner_model=model, index=SimpleNamespace(actuators=np.arange(2)))
        self.spline = UniformBSpline(num_points, (0.0, horizon))
        steps = int(round(horizon / model.opt.timestep))
        self.track = SimpleNamespace(
            index=lambda t: int(round(t / model.opt.timestep)),
            window=lambda t, n: slice(0, n),
        )
        ranges = model.actuator_ctrlrange.copy()
        self.space = SimpleNamespace(
            noise_std=np.full(2, sigma),
            controls=lambda theta, basis: np.clip(basis @ theta, ranges[:, 0], ranges[:, 1]),
        )
        self.cost = _GoalCost(self.goal)
        self.steps = steps
        data = mujoco.MjData(model)
        self.state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
        mujoco.mj_getState(model, data, self.state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        self.engine = RolloutEngine(model, nthread=1)

    def bind(self, planner) -> None:
        planner.engine = self.engine
        problem = Problem(self.scene, self.track, self.spline, self.space, self.cost, np.zeros((6, 2)), 1.0)
        planner.bind(problem)

    def final_distance(self, planner) -> float:
        """Distance to the goal at the end of the horizon, rolling out the committed nominal."""
        ctrl = planner.controls(planner.theta[None], planner.basis(0.0))
        _, sd, _ = self.engine.run(self.state, ctrl)
        return float(np.linalg.norm(sd[0, -1, :2] - self.goal))


def assert_resets_once_at(planner, problem, at: float, state, rng, target) -> np.ndarray:
    """For a planner whose committed control points walked 0.3 from ``problem.theta0``: a plan before
    ``at`` leaves them; the first plan at or after it puts those whose support meets the rest of the trial
    to ``target``'s (the others kept); a later plan does not reset them again. Returns the indices reset."""
    planner.plan(at - 0.1, state, rng)  # before: carries on
    np.testing.assert_array_equal(planner.theta, problem.theta0 + 0.3)
    planner.plan(at + 0.005, state, rng)  # the first plan at or after it
    reset = problem.spline.window_indices(at, problem.spline.domain[1] - at)
    kept = np.setdiff1d(np.arange(len(planner.theta)), reset)
    assert 0 < len(reset) < len(planner.theta)
    np.testing.assert_array_equal(planner.theta[reset], target[reset])
    np.testing.assert_array_equal(planner.theta[kept], problem.theta0[kept] + 0.3)
    planner.theta[reset] += 0.1  # once: a later plan does not reset again
    planner.plan(at + 0.1, state, rng)
    np.testing.assert_array_equal(planner.theta[reset], target[reset] + 0.1)
    return reset


def rest_state(model) -> np.ndarray:
    """The full-physics state of a fresh ``MjData`` of ``model`` (at rest, where the model puts it)."""
    data = mujoco.MjData(model)
    state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    return state
