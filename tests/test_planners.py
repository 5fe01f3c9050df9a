"""Planners on a toy problem, and planning invariants on the real scenes."""

from __future__ import annotations

import numpy as np
import pytest

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners import CEM, MPPI, PredictiveSampling, Replay
from contactmpc.control.samplers import JointSplineSpace, PCASplineSpace
from contactmpc.trial import Trial
from tests.helpers import PointMassProblem, static_reference

PLANNERS = {
    "predictive_sampling": lambda: PredictiveSampling(num_samples=64, horizon=1.0, replan_period=0.01),
    "mppi": lambda: MPPI(num_samples=64, horizon=1.0, replan_period=0.01, temperature=0.1),
    "cem": lambda: CEM(num_samples=64, horizon=1.0, replan_period=0.01, num_elites=8),
}


@pytest.mark.parametrize("name", sorted(PLANNERS))
def test_planner_reaches_goal_on_point_mass(name):
    problem = PointMassProblem()
    planner = PLANNERS[name]()
    problem.bind(planner)
    rng = np.random.default_rng(0)
    start = problem.final_distance(planner)
    first = planner.plan(0.0, problem.state, rng)
    for _ in range(14):
        last = planner.plan(0.0, problem.state, rng)
    end = problem.final_distance(planner)
    # The planners minimise the cost summed over the horizon: it must drop by nearly an order of
    # magnitude (the lag of the servo bounds it from below), and the mass must end near the goal.
    assert last.best_cost < first.nominal_cost / 8, (
        f"{name}: {first.nominal_cost:.2f} -> {last.best_cost:.2f}"
    )
    assert start > 0.3
    assert end < 0.1, f"{name}: distance to goal {start:.3f} -> {end:.3f}"
    problem.engine.close()


def test_replay_never_changes_the_nominal():
    problem = PointMassProblem()
    planner = Replay(num_samples=1, horizon=1.0, replan_period=0.01)
    problem.bind(planner)
    theta = planner.theta.copy()
    info = planner.plan(0.0, problem.state, np.random.default_rng(0))
    np.testing.assert_array_equal(planner.theta, theta)
    assert np.isnan(info.best_cost)
    problem.engine.close()


def test_predictive_sampling_never_worse_than_incumbent():
    problem = PointMassProblem(sigma=0.5)
    planner = PredictiveSampling(num_samples=16, horizon=1.0, replan_period=0.01)
    problem.bind(planner)
    rng = np.random.default_rng(1)
    previous = np.inf
    for _ in range(10):
        info = planner.plan(0.0, problem.state, rng)
        assert info.best_cost <= info.nominal_cost
        # Rollouts are deterministic: the incumbent's cost is the previous winner's cost.
        assert info.nominal_cost <= previous + 1e-12
        previous = info.best_cost
    problem.engine.close()


@pytest.fixture(scope="module")
def apple_trial_parts(scene_for):
    scene = scene_for("apple")
    return scene, static_reference(scene)


@pytest.mark.parametrize("space_cls", [PCASplineSpace, JointSplineSpace])
def test_only_window_points_change_and_root_is_fixed(apple_trial_parts, space_cls):
    scene, ref = apple_trial_parts
    planner = PredictiveSampling(num_samples=8, horizon=0.3, replan_period=0.05, nthread=1)
    Trial(  # binds the planner to the scene, reference, space and cost
        scene,
        ref,
        space_cls(0.2, root_sigma2=0.0),
        TrackingCost(),
        planner,
        seed=0,
        num_control_points=12,
        progress=False,
    )
    rng = np.random.default_rng(0)
    state = _plant_state(scene)
    for t in (0.0, 1.5, 3.0):
        before = planner.theta.copy()
        info = planner.plan(t, state, rng)
        changed = np.flatnonzero(np.any(planner.theta != before, axis=1))
        assert set(changed) <= set(info.window.tolist())
        assert len(info.window) < planner.theta.shape[0]
        np.testing.assert_array_equal(planner.theta[:, :6], before[:, :6])
    planner.close()


def _plant_state(scene):
    import mujoco

    d = scene.make_data()
    m = scene.plant_model
    s = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(m, d, s, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    return s
