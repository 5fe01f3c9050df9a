"""Allegro hand builder: names, kinematics (against an independent transform chain), actuation, stability."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from contactmpc.hands import AllegroHand
from contactmpc.scene import SceneError, ids

_OBJ = mujoco.mjtObj


# ---------------------------------------------------------------- ids of a hand-only model
def joint_ids(hand, model) -> np.ndarray:
    return ids(model, _OBJ.mjOBJ_JOINT, hand.joint_names, "joint")


def qpos_adr(hand, model) -> np.ndarray:
    return model.jnt_qposadr[joint_ids(hand, model)]


def dof_adr(hand, model) -> np.ndarray:
    return model.jnt_dofadr[joint_ids(hand, model)]


def actuator_ids(hand, model) -> np.ndarray:
    return ids(model, _OBJ.mjOBJ_ACTUATOR, hand.actuator_names, "actuator")


def link_body_ids(hand, model) -> np.ndarray:
    return ids(model, _OBJ.mjOBJ_BODY, hand.link_names, "link")


def link_geom_ids(hand, model) -> np.ndarray:
    return ids(model, _OBJ.mjOBJ_GEOM, hand.link_geoms, "link geom")


def open_pose(hand) -> np.ndarray:
    """A relaxed open hand: every finger joint at 0 clipped to its range (thumb base at its lower limit)."""
    return np.clip(np.zeros(hand.num_fingers), *hand.finger_ranges.T)


def link_sensor_adr(hand, model) -> tuple[np.ndarray, np.ndarray]:
    pos = ids(model, _OBJ.mjOBJ_SENSOR, [f"{n}_pos" for n in hand.link_names], "sensor")
    quat = ids(model, _OBJ.mjOBJ_SENSOR, [f"{n}_quat" for n in hand.link_names], "sensor")
    return model.sensor_adr[pos], model.sensor_adr[quat]


# ---------------------------------------------------------------- independent kinematics (DESIGN.md §3)
# body: (parent, pos, quat (w x y z), joint, axis); copied from the DESIGN table, not from the builder.
_IDQ = (1.0, 0.0, 0.0, 0.0)
_TABLE: dict[str, tuple] = {}
for _f, _pos, _quat in (
    ("ff", (0.0, 0.0435, -0.001542), (0.999048, -0.0436194, 0.0, 0.0)),
    ("mf", (0.0, 0.0, 0.0007), _IDQ),
    ("rf", (0.0, -0.0435, -0.001542), (0.999048, 0.0436194, 0.0, 0.0)),
):
    _TABLE[f"{_f}_base"] = ("palm", _pos, _quat, f"{_f}j0", (0, 0, 1))
    _TABLE[f"{_f}_proximal"] = (f"{_f}_base", (0, 0, 0.0164), _IDQ, f"{_f}j1", (0, 1, 0))
    _TABLE[f"{_f}_medial"] = (f"{_f}_proximal", (0, 0, 0.054), _IDQ, f"{_f}j2", (0, 1, 0))
    _TABLE[f"{_f}_distal"] = (f"{_f}_medial", (0, 0, 0.0384), _IDQ, f"{_f}j3", (0, 1, 0))
    _TABLE[f"{_f}_tip"] = (f"{_f}_distal", (0, 0, 0), _IDQ, None, None)
_TABLE["th_base"] = (
    "palm",
    (-0.0182, 0.019333, -0.045987),
    (0.477714, -0.521334, -0.521334, -0.477714),
    "thj0",
    (-1, 0, 0),
)
_TABLE["th_proximal"] = ("th_base", (-0.027, 0.005, 0.0399), _IDQ, "thj1", (0, 0, 1))
_TABLE["th_medial"] = ("th_proximal", (0, 0, 0.0177), _IDQ, "thj2", (0, 1, 0))
_TABLE["th_distal"] = ("th_medial", (0, 0, 0.0514), _IDQ, "thj3", (0, 1, 0))
_TABLE["th_tip"] = ("th_distal", (0, 0, 0), _IDQ, None, None)


def _quat_to_mat(q) -> np.ndarray:
    """(3, 3) rotation of a scalar-first quaternion (normalised here)."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _axis_angle(axis, angle: float) -> np.ndarray:
    """(3, 3) Rodrigues rotation about a unit axis."""
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _body_in_palm(body: str, q: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """(3,) position and (3, 3) rotation of ``body`` in the palm frame by a transform chain."""
    if body == "palm":
        return np.zeros(3), np.eye(3)
    parent, pos, quat, joint, axis = _TABLE[body]
    p_par, R_par = _body_in_palm(parent, q)
    R = R_par @ _quat_to_mat(quat)
    if joint is not None:
        R = R @ _axis_angle(axis, q[joint])
    return p_par + R_par @ np.asarray(pos, dtype=float), R


# ---------------------------------------------------------------- fixtures
def _build(hand: AllegroHand, root_pos=(0.0, 0.0, 0.0), degree: bool = True):
    spec = mujoco.MjSpec()
    spec.compiler.degree = degree
    spec.option.timestep = 0.001
    spec.option.gravity = (0.0, 0.0, -9.81)
    hand.add_to(spec, root_pos=root_pos)
    model = spec.compile()
    return model, mujoco.MjData(model)


@pytest.fixture(scope="module")
def hand() -> AllegroHand:
    return AllegroHand()


@pytest.fixture(scope="module")
def model(hand):
    return _build(hand)[0]


# ---------------------------------------------------------------- tests
def test_compiles_and_names_resolve(hand, model):
    assert hand.num_joints == 22 and hand.num_root == 6 and hand.num_fingers == 16
    assert len(hand.link_names) == 21 and len(hand.actuator_names) == 22
    assert model.nq == 22 and model.nv == 22 and model.nu == 22
    assert len(set(link_body_ids(hand, model))) == 21
    assert len(set(joint_ids(hand, model))) == 22
    assert len(set(actuator_ids(hand, model))) == 22
    assert len(set(link_geom_ids(hand, model))) == 21
    # qpos follows JOINTS order when the hand is alone
    np.testing.assert_array_equal(qpos_adr(hand, model), np.arange(22))
    # each actuator drives the joint of the same name
    np.testing.assert_array_equal(model.actuator_trnid[actuator_ids(hand, model), 0], joint_ids(hand, model))
    assert set(hand.FINGERTIPS) <= set(hand.LINKS)


def test_missing_name_raises(model):
    with pytest.raises(SceneError, match="no_such_body"):
        ids(model, mujoco.mjtObj.mjOBJ_BODY, ["palm", "no_such_body"], "body")


@pytest.mark.parametrize("degree", [True, False])
def test_joint_ranges_and_open_pose(hand, degree):
    model, _ = _build(hand, degree=degree)
    ranges = hand.joint_ranges
    assert ranges.shape == (22, 2)
    jid = joint_ids(hand, model)
    np.testing.assert_allclose(model.jnt_range[jid], ranges, atol=1e-12)
    assert model.jnt_limited[jid].all()
    np.testing.assert_allclose(model.actuator_ctrlrange[actuator_ids(hand, model)], ranges, atol=1e-12)
    pose = open_pose(hand)
    assert pose.shape == (16,)
    assert np.all(pose >= hand.finger_ranges[:, 0]) and np.all(pose <= hand.finger_ranges[:, 1])
    assert pose[hand.FINGER_JOINTS.index("thj0")] == pytest.approx(0.263)


def test_actuation_parameters(hand, model):
    aid = actuator_ids(hand, model)
    did = dof_adr(hand, model)
    n_w = hand.num_root
    kp = np.array([600.0] * 3 + [40.0] * 3 + [10.0] * 16)
    np.testing.assert_allclose(model.actuator_gainprm[aid, 0], kp)
    np.testing.assert_allclose(model.actuator_biasprm[aid, :3], np.stack([0 * kp, -kp, 0 * kp], axis=1))
    np.testing.assert_allclose(model.dof_damping[did], [60.0] * 3 + [3.0] * 3 + [1.0] * 16)
    np.testing.assert_allclose(model.dof_armature[did[n_w:]], 0.01)
    # finger torque limit ±0.7 N·m, wrist unlimited
    fingers = aid[n_w:]
    assert model.actuator_forcelimited[fingers].all()
    np.testing.assert_allclose(model.actuator_forcerange[fingers], np.tile([-0.7, 0.7], (16, 1)))
    assert not model.actuator_forcelimited[aid[:n_w]].any()
    assert (model.body_gravcomp[link_body_ids(hand, model)] == 1.0).all()


def test_finger_force_is_clamped(hand, model):
    data = mujoco.MjData(model)
    aid = actuator_ids(hand, model)
    data.qpos[qpos_adr(hand, model)[hand.num_root :]] = open_pose(hand)
    data.ctrl[aid[hand.num_root :]] = hand.finger_ranges[:, 1]
    mujoco.mj_forward(model, data)
    assert np.abs(data.actuator_force[aid[hand.num_root :]]).max() == pytest.approx(0.7)


def _configs(hand: AllegroHand) -> list[np.ndarray]:
    rng = np.random.default_rng(1234)
    lo, hi = hand.finger_ranges.T
    return [np.zeros(16), lo + 0.7 * (hi - lo), rng.uniform(lo, hi), rng.uniform(lo, hi)]


@pytest.mark.parametrize("k", range(4))
def test_forward_kinematics_matches_table(hand, model, k):
    """Every link pose in the palm frame equals an independent chain of the DESIGN table."""
    fingers = _configs(hand)[k]
    data = mujoco.MjData(model)
    rng = np.random.default_rng(k)
    wrist = rng.uniform(-0.5, 0.5, size=hand.num_root)  # must not matter in the palm frame
    qadr = qpos_adr(hand, model)
    data.qpos[qadr] = np.concatenate([wrist, fingers])
    mujoco.mj_kinematics(model, data)
    q = dict(zip(hand.FINGER_JOINTS, fingers, strict=True))
    bid = dict(zip(hand.LINKS, link_body_ids(hand, model), strict=True))
    p_palm, R_palm = data.xpos[bid["palm"]], data.xmat[bid["palm"]].reshape(3, 3)
    for link in hand.LINKS:
        p_ref, R_ref = _body_in_palm(link, q)
        p = R_palm.T @ (data.xpos[bid[link]] - p_palm)
        R = R_palm.T @ data.xmat[bid[link]].reshape(3, 3)
        np.testing.assert_allclose(p, p_ref, atol=1e-6, err_msg=link)
        np.testing.assert_allclose(R, R_ref, atol=1e-6, err_msg=link)


def test_wrist_kinematics_and_sensors(hand):
    """Palm pose = root_pos + slides, R = Rx Ry Rz R_palm; frame sensors report the body frames."""
    root_pos = np.array([0.1, -0.2, 0.3])
    model, data = _build(hand, root_pos=root_pos)
    wrist = np.array([0.05, -0.03, 0.02, 0.4, -0.3, 1.1])
    data.qpos[qpos_adr(hand, model)] = np.concatenate([wrist, open_pose(hand)])
    mujoco.mj_forward(model, data)
    palm = link_body_ids(hand, model)[0]
    R_ref = (
        _axis_angle((1, 0, 0), wrist[3])
        @ _axis_angle((0, 1, 0), wrist[4])
        @ _axis_angle((0, 0, 1), wrist[5])
        @ _quat_to_mat((0, 1, 0, 1))
    )
    np.testing.assert_allclose(data.xpos[palm], root_pos + wrist[:3], atol=1e-9)
    np.testing.assert_allclose(data.xmat[palm].reshape(3, 3), R_ref, atol=1e-9)
    pos_adr, quat_adr = link_sensor_adr(hand, model)
    bids = link_body_ids(hand, model)
    np.testing.assert_allclose(data.sensordata[pos_adr[:, None] + np.arange(3)], data.xpos[bids], atol=1e-12)
    quats = data.sensordata[quat_adr[:, None] + np.arange(4)]
    sign = np.sign(np.sum(quats * data.xquat[bids], axis=1, keepdims=True))
    np.testing.assert_allclose(quats * sign, data.xquat[bids], atol=1e-9)


def test_geoms_attribute_to_links(hand, model):
    body_link = -np.ones(model.nbody, int)
    body_link[link_body_ids(hand, model)] = np.arange(len(hand.LINKS))
    np.testing.assert_array_equal(
        body_link[model.geom_bodyid[link_geom_ids(hand, model)]], np.arange(len(hand.LINKS))
    )
    assert all(model.geom_contype[g] and model.geom_conaffinity[g] for g in link_geom_ids(hand, model))


def test_open_pose_has_no_self_contact(hand, model):
    data = mujoco.MjData(model)
    data.qpos[qpos_adr(hand, model)[hand.num_root :]] = open_pose(hand)
    mujoco.mj_forward(model, data)
    assert data.ncon == 0


def test_passive_hold_is_stable(hand):
    """2 s at 1 ms with the wrist servoed in place and the fingers open: no drift, NaN or warning."""
    model, data = _build(hand, root_pos=(0.0, 0.0, 0.3))
    qadr, aid = qpos_adr(hand, model), actuator_ids(hand, model)
    target = np.concatenate([[0.02, -0.01, 0.05, 0.3, -0.2, 0.5], open_pose(hand)])
    data.qpos[qadr] = target
    data.ctrl[aid] = target
    mujoco.mj_forward(model, data)
    palm = link_body_ids(hand, model)[0]
    palm_target = data.xpos[palm].copy()
    worst = 0.0
    for _ in range(2000):
        mujoco.mj_step(model, data)
        worst = max(worst, float(np.linalg.norm(data.xpos[palm] - palm_target)))
    assert np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()
    assert all(w.number == 0 for w in data.warning)
    assert worst < 5e-3
