"""Plant-only perturbations (contactmpc.perturbations): seeded draws, only the plant changes, none is none."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners import PredictiveSampling
from contactmpc.control.samplers import PCASplineSpace
from contactmpc.perturbations import Perturbation, PerturbationDraw
from contactmpc.trial import Trial
from tests.helpers import static_reference

EVERYTHING = Perturbation(
    object_offset=0.02,
    object_yaw=0.3,
    mass_scale=0.3,
    friction_scale=0.3,
    size_scale=0.1,
    gain_scale=0.3,
    pushes=2,
    push_impulse=0.05,
    observation_noise=0.005,
    delay=True,
)


def _run(scene, ref, seed: int, perturbation=None, duration: float = 0.4):
    planner = PredictiveSampling(num_samples=8, horizon=0.2, replan_period=0.05, nthread=1)
    trial = Trial(
        scene, ref, PCASplineSpace(0.2), TrackingCost(lambda_v=0.0), planner, seed,
        duration=duration, progress=False, perturbation=perturbation,
    )  # fmt: skip
    try:
        return trial, trial.run().arrays()
    finally:
        planner.close()


def test_draws_are_seeded_recorded_and_none_draws_nothing() -> None:
    a = EVERYTHING.draw(Perturbation.generator(3), 10.0, 3)
    b = EVERYTHING.draw(Perturbation.generator(3), 10.0, 3)
    c = EVERYTHING.draw(Perturbation.generator(4), 10.0, 4)
    assert a == b and a != c
    assert np.linalg.norm(a.object_offset) == pytest.approx(0.02) and a.object_offset[2] == 0.0
    assert 0.7 <= a.mass_scale <= 1.3 and 0.9 <= a.size_scale <= 1.1 and abs(a.object_yaw) <= 0.3
    assert len(a.push_times) == 2 and all(0 <= t < 10 for t in a.push_times)
    np.testing.assert_allclose(np.linalg.norm(a.push_impulses, axis=1), 0.05)
    assert json.loads(json.dumps(a.record()))["push_times"] == list(a.push_times)
    rng = Perturbation.generator(3)
    before = rng.bit_generator.state
    assert Perturbation().draw(rng, 10.0, 3) == PerturbationDraw(seed=(3, 1))
    assert rng.bit_generator.state == before  # nothing drawn, no number taken


def test_edge_draws_set_the_factor_and_take_no_number() -> None:
    rng = Perturbation.generator(5)
    before = rng.bit_generator.state
    high = Perturbation(mass_scale=0.6, gain_scale=0.2, scale_draw="high").draw(rng, 10.0, 5)
    low = Perturbation(mass_scale=0.6, scale_draw="low").draw(rng, 10.0, 5)
    assert rng.bit_generator.state == before
    assert high.mass_scale == pytest.approx(1.6) and high.gain_scale == pytest.approx(1.2)
    assert low.mass_scale == pytest.approx(0.4) and low.friction_scale == 1.0
    with pytest.raises(ValueError, match="scale_draw"):
        Perturbation(mass_scale=0.6, scale_draw="max")


def test_no_perturbation_is_bit_identical(scene_for) -> None:
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.5, frames=11)
    _, plain = _run(scene, ref, 5)
    trial, none = _run(scene, ref, 5, Perturbation())
    assert trial.draw.plant_model(scene) is scene.plant_model
    for key in plain:
        if key != "plan_seconds":
            np.testing.assert_array_equal(plain[key], none[key], err_msg=key)


def test_physics_change_only_the_plant(scene_for) -> None:
    scene = scene_for("apple")
    planner_before = {
        f: getattr(scene.planner_model, f).copy()
        for f in ("body_mass", "geom_size", "geom_friction", "actuator_gainprm")
    }
    plant_before = scene.plant_model.body_mass.copy()
    draw = Perturbation(mass_scale=0.5, friction_scale=0.5, size_scale=0.2, gain_scale=0.5).draw(
        Perturbation.generator(1), 1.0, 1
    )
    plant = draw.plant_model(scene)
    body = scene.index.object_bodies[0]
    # the apple's geoms have explicit masses: a size change keeps them, the mass scale scales them
    assert plant.body_mass[body] == pytest.approx(plant_before[body] * draw.mass_scale, rel=1e-9)
    apple = mujoco.mj_name2id(plant, mujoco.mjtObj.mjOBJ_GEOM, "apple_col")
    np.testing.assert_allclose(plant.geom_size[apple], scene.plant_model.geom_size[apple] * draw.size_scale)
    np.testing.assert_allclose(
        plant.geom_friction[apple, 0], scene.plant_model.geom_friction[apple, 0] * draw.friction_scale
    )
    finger = scene.index.actuators[scene.hand.num_root]
    assert plant.actuator_gainprm[finger, 0] == pytest.approx(
        scene.plant_model.actuator_gainprm[finger, 0] * draw.gain_scale
    )
    assert plant.actuator_biasprm[finger, 1] == pytest.approx(
        scene.plant_model.actuator_biasprm[finger, 1] * draw.gain_scale
    )
    wrist = scene.index.actuators[0]
    assert plant.actuator_gainprm[wrist, 0] == scene.plant_model.actuator_gainprm[wrist, 0]
    for field, value in planner_before.items():  # the planner's model and the scene's plant untouched
        np.testing.assert_array_equal(getattr(scene.planner_model, field), value, err_msg=field)
    np.testing.assert_array_equal(scene.plant_model.body_mass, plant_before)


def test_every_perturbation_runs_and_moves_the_plant(scene_for) -> None:
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.5, frames=11)
    _, plain = _run(scene, ref, 2)
    trial, log = _run(scene, ref, 2, EVERYTHING)
    draw = trial.draw
    start = log["object_qpos"][0]
    np.testing.assert_allclose(start[:2] - plain["object_qpos"][0][:2], draw.object_offset[:2], atol=2e-3)
    # What the planner saw differs (the object 2 cm off, noise, a delay), by far more than any float
    # path could: its nominal's cost. Its choice may not: the best of 8 samples can be the same one
    # (the hand targets then match bit for bit, as on some CPUs), so they are not compared.
    seen = np.abs(log["nominal_cost"] - plain["nominal_cost"]) / np.abs(plain["nominal_cost"])
    assert seen.max() > 1e-3, seen
    assert draw.plant_model(scene) is not scene.plant_model  # mass, friction, size, gains
    assert np.isfinite(log["object_qpos"]).all()


def test_a_push_moves_the_object(scene_for) -> None:
    scene = scene_for("apple")
    draw = PerturbationDraw(push_times=(0.1,), push_impulses=((0.5, 0.0, 0.0),))
    dt = scene.plant_model.opt.timestep
    np.testing.assert_allclose(draw.push_force(0.1, 0.1 + dt, dt), [0.5 / dt, 0.0, 0.0])
    assert draw.push_force(0.0, dt, dt) is None


def test_observation_noise_touches_only_the_objects_configuration(scene_for) -> None:
    scene = scene_for("apple")
    d = scene.make_data()
    state = np.empty(mujoco.mj_stateSize(scene.plant_model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(scene.plant_model, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    seen = PerturbationDraw(observation_noise=0.01).observe(scene, state, np.random.default_rng(0))
    changed = np.flatnonzero(seen != state)
    assert set(changed) <= set(1 + scene.index.object_qpos) and len(changed) >= 3
    quat = seen[1 + scene.index.object_qpos[3:7]]
    assert np.linalg.norm(quat) == pytest.approx(1.0)


def test_wrist_noise_per_axis() -> None:
    """root_sigma2 on the wrist slides, root_rotation_sigma2 on its hinges (None: the same for both)."""
    from contactmpc.control.samplers import JointSplineSpace
    from contactmpc.reference.bspline import UniformBSpline

    times = np.linspace(0, 1, 20)
    qpos = np.random.default_rng(0).normal(size=(20, 22))
    ranges = np.tile([-10.0, 10.0], (22, 1))
    space = JointSplineSpace(0.2, root_sigma2=1e-4, root_rotation_sigma2=0.01)
    space.fit(UniformBSpline(6, (0.0, 1.0)), times, qpos, ranges, 6)
    np.testing.assert_allclose(space.noise_std[:6], [0.01] * 3 + [0.1] * 3)
    np.testing.assert_allclose(space.noise_std[6:], np.sqrt(0.2))
    same = JointSplineSpace(0.2, root_sigma2=1e-4)
    same.fit(UniformBSpline(6, (0.0, 1.0)), times, qpos, ranges, 6)
    np.testing.assert_allclose(same.noise_std[:6], 0.01)


def test_an_offset_off_the_table_or_on_a_fixed_object_is_refused(scene_for) -> None:
    from contactmpc.perturbations import support
    from contactmpc.validate import ConfigError

    apple = scene_for("apple")
    start = apple.task.initial_object_qpos(apple.plant_model)
    assert support(apple.plant_model, start[:3]) == ("table_top", pytest.approx(0.45))
    Perturbation(object_offset=0.4).check(apple, start)  # large, but still on the table
    with pytest.raises(ConfigError, match="object_offset = 10 m takes the object of task 'apple' off its"):
        Perturbation(object_offset=10.0).check(apple, start)
    door = scene_for("doorknob")
    with pytest.raises(ConfigError, match="task 'doorknob' has none"):
        Perturbation(object_offset=0.02).check(door, door.task.initial_object_qpos(door.plant_model))
    Perturbation(mass_scale=0.5).check(door, door.task.initial_object_qpos(door.plant_model))
    # a scale's half-width stops short of 1: no mass, friction or size reaches 0
    with pytest.raises(ConfigError, match="mass_scale must be finite and >= 0 and <= 0.99, got 1.5"):
        Perturbation(mass_scale=1.5)


def test_the_wrist_is_sampled_only_around_the_first_expected_contact() -> None:
    """sampler.root_window: wrist noise on the control points whose support meets the window, none
    elsewhere; the fingers' noise everywhere; without a window, the space's (d,) noise as before."""
    from contactmpc.control.samplers import JointSplineSpace
    from contactmpc.reference.bspline import UniformBSpline

    times = np.linspace(0, 10, 50)
    qpos = np.random.default_rng(0).normal(size=(50, 8))
    spline = UniformBSpline(12, (0.0, 10.0))
    space = JointSplineSpace(0.2, root_sigma2=1e-4, root_rotation_sigma2=0.01, root_window=(-1.0, 2.0))
    space.fit(spline, times, qpos, np.tile([-10.0, 10.0], (8, 1)), 6)
    std = space.point_noise_std(spline, first_contact=5.0)
    inside = spline.window_indices(4.0, 3.0)
    assert std.shape == (12, 8) and 0 < len(inside) < 12
    np.testing.assert_allclose(std[inside, :6], np.tile([0.01] * 3 + [0.1] * 3, (len(inside), 1)))
    outside = np.setdiff1d(np.arange(12), inside)
    assert not std[outside, :6].any()
    np.testing.assert_allclose(std[:, 6:], np.sqrt(0.2))
    assert not space.point_noise_std(spline, None)[:, :6].any()  # no contact expected: never
    plain = JointSplineSpace(0.2, root_sigma2=1e-4)
    plain.fit(spline, times, qpos, np.tile([-10.0, 10.0], (8, 1)), 6)
    assert plain.point_noise_std(spline, 5.0).shape == (8,)
    with pytest.raises(ValueError, match="root_window"):
        JointSplineSpace(0.2, root_window=(2.0, 1.0))
