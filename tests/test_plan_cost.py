"""The planning-model cuts (``scene.planning_cuts``, :func:`contactmpc.scene.planning_model`) and the
profile job (``job=profile``): off, the old planning model bit for bit; on, what each cut promises."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from contactmpc.jobs.benchmark import STATE
from contactmpc.scene import finger_pairs, planning_model
from tests.conftest import build_scene


def _collides(m: mujoco.MjModel, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(len(a), len(b)) MuJoCo's contype/conaffinity test between geoms ``a`` and ``b``."""
    ct, ca = m.geom_contype, m.geom_conaffinity
    return ((ct[a][:, None] & ca[b][None, :]) | (ct[b][None, :] & ca[a][:, None])) > 0


def _rollout(model: mujoco.MjModel, state: np.ndarray, ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = mujoco.MjData(model)
    mujoco.mj_setState(model, d, state, STATE)
    qpos, sensors = [], []
    for u in ctrl:
        d.ctrl[:] = u
        mujoco.mj_step(model, d)
        qpos.append(d.qpos.copy())
        sensors.append(d.sensordata.copy())
    return np.array(qpos), np.array(sensors)


def _grasp_state(scene) -> tuple[np.ndarray, np.ndarray]:
    """A state with the fingers closing on the apple and 0.3 s of controls that close them further."""
    m = scene.planner_model
    d = scene.make_data(m)
    state = np.empty(mujoco.mj_stateSize(m, STATE))
    mujoco.mj_getState(m, d, state, STATE)
    lo, hi = m.actuator_ctrlrange.T
    ctrl = np.linspace(d.ctrl, lo + 0.8 * (hi - lo), 30)
    return state, ctrl


def test_no_cut_is_the_scene_planning_model_bit_for_bit():
    scene = build_scene(("task=apple",))
    assert not scene.planning_cuts
    state, ctrl = _grasp_state(scene)
    q0, s0 = _rollout(scene.planner_model, state, ctrl)
    q1, s1 = _rollout(planning_model(scene), state, ctrl)
    assert np.array_equal(q0, q1) and np.array_equal(s0, s1)
    off = build_scene(("task=apple", "scene.planning_cuts={}"))
    q2, s2 = _rollout(off.planner_model, state, ctrl)
    assert np.array_equal(q0, q2) and np.array_equal(s0, s2)


def test_hand_pairs_none_drops_only_hand_hand_pairs():
    scene = build_scene(("task=apple",))
    cut = planning_model(scene, hand_pairs="none")
    m = scene.planner_model
    geoms = np.arange(m.ngeom)
    hand = scene.index.link_of_geom >= 0
    before, after = _collides(m, geoms, geoms), _collides(cut, geoms, geoms)
    hand_pair = hand[:, None] & hand[None, :]
    assert before[hand_pair].any() and not after[hand_pair].any()
    assert np.array_equal(before[~hand_pair], after[~hand_pair])  # hand-world, hand-object, the rest
    assert np.array_equal(scene.plant_model.geom_contype, m.geom_contype)  # the plant and the scene's kept


def _contact_pairs(model: mujoco.MjModel, qpos: np.ndarray) -> set[tuple[int, int]]:
    d = mujoco.MjData(model)
    d.qpos[:] = qpos
    mujoco.mj_forward(model, d)
    return {tuple(sorted((int(c.geom1), int(c.geom2)))) for c in d.contact[: d.ncon]}


def test_across_fingers_drops_only_pairs_within_a_finger_and_scene_planning_cuts_builds_it():
    """The links of one finger never touch each other (200 random hand poses over the joint ranges: every
    contact of the exact planning model is one of the cut model's), but their bounding spheres overlap:
    narrow-phase work the cut saves."""
    scene = build_scene(("task=apple",))
    m = scene.planner_model
    cut = planning_model(scene, hand_pairs="across_fingers")
    pairs = {tuple(sorted(p)) for p in finger_pairs(m, scene.index.link_bodies)}
    assert pairs and not any(scene.index.link_bodies[0] in p for p in pairs)  # the palm keeps its contacts
    geoms = [np.flatnonzero(m.geom_bodyid == b) for b in range(m.nbody)]
    rng = np.random.default_rng(0)
    adr = scene.index.hand_qpos
    joints = [int(np.flatnonzero(m.jnt_qposadr == a)[0]) for a in adr]
    lo, hi = m.jnt_range[joints].T
    overlapping = 0
    for _ in range(200):
        q = scene.make_data(m).qpos.copy()
        q[adr] = rng.uniform(lo, hi)
        assert _contact_pairs(cut, q) == _contact_pairs(m, q)
        d = mujoco.MjData(m)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        for a, b in pairs:
            for ga in geoms[a]:
                for gb in geoms[b]:
                    gap = np.linalg.norm(d.geom_xpos[ga] - d.geom_xpos[gb])
                    overlapping += gap < m.geom_rbound[ga] + m.geom_rbound[gb]
    assert overlapping > 0
    fast = build_scene(("task=apple", "scene.planning_cuts={hand_pairs: across_fingers}"))
    assert fast.planner_model.nexclude == cut.nexclude
    assert fast.plant_model.nexclude == m.nexclude  # the plant keeps every contact


def test_profile_job_splits_a_plan_by_phase_and_part(tmp_path):
    from hydra.utils import instantiate

    from tests.conftest import compose_config

    cfg = compose_config(
        ("task=apple", "job=profile", "job.every=2.0", "job.repeats=1", "duration=4.5", "effort=acquire",
         "+job.alternatives.fast={hand_pairs: across_fingers}",
         "+job.alternatives.pyramidal={options: {cone: pyramidal}}")
    )  # fmt: skip
    import launch

    job = instantiate(cfg.job)
    path = job(
        make_scene=lambda: launch.build_scene(cfg), output_dir=tmp_path, seed=0, labels={"task": "apple"}
    )
    result = json.loads(path.read_text())
    rows = result["rows"]
    assert [r["time"] for r in rows] == pytest.approx([0.0, 2.0, 4.0])
    assert {r["phase"] for r in rows} <= {"before", "contact", "after"}
    for r in rows:
        parts = sum(r[p] for p in ("collision", "constraint", "sensors", "kinematics", "physics_rest"))
        assert parts == pytest.approx(r["rollout_us"])  # the timers split the rollout's time
        assert r["plan_us"] > 0 and r["plan_fast_us"] > 0 and r["plan_pyramidal_us"] > 0 and r["cost"] > 0
    # effort=acquire: the plans draw 128 samples from the start, the candidates timed 32; a plan per its own
    assert [r["plan_samples"] for r in rows] == [128, 128, 128]
    assert result["alternatives"]["pyramidal"] == {"options": {"cone": "pyramidal"}}  # nested: written
    assert "all" in result["summary"] and (tmp_path / "profile.csv").exists()
    assert "| apple" in result["table"]


def test_distance_cutoff_reads_the_link_distances_only_that_far_and_moves_nothing():
    """``distance_cutoff``: the planning model's link-object distance sensors read up to it (the others and
    the physics as the scene's, bit for bit; a link farther reads the cutoff); the scene's models untouched;
    a cut the scene does not know, or a cutoff that is not positive, is refused naming it."""
    from contactmpc.scene import SceneError

    scene = build_scene(("task=stapler", "scene.link_distance_cutoff=0.05"))
    m = scene.planner_model
    dist = m.sensor_type == mujoco.mjtSensor.mjSENS_GEOMDIST
    near = planning_model(scene, distance_cutoff=0.03)
    assert (near.sensor_cutoff[dist] == 0.03).all() and (m.sensor_cutoff[dist] == 0.05).all()
    state = np.empty(mujoco.mj_stateSize(m, STATE))
    mujoco.mj_getState(m, scene.make_data(m), state, STATE)
    ctrl = scene.task.hand_home + np.random.default_rng(5).normal(0, 0.3, (60, m.nu))  # fingers near it
    q0, s0 = _rollout(m, state, ctrl)
    q1, s1 = _rollout(near, state, ctrl)
    assert np.array_equal(q0, q1)
    cols = np.flatnonzero(np.repeat(dist, m.sensor_dim))  # the distance sensors' columns
    others = np.setdiff1d(np.arange(m.nsensordata), cols)
    assert np.array_equal(s0[:, others], s1[:, others])
    assert np.array_equal(np.minimum(s0[:, cols], 0.03), s1[:, cols])
    assert (s0[:, cols] > 0.03).any() and (s0[:, cols] < 0.03).any()  # both sides of the cutoff met
    with pytest.raises(SceneError, match="distance_cutoff = 0"):
        planning_model(scene, distance_cutoff=0)
    with pytest.raises(SceneError, match="not among options, hand_pairs, distance_cutoff"):
        build_scene(("task=apple", "scene.planning_cuts={far: 1}"))
