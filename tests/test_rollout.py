"""The rollout engine: agreement with a plain MjData loop, divergence detection."""

from __future__ import annotations

import os

import mujoco
import numpy as np

from contactmpc.control import rollout
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


def test_available_cpus_follow_affinity_and_cgroup_quota(tmp_path, monkeypatch):
    """A job limited to some CPUs (Slurm, taskset, a container quota) starts a thread per CPU it may use,
    not per core of the node."""

    quota = rollout._cgroup_cpu_quota  # the real reader, tested on files below
    assert 1 <= rollout.available_cpus() <= (os.cpu_count() or 1)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1, 2, 3, 4, 5, 6, 7})
    monkeypatch.setattr(rollout, "_cgroup_cpu_quota", lambda: None)
    assert rollout.available_cpus() == 8
    monkeypatch.setattr(rollout, "_cgroup_cpu_quota", lambda: 3)
    assert rollout.available_cpus() == 3

    v2 = tmp_path / "v2"
    v2.mkdir()
    (v2 / "cpu.max").write_text("250000 100000\n")
    assert quota(str(v2)) == 3  # 2.5 CPUs rounded up
    (v2 / "cpu.max").write_text("max 100000\n")
    assert quota(str(v2)) is None
    v1 = tmp_path / "v1"
    (v1 / "cpu").mkdir(parents=True)
    (v1 / "cpu" / "cpu.cfs_quota_us").write_text("400000\n")
    (v1 / "cpu" / "cpu.cfs_period_us").write_text("100000\n")
    assert quota(str(v1)) == 4
    (v1 / "cpu" / "cpu.cfs_quota_us").write_text("-1\n")
    assert quota(str(v1)) is None
    assert quota(str(tmp_path / "none")) is None
