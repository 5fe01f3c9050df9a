"""A second hand through the whole controller: the two-finger gripper on the Allegro's wrist.

Nothing outside ``contactmpc/hands/`` may assume the Allegro hand's 22 joints, 16 fingers or 21 links;
this builds a scene with an 8-joint, 3-link hand and runs a few closed-loop planning steps.
"""

from __future__ import annotations

import numpy as np
import pytest

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners import PredictiveSampling
from contactmpc.control.samplers import JointSplineSpace, PCASplineSpace
from contactmpc.hands import ParallelGripper
from contactmpc.scene import Scene, SceneError
from contactmpc.tasks import AppleTask
from contactmpc.trial import Trial
from tests.helpers import static_reference

# palm down 16 cm above the apple (wrist x y z rx ry rz), both fingers open
HOME = [0.0, 0.0, 0.16, np.pi, 0.0, 0.0, 0.0, 0.0]


@pytest.fixture(scope="module")
def scene() -> Scene:
    return Scene(ParallelGripper(), AppleTask(hand_home=HOME, time_scale=1.0))


def test_gripper_interface(scene):
    hand = scene.hand
    assert (hand.num_joints, hand.num_root, hand.num_fingers) == (8, 6, 2)
    assert hand.joint_names == hand.root_joints + hand.finger_joints
    assert scene.plant_model.nu == 8 and len(scene.index.link_bodies) == 3
    np.testing.assert_allclose(scene.plant_model.actuator_ctrlrange[scene.index.actuators], hand.joint_ranges)


def test_hand_home_must_match_the_hand():
    with pytest.raises(SceneError, match="hand_home has 22 entries, but hand 'parallel_gripper' has 8"):
        Scene(ParallelGripper(), AppleTask(hand_home=[0.0] * 22))


@pytest.mark.parametrize(
    "space", [PCASplineSpace(sigma2=0.2), JointSplineSpace(sigma2=0.2)], ids=["pca", "joint"]
)
def test_gripper_plans_in_closed_loop(scene, space):
    reference = static_reference(scene, active_links=3)
    planner = PredictiveSampling(num_samples=8, horizon=0.2, replan_period=0.05, nthread=1)
    trial = Trial(scene, reference, space, TrackingCost(), planner, seed=0, duration=0.3, progress=False)
    try:
        log = trial.run().arrays()
    finally:
        planner.close()
    assert space.dim == 6 + 2 and planner.theta.shape == (trial.spline.num_control_points, space.dim)
    assert log["hand_qpos"].shape == (6, 8) and log["hand_target"].shape == (6, 8)
    assert log["contacts"].shape == (6, 3)
    for term in TrackingCost.terms:
        assert np.isfinite(log[f"cost_{term}"]).all()
    assert np.isfinite(log["best_cost"]).all() and (log["best_cost"] <= log["nominal_cost"]).all()
