"""The rollout engine: agreement with a plain MjData loop, divergence detection."""

from __future__ import annotations

import mujoco
import numpy as np

from contactmpc.control.rollout import RolloutEngine
from tests.helpers import POINT_MASS


def _state(model, data):
    s = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, s, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    return s


def test_rollout_matches_a_python_loop_and_sensor_timing():
    model = mujoco.MjModel.from_xml_string(POINT_MASS)
    data = mujoco.MjData(model)
    x0 = _state(model, data)
    ctrl = np.random.default_rng(0).uniform(-1, 1, (3, 15, model.nu))
    with RolloutEngine(model, nthread=2) as engine:
        state, sensordata, diverged = engine.run(x0, ctrl)
    assert not diverged.any()
    for s in range(3):
        mujoco.mj_setState(model, data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        for h in range(15):
            mujoco.mj_forward(model, data)
            np.testing.assert_allclose(sensordata[s, h], data.sensordata, atol=1e-12)  # before step h
            data.ctrl[:] = ctrl[s, h]
            mujoco.mj_step(model, data)
            np.testing.assert_allclose(state[s, h], _state(model, data), atol=1e-12)  # after step h


def test_diverged_rollouts_are_flagged():
    # An absurdly stiff servo on a tiny mass explodes at 10 ms.
    xml = POINT_MASS.replace('kp="20"', 'kp="1e12"').replace('mass="0.1"', 'mass="1e-6"')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    ctrl = np.zeros((2, 50, model.nu))
    ctrl[1] = 1.0  # sample 1 explodes, sample 0 stays at rest
    with RolloutEngine(model, nthread=1) as engine:
        _, _, diverged = engine.run(_state(model, data), ctrl)
    assert diverged.tolist() == [False, True]
