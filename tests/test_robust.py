"""Robust planning (contactmpc.control.robust): K = 1 with zero widths is plain planning, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from contactmpc.control.cost import TrackingCost
from contactmpc.control.planners import PredictiveSampling
from contactmpc.control.robust import ModelEnsemble
from contactmpc.control.samplers import PCASplineSpace
from contactmpc.trial import Trial
from tests.helpers import static_reference


def _run(scene, ref, robust=None):
    planner = PredictiveSampling(num_samples=8, horizon=0.2, replan_period=0.05, nthread=1, robust=robust)
    trial = Trial(
        scene, ref, PCASplineSpace(0.2), TrackingCost(lambda_v=0.0), planner, 4, duration=0.3, progress=False
    )
    try:
        return trial.run().arrays()
    finally:
        planner.close()


def test_one_unchanged_model_is_plain_planning(scene_for) -> None:
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.5, frames=11)
    plain = _run(scene, ref)
    for risk in ("mean", "worst", "cvar"):
        robust = _run(scene, ref, ModelEnsemble(num_models=1, risk=risk))
        for key in plain:
            if key != "plan_seconds":
                np.testing.assert_array_equal(plain[key], robust[key], err_msg=f"{risk}: {key}")


def test_ensemble_models_differ_only_in_the_object(scene_for) -> None:
    scene = scene_for("apple")
    ensemble = ModelEnsemble(num_models=3, mass_scale=0.3, friction_scale=0.3, seed=2)
    models = ensemble.build(scene)
    base = scene.planner_model
    body = scene.index.object_bodies[0]
    for m, (mass, friction) in zip(models, ensemble.scales, strict=True):
        assert m is not base
        assert m.body_mass[body] == pytest.approx(base.body_mass[body] * mass)
        geom = base.geom("apple_col").id
        assert m.geom_friction[geom, 0] == pytest.approx(base.geom_friction[geom, 0] * friction)
        hand = np.ones(base.nbody, bool)
        hand[body] = False
        np.testing.assert_array_equal(m.body_mass[hand], base.body_mass[hand])
        np.testing.assert_array_equal(m.actuator_gainprm, base.actuator_gainprm)
    assert len({tuple(s) for s in ensemble.scales}) == 3
    np.testing.assert_array_equal(
        ModelEnsemble(num_models=3, mass_scale=0.3, friction_scale=0.3, seed=2).build(scene)[0].body_mass,
        models[0].body_mass,
    )


def test_risk_measures() -> None:
    costs = np.array([[1.0, 4.0], [3.0, 2.0], [2.0, np.inf], [6.0, 1.0]])  # (K=4, S=2)
    np.testing.assert_allclose(ModelEnsemble(num_models=4, risk="mean").aggregate(costs[:, :1]), [3.0])
    np.testing.assert_allclose(ModelEnsemble(num_models=4, risk="worst").aggregate(costs), [6.0, np.inf])
    np.testing.assert_allclose(
        ModelEnsemble(num_models=4, risk="cvar", cvar_alpha=0.5).aggregate(costs), [4.5, np.inf]
    )


def test_robust_planning_runs(scene_for) -> None:
    scene = scene_for("apple")
    ref = static_reference(scene, duration=0.5, frames=11)
    log = _run(scene, ref, ModelEnsemble(num_models=3, mass_scale=0.3, friction_scale=0.3, risk="cvar"))
    assert np.isfinite(log["best_cost"]).all()
