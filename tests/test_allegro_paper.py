"""``hand=allegro_paper``: the AllegroHand builder with the paper authors' kinematic table.

The comparison with the authors' own model reads their XML from ``$CONTACTMPC_PAPER_DATA`` (their
``mjpc/tasks`` directory; never copied into this repository) and is skipped without it. Their visual
meshes are not available: the test strips every mesh geom and compiles their body under the default
classes of their ``right_hand_template.xml`` (joint axes, ranges, damping, actuator gains).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import hydra
import mujoco
import numpy as np
import pytest

from contactmpc.hands import AllegroHand, AllegroPaperHand
from tests.conftest import compose_config

_PAPER_DATA = os.environ.get("CONTACTMPC_PAPER_DATA")
_PREFIX = "allegro_"  # their body names: allegro_<our link name>
# their actuator names: <finger>a<i> for joint <finger>j<i>
_THEIR_ACTUATOR = {f"{f}j{i}": f"{f}a{i}" for f in ("ff", "mf", "rf", "th") for i in range(4)}


def _our_model(hand: AllegroHand) -> mujoco.MjModel:
    spec = mujoco.MjSpec()
    hand.add_to(spec)  # hand_root at the world origin, like their allegro_wrist
    return spec.compile()


def test_builds_with_allegro_names_and_sizes():
    paper, ours = AllegroPaperHand(), AllegroHand()
    model, reference = _our_model(paper), _our_model(ours)
    assert paper.num_joints == 22 and (paper.num_root, paper.num_fingers) == (6, 16)
    assert paper.joint_names == ours.joint_names
    assert paper.link_names == ours.link_names and paper.link_geoms == ours.link_geoms
    assert paper.actuator_names == ours.actuator_names
    assert paper.flexion_joints == ours.flexion_joints
    assert paper.joint_ranges.shape == ours.joint_ranges.shape == (22, 2)
    for kind, count in (
        (mujoco.mjtObj.mjOBJ_BODY, "nbody"),
        (mujoco.mjtObj.mjOBJ_JOINT, "njnt"),
        (mujoco.mjtObj.mjOBJ_GEOM, "ngeom"),
        (mujoco.mjtObj.mjOBJ_ACTUATOR, "nu"),
        (mujoco.mjtObj.mjOBJ_SENSOR, "nsensor"),
    ):
        n = getattr(model, count)
        assert n == getattr(reference, count)
        assert [mujoco.mj_id2name(model, kind, i) for i in range(n)] == [
            mujoco.mj_id2name(reference, kind, i) for i in range(n)
        ]
    assert (model.nq, model.nv, model.nu) == (22, 22, 22)
    # the paper hand's own values: palm 0.0942 m above the wrist, their finger gains
    assert np.allclose(model.body("palm").pos, [0.0, 0.0, 0.0942])
    finger_dofs = [model.joint(j).dofadr[0] for j in paper.finger_joints]
    assert np.allclose(model.dof_damping[finger_dofs], 0.1)
    assert np.allclose(model.actuator_gainprm[[model.actuator(j).id for j in paper.finger_joints], 0], 1.0)


# ---------------------------------------------------------------- against the authors' model


def _mesh_classes(default: ET.Element, inherited: bool = False) -> set[str]:
    """Names of the default classes (under ``default``) whose geoms are meshes."""
    names = set()
    for child in default.findall("default"):
        geom = child.find("geom")
        is_mesh = inherited or (
            geom is not None and (geom.get("type") == "mesh" or geom.get("mesh") is not None)
        )
        if is_mesh:
            names.add(child.get("class"))
        names |= _mesh_classes(child, is_mesh)
    return names


def _their_model(tasks: Path) -> mujoco.MjModel:
    """Their right_hand_body.xml under their template's defaults and actuators, mesh geoms stripped."""
    template = ET.parse(tasks / "allegro" / "right_hand_template.xml").getroot()
    body = ET.parse(tasks / "allegro" / "right_hand_body.xml").getroot()
    defaults = template.find("default")
    mesh_classes = _mesh_classes(defaults)
    assert {"visual", "fingertip_collision", "thumbtip_collision"} <= mesh_classes
    for default_geom in defaults.iter("geom"):  # the mesh files are not available
        default_geom.attrib.pop("mesh", None)
    for parent in body.iter("body"):
        for geom in parent.findall("geom"):
            if geom.get("mesh") is not None or geom.get("class") in mesh_classes:
                parent.remove(geom)
    asset = template.find("asset")
    for mesh in asset.findall("mesh"):
        asset.remove(mesh)

    root = ET.Element("mujoco", model="allegro_right_kinematics")
    compiler = dict(template.find("compiler").attrib)
    compiler.pop("meshdir", None)
    # their collision geoms are massless (the masses came from the meshes): bound the links' inertia
    ET.SubElement(root, "compiler", compiler, boundmass="1e-3", boundinertia="1e-6")
    ET.SubElement(root, "default").append(defaults)  # their class "allegro_right" under the main class
    root.append(asset)
    worldbody = ET.SubElement(root, "worldbody")
    for child in body:
        worldbody.append(child)
    root.append(template.find("actuator"))
    return mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))


def _wrist_quat(rx: float, ry: float, rz: float) -> np.ndarray:
    """Unit quaternion of ``Rx(rx) @ Ry(ry) @ Rz(rz)``: our three wrist hinges as their ball joint."""
    quat = np.array([1.0, 0.0, 0.0, 0.0])
    for axis, angle in zip(np.eye(3), (rx, ry, rz), strict=True):
        step, out = np.zeros(4), np.zeros(4)
        mujoco.mju_axisAngle2Quat(step, axis, angle)
        mujoco.mju_mulQuat(out, quat, step)
        quat = out
    return quat


@pytest.fixture(scope="module")
def models():
    if not _PAPER_DATA:
        pytest.skip("CONTACTMPC_PAPER_DATA is not set (the authors' mjpc/tasks directory)")
    hand = AllegroPaperHand()
    return hand, _our_model(hand), _their_model(Path(_PAPER_DATA))


def test_joint_ranges_gains_and_damping_match_theirs(models):
    hand, ours, theirs = models
    for joint in hand.finger_joints:
        assert np.allclose(ours.joint(joint).range, theirs.joint(joint).range, atol=1e-12, rtol=0), joint
        assert np.allclose(ours.joint(joint).range, hand.finger_range(joint)), joint
        assert np.allclose(ours.jnt_axis[ours.joint(joint).id], theirs.jnt_axis[theirs.joint(joint).id])
        ours_dof, theirs_dof = ours.joint(joint).dofadr[0], theirs.joint(joint).dofadr[0]
        assert ours.dof_damping[ours_dof] == theirs.dof_damping[theirs_dof], joint
        theirs_act = theirs.actuator(_THEIR_ACTUATOR[joint])
        assert np.allclose(ours.actuator(joint).ctrlrange, theirs_act.ctrlrange)
        assert ours.actuator(joint).gainprm[0] == theirs_act.gainprm[0]


def test_links_match_theirs_in_world(models):
    """Every link body (fingertips included), position and orientation, over random finger and wrist poses."""
    hand, ours, theirs = models
    rng = np.random.default_rng(0)
    data_ours, data_theirs = mujoco.MjData(ours), mujoco.MjData(theirs)
    links = hand.link_names
    ours_ids = [ours.body(link).id for link in links]
    theirs_ids = [theirs.body(_PREFIX + link).id for link in links]
    tips = [links.index(tip) for tip in hand.FINGERTIPS]
    low, high = hand.finger_ranges.T
    wrists = [np.zeros(6)] + [
        np.concatenate([rng.uniform(-0.3, 0.3, 3), rng.uniform(-np.pi, np.pi, 3)]) for _ in range(4)
    ]
    worst_pos = worst_tip = worst_rot = 0.0
    for wrist in wrists:
        for sample in range(8):
            fingers = (low + high) / 2 if sample == 0 else rng.uniform(low, high)
            data_ours.qpos[:] = 0.0
            data_theirs.qpos[:] = 0.0
            for joint, value in zip(hand.joint_names, np.concatenate([wrist, fingers]), strict=True):
                data_ours.qpos[ours.joint(joint).qposadr[0]] = value
            for joint, value in zip(hand.finger_joints, fingers, strict=True):
                data_theirs.qpos[theirs.joint(joint).qposadr[0]] = value
            for k, joint in enumerate(("RootTx", "RootTy", "RootTz")):
                data_theirs.qpos[theirs.joint(joint).qposadr[0]] = wrist[k]
            adr = theirs.joint("RootR").qposadr[0]
            data_theirs.qpos[adr : adr + 4] = _wrist_quat(*wrist[3:])
            mujoco.mj_kinematics(ours, data_ours)
            mujoco.mj_kinematics(theirs, data_theirs)
            gap = np.linalg.norm(data_ours.xpos[ours_ids] - data_theirs.xpos[theirs_ids], axis=1)
            rot = np.abs(data_ours.xmat[ours_ids] - data_theirs.xmat[theirs_ids]).max()
            worst_pos, worst_tip = max(worst_pos, gap.max()), max(worst_tip, gap[tips].max())
            worst_rot = max(worst_rot, rot)
    print(
        f"\nallegro_paper vs the authors' hand, {len(wrists) * 8} poses: largest fingertip gap "
        f"{worst_tip:.2e} m, largest link gap {worst_pos:.2e} m, "
        f"largest rotation-matrix entry gap {worst_rot:.2e}"
    )
    assert worst_pos < 1e-6 and worst_rot < 1e-6


def test_config_instantiates():
    cfg = compose_config(["hand=allegro_paper"])
    hand = hydra.utils.instantiate(cfg.hand)
    assert type(hand) is AllegroPaperHand
    assert (hand.kp_finger, hand.damping_finger) == (1.0, 0.1)
    assert hand.joint_names == AllegroHand().joint_names
