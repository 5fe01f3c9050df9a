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


SEEDS = range(6)


@pytest.mark.parametrize("name", sorted(PLANNERS))
def test_planner_reaches_goal_on_point_mass(name):
    """15 iterations from the same start, over several seeds: a seed stands in for another CPU's float
    path (which sample wins moves with both), so the test asserts what holds across seeds, not one
    seed's outcome. Measured over 8 seeds (cost ratio first / last; distance start 0.36 -> end):
    predictive sampling 6.6-12.4x, end 0.03-0.38 m; MPPI 12-20x, 0.03-0.22 m; CEM 15-19x, 0.005-0.06 m.
    Predictive sampling only keeps its best sample, so one seed can end farther than it began."""
    ratios, ends = [], []
    for seed in SEEDS:
        problem = PointMassProblem()
        planner = PLANNERS[name]()
        problem.bind(planner)
        rng = np.random.default_rng(seed)
        start = problem.final_distance(planner)
        first = planner.plan(0.0, problem.state, rng)
        for _ in range(14):
            last = planner.plan(0.0, problem.state, rng)
        ratios.append(first.nominal_cost / last.best_cost)
        ends.append(problem.final_distance(planner))
        problem.engine.close()
    assert start > 0.3
    # The cost summed over the horizon drops several-fold on every seed (the servo's lag bounds it
    # from below), and the mass ends nearer the goal than it began on the median seed.
    summary = f"{name}: cost ratios {np.round(ratios, 1)}, end distances {np.round(ends, 3)} from {start:.3f}"
    assert min(ratios) > 4 and np.median(ratios) > 5, summary
    assert np.median(ends) < start, summary


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
