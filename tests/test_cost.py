"""The vectorised cost against direct per-state computations from MjData."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from contactmpc.control.cost import TrackingCost
from contactmpc.control.rollout import RolloutEngine
from contactmpc.control.track import ReferenceTrack
from tests.helpers import static_reference


@pytest.mark.parametrize("task", ["apple", "stapler"])
def test_contact_and_object_terms_match_mjdata(scene_for, task):
    scene = scene_for(task)
    m = scene.planner_model
    ref = static_reference(scene, active_links=21)
    rng = np.random.default_rng(3)
    ref.contact_active[:] = rng.random(ref.contact_active.shape) < 0.5
    ref.contact_link_point[:] = rng.normal(0, 0.02, ref.contact_link_point.shape)
    ref.contact_object_point[:] = rng.normal(0, 0.02, ref.contact_object_point.shape)
    ref.contact_object_body[:] = rng.integers(0, len(scene.task.object_bodies), ref.contact_object_body.shape)
    track = ReferenceTrack.build(ref, scene.task.layout, scene.task.time_scale, m.opt.timestep, 1.0)
    cost = TrackingCost(lambda_o=1.0, lambda_c=1.0, lambda_v=0.1)
    cost.bind(scene, track)

    data = scene.make_data(m)
    nstate = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    x0 = np.empty(nstate)
    mujoco.mj_getState(m, data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    S, H = 3, 20
    ctrl = scene.task.hand_home + rng.normal(0, 0.3, (S, H, m.nu))
    with RolloutEngine(m, nthread=1) as engine:
        state, sensordata, diverged = engine.run(x0, ctrl)
    assert not diverged.any()
    window = track.window(0.3, H)
    terms = cost(sensordata, window)
    contact = cost.contact_term(sensordata, window)

    idx = scene.index
    checked = 0
    for s in range(S):
        for h in (1, 7, H - 1):  # sensordata row h is the state after h steps
            mujoco.mj_setState(m, data, state[s, h - 1], mujoco.mjtState.mjSTATE_FULLPHYSICS)
            mujoco.mj_forward(m, data)
            g = window.start + h
            direct = 0.0
            for link in range(len(idx.link_bodies)):
                if not track.contact_active[g, link]:
                    continue
                lb = idx.link_bodies[link]
                ob = idx.object_bodies[track.contact_object_body[g, link]]
                xl = data.xpos[lb] + data.xmat[lb].reshape(3, 3) @ track.contact_link_point[g, link]
                xo = data.xpos[ob] + data.xmat[ob].reshape(3, 3) @ track.contact_object_point[g, link]
                direct += float(np.sum((xl - xo) ** 2))
            assert contact[s, h] == pytest.approx(direct, rel=1e-9, abs=1e-12)
            assert terms["contact"][s, h] == pytest.approx(direct, rel=1e-9, abs=1e-12)
            err = scene.task.layout.error(scene.object_qpos(data), track.object_qpos[g])
            direct_obj = err.position**2 + cost.rotation_weight * err.rotation**2
            direct_obj += cost.articulation_weight * err.articulation**2
            assert terms["object"][s, h] == pytest.approx(direct_obj, rel=1e-7, abs=1e-12)
            vel = 0.1 * np.sum(data.qvel[idx.hand_dof] ** 2)
            assert terms["velocity"][s, h] == pytest.approx(vel, rel=1e-9, abs=1e-12)
            checked += 1
    assert checked == 3 * S
    assert contact.max() > 0


def test_object_only_cost_has_no_contact_term(scene_for):
    scene = scene_for("apple")
    ref = static_reference(scene)
    track = ReferenceTrack.build(ref, scene.task.layout, 5.0, 0.01, 1.0)
    cost = TrackingCost(lambda_c=0.0)
    cost.bind(scene, track)
    sd = np.zeros((2, 5, scene.planner_model.nsensordata))
    sd[..., scene.index.object_qo[3]] = 1.0  # unit quaternions
    assert np.all(cost(sd, track.window(0.0, 5))["contact"] == 0.0)
