"""Synthetic demonstrations: every task's reference passes its quality gates, is deterministic, and its
expected contacts are real contacts when the reference is replayed kinematically in the plant model."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from contactmpc.reference import Reference
from contactmpc.reference.source import get_reference
from contactmpc.reference.synthetic.demonstration import synthesize
from contactmpc.reference.synthetic.gates import check_gates, gate_report
from contactmpc.reference.synthetic.kinematics import SynthesisError, wrist_angles
from contactmpc.reference.synthetic.phases import min_jerk

TASKS = ("apple", "bottle", "stapler", "doorknob")
FREE_BODY_TASKS = {"apple", "bottle", "stapler"}


@pytest.fixture(scope="module")
def refs(scene_for) -> dict[str, Reference]:
    """Each task's synthesised reference, built once for the module."""
    return {task: synthesize(scene_for(task), scene_for(task).task.demonstration) for task in TASKS}


def _frames_of(ref: Reference, *names: str) -> np.ndarray:
    """(T,) bool: frames inside the named phases (all holding phases when no name is given)."""
    mask = np.zeros(ref.num_frames, bool)
    for p in ref.meta["phases"]:
        if (p["name"] in names) if names else p["holding"]:
            mask |= (ref.time >= p["start"] - 1e-9) & (ref.time <= p["end"] + 1e-9)
    return mask


# ------------------------------------------------------------------------------------------ gates
@pytest.mark.parametrize("task", TASKS)
def test_reference_passes_every_gate(task, refs, scene_for) -> None:
    scene, ref = scene_for(task), refs[task]
    ref.validate(scene.hand.joint_names, scene.hand.link_names)
    report = gate_report(scene, ref)  # recomputed here, independently of synthesize's own run
    check_gates(report, task=task)
    assert report["penetration_hand_object"] <= 0.002
    assert report["penetration_hand_env"] <= 0.002
    assert report["penetration_hand_hand"] <= 0.002
    assert report["penetration_object_env"] <= 0.002
    assert report["contact_link_point_distance"] <= 0.003
    assert report["contact_object_point_distance"] <= 0.003
    assert report["contact_gap"] <= 0.003
    assert report["joint_limit_violations"] == 0
    assert report["hold_frames"] > 0
    assert report["hold_links_min"] > 6, "the TTF rule needs more than six expected contacts"
    assert report["hold_active_min"] > 6
    assert ref.contact_active[_frames_of(ref)].sum(axis=1).min() > 6
    assert report["keyframe_position_error"] <= 1e-3
    assert report["keyframe_rotation_error"] <= 1e-2
    assert report["start_error"] <= 1e-6
    assert report == pytest.approx(ref.meta["gates"])


@pytest.mark.parametrize("task", TASKS)
def test_reference_meta_and_timing(task, refs, scene_for) -> None:
    scene, ref = scene_for(task), refs[task]
    meta = ref.meta
    assert meta["source"] == "synthetic"
    assert isinstance(meta["version"], int)
    assert meta["time_scale"] == scene.task.time_scale
    assert meta["sample_rate"] > 0
    assert np.allclose(np.diff(ref.time), 1.0 / meta["sample_rate"])
    assert meta["object_quat_index"] == (3 if task in FREE_BODY_TASKS else None)
    assert 4 <= meta["num_control_points"] < ref.num_frames
    phases = meta["phases"]
    assert phases[0]["name"] == "approach" and phases[0]["start"] == 0.0
    assert phases[-1]["end"] == pytest.approx(ref.duration)
    for p in phases:
        assert 0.3 <= p["end"] - p["start"] <= 3.0, p  # a few seconds each, before the slow-down
    # The reference starts where the scene resets: the task's home and initial object pose.
    np.testing.assert_allclose(ref.hand_qpos[0], scene.task.hand_home, atol=1e-9)
    np.testing.assert_allclose(ref.object_qpos[0], scene.task.initial_object_qpos(scene.plant_model))


def test_object_keyframes(refs, scene_for) -> None:
    """The object reaches the demo's milestones: lifted apple, tilted bottle, shut stapler, open door."""
    apple, bottle, stapler, door = (refs[t] for t in TASKS)
    assert apple.object_qpos[:, 2].max() - apple.object_qpos[0, 2] >= 0.14
    tilt = [Rotation.from_quat(q, scalar_first=True).apply([0, 0, 1])[2] for q in bottle.object_qpos[:, 3:7]]
    assert np.degrees(np.arccos(np.clip(min(tilt), -1, 1))) >= 95.0
    assert stapler.object_qpos[:, 2].max() - stapler.object_qpos[0, 2] >= 0.09
    assert stapler.object_qpos[:, 7].min() <= 1e-6 and stapler.object_qpos[0, 7] > 0.2
    unlock = scene_for("doorknob").task.unlock_angle
    assert door.object_qpos[:, 0].min() <= -0.55
    pull = _frames_of(door, "pull")
    assert pull.any() and np.all(door.object_qpos[pull, 1] > unlock)  # the latch is open while pulling
    assert np.all(door.object_qpos[door.time < door.meta["phases"][3]["start"], 0] == 0.0)


# ------------------------------------------------------------------------------- kinematic replay
@pytest.mark.parametrize("task", TASKS)
def test_kinematic_replay_matches_expected_contacts(task, refs, scene_for) -> None:
    """Replaying the reference in the plant: expected contacts are real, unexpected ones absent."""
    scene, ref = scene_for(task), refs[task]
    m = scene.plant_model
    d = mujoco.MjData(m)
    collides = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
    obj_geoms = np.flatnonzero(scene.index.object_geom_mask & collides)
    link_geoms = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f"{n}_col") for n in scene.hand.link_names]
    touching = np.zeros(ref.contact_active.shape, bool)
    dist = np.zeros(ref.contact_active.shape)
    for t in range(ref.num_frames):
        d.qpos[scene.index.hand_qpos] = ref.hand_qpos[t]
        d.qpos[scene.index.object_qpos] = ref.object_qpos[t]
        mujoco.mj_forward(m, d)
        touching[t] = scene.link_contacts(d)
        for link, g in enumerate(link_geoms):
            dist[t, link] = min(mujoco.mj_geomDistance(m, d, g, int(o), 0.05, None) for o in obj_geoms)
    active = ref.contact_active
    real = touching | (dist <= 0.001)
    assert real[active].mean() >= 0.95
    per_link = [real[active[:, k], k].mean() for k in range(active.shape[1]) if active[:, k].any()]
    assert np.mean(np.array(per_link) >= 0.9) >= 0.8, per_link
    # No link touches the object where no contact is expected.
    assert not touching[~active].any()
    # Approaching, the whole hand stays clear of the object.
    approach = _frames_of(ref, "approach")
    assert dist[approach].min() > 0.005
    # Holding, the replay has more than six links in contact on every frame.
    assert real[_frames_of(ref)].sum(axis=1).min() > 6


# ---------------------------------------------------------------------------------- determinism
def test_synthesis_is_deterministic(refs, scene_for) -> None:
    again = synthesize(scene_for("doorknob"), scene_for("doorknob").task.demonstration)
    first = refs["doorknob"]
    for name, value in first.as_arrays().items():
        other = again.as_arrays()[name]
        assert value.dtype == other.dtype and np.array_equal(value, other), name


def test_round_trip(refs, tmp_path, scene_for) -> None:
    scene = scene_for("apple")
    path = refs["apple"].save(tmp_path / "apple.npz")
    loaded = Reference.load(path, scene.hand.joint_names, scene.hand.link_names)
    np.testing.assert_array_equal(loaded.hand_qpos, refs["apple"].hand_qpos)
    assert loaded.meta["gates"] == refs["apple"].meta["gates"]


# ------------------------------------------------------------------------------------- pieces
def test_wrist_angles_match_the_hand_root(scene_for) -> None:
    """R = Rx(rx) Ry(ry) Rz(rz) on hand_root, and the conversion back picks the nearest branch."""
    scene = scene_for("apple")
    m = scene.plant_model
    d = mujoco.MjData(m)
    root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, scene.hand.root_body)
    rng = np.random.default_rng(0)
    for _ in range(20):
        angles = rng.uniform([-3.0, -1.4, -3.0], [3.0, 1.4, 3.0])
        hq = scene.task.hand_home.copy()
        hq[3:6] = angles
        scene.reset(d, hand_qpos=hq)
        rot = Rotation.from_matrix(d.xmat[root].reshape(3, 3))
        np.testing.assert_allclose(rot.as_matrix(), Rotation.from_euler("XYZ", angles).as_matrix(), atol=1e-9)
        np.testing.assert_allclose(wrist_angles(rot, angles + 0.3), angles, atol=1e-9)
        shifted = wrist_angles(rot, angles + 2 * np.pi)  # same rotation, the branch near the reference
        np.testing.assert_allclose(shifted, angles + 2 * np.pi, atol=1e-9)


def test_min_jerk_profile() -> None:
    s = np.linspace(0, 1, 101)
    e = min_jerk(s)
    assert e[0] == 0.0 and e[-1] == 1.0 and np.all(np.diff(e) >= 0)
    assert min_jerk(-1.0) == 0.0 and min_jerk(2.0) == 1.0


def test_check_gates_names_the_failing_gate(refs) -> None:
    report = dict(refs["apple"].meta["gates"])
    report["penetration_hand_env"] = 0.0042
    with pytest.raises(SynthesisError, match="penetration_hand_env") as err:
        check_gates(report, task="apple")
    assert "\n" not in str(err.value)
    report = dict(refs["apple"].meta["gates"], hold_links_min=5)
    with pytest.raises(SynthesisError, match="hold_links_min"):
        check_gates(report)


def test_task_without_design_or_file_is_refused(scene_for) -> None:
    scene = scene_for("apple", "task.demonstration=null")
    with pytest.raises(
        SynthesisError, match="task 'apple' has no reference_path and no demonstration design"
    ):
        get_reference(scene)
