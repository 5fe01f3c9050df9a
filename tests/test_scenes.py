"""Scenes with real physics (no mocks): composition, compilation, rest stability, the door latch,
planner-vs-plant agreement under squeezes, step cost and a render smoke test.

Measured gaps are printed; run ``pytest tests/test_scenes.py -s`` to see them.
"""

from __future__ import annotations

import subprocess
import sys

import imageio.v3 as iio
import mujoco
import numpy as np
import pytest
from hydra.utils import instantiate

import launch
from contactmpc.jobs.render_scene import render_scene
from contactmpc.scene import FREE_PLANNER_OPTIONS, Scene

FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS
TASKS = ("apple", "bottle", "stapler", "doorknob")
CTRL_DT = 0.01  # the control is held constant within each 10 ms (one planner step)

# ------------------------------------------------------------------------------------ helpers


def _warnings(data: mujoco.MjData) -> dict[str, int]:
    """Non-zero MuJoCo warning counters by name."""
    return {
        mujoco.mjtWarning(i).name: int(data.warning[i].number)
        for i in range(len(data.warning))
        if data.warning[i].number
    }


def _ctrl_at(knots: list[tuple[float, np.ndarray]], t: float) -> np.ndarray:
    """Piecewise-linear control through ``(time, ctrl)`` knots, constant after the last one."""
    ts = np.array([k[0] for k in knots])
    u = np.stack([k[1] for k in knots])
    return np.array([np.interp(t, ts, u[:, j]) for j in range(u.shape[1])])


def _settle(scene: Scene, q_pre: np.ndarray, duration: float = 1.2) -> np.ndarray:
    """Drive the plant from the task's home pose to ``q_pre`` (0.7 s ramp, then hold); its full state."""
    m = scene.plant_model
    d = scene.make_data(m)
    knots = [(0.0, scene.task.hand_home), (0.7, q_pre), (duration, q_pre)]
    steps = int(round(CTRL_DT / m.opt.timestep))
    for k in range(int(round(duration / CTRL_DT))):
        d.ctrl[scene.index.actuators] = _ctrl_at(knots, k * CTRL_DT)
        for _ in range(steps):
            mujoco.mj_step(m, d)
    state = np.empty(mujoco.mj_stateSize(m, FULL))
    mujoco.mj_getState(m, d, state, FULL)  # includes ctrl
    return state


def _run(scene: Scene, model: mujoco.MjModel, state: np.ndarray, knots, duration: float = 0.5) -> dict:
    """Run ``model`` from ``state`` under the knotted control; sample the object every 10 ms."""
    d = mujoco.MjData(model)
    mujoco.mj_setState(model, d, state, FULL)
    mujoco.mj_forward(model, d)
    idx = scene.index
    free_lin = idx.object_dof[:3]  # linear velocity of the (first, free) object joint
    steps = int(round(CTRL_DT / model.opt.timestep))
    pos, qo = [d.xpos[idx.object_bodies[0]].copy()], [scene.object_qpos(d)]
    speed, penetration, finite = 0.0, 0.0, True
    for k in range(int(round(duration / CTRL_DT))):
        d.ctrl[idx.actuators] = _ctrl_at(knots, k * CTRL_DT)
        for _ in range(steps):
            mujoco.mj_step(model, d)
            if d.ncon:
                penetration = max(penetration, -float(d.contact.dist[: d.ncon].min()))
            speed = max(speed, float(np.linalg.norm(d.qvel[free_lin])))
        finite &= bool(np.isfinite(d.qpos).all())
        pos.append(d.xpos[idx.object_bodies[0]].copy())
        qo.append(scene.object_qpos(d))
    return {
        "pos": np.array(pos),
        "qo": np.array(qo),
        "speed": speed,
        "penetration": penetration,
        "finite": finite,
        "warnings": _warnings(d),
        "data": d,
    }


def _hand_object_force(scene: Scene, data: mujoco.MjData) -> float:
    """Total normal force (N) between hand links and the object in ``data``."""
    idx, m, total = scene.index, data.model, 0.0
    f = np.zeros(6)
    for i in range(data.ncon):
        g1, g2 = data.contact.geom1[i], data.contact.geom2[i]
        hand_obj = (idx.link_of_geom[g1] >= 0 and idx.object_geom_mask[g2]) or (
            idx.link_of_geom[g2] >= 0 and idx.object_geom_mask[g1]
        )
        if hand_obj:
            mujoco.mj_contactForce(m, data, i, f)
            total += f[0]
    return total


def _compare(scene: Scene, state: np.ndarray, knots, label: str) -> tuple[dict, dict, float]:
    """Same state, same control in the 1 ms plant and the 10 ms planner; print and return the gaps."""
    plant = _run(scene, scene.plant_model, state, knots)
    planner = _run(scene, scene.planner_model, state, knots)
    gap = float(np.linalg.norm(plant["pos"] - planner["pos"], axis=-1).max())
    force = [_hand_object_force(scene, r["data"]) for r in (plant, planner)]
    print(
        f"\n[{label}] max |object pos plant - planner| = {gap * 1e3:.2f} mm; "
        f"max object speed plant {plant['speed']:.3f} / planner {planner['speed']:.3f} m/s; "
        f"max penetration plant {plant['penetration'] * 1e3:.2f} / planner "
        f"{planner['penetration'] * 1e3:.2f} mm; hand-object force at end plant "
        f"{force[0]:.1f} / planner {force[1]:.1f} N"
    )
    for name, r in (("plant", plant), ("planner", planner)):
        assert r["finite"], f"{label}: NaN in the {name}"
        assert not r["warnings"], f"{label}: MuJoCo warnings in the {name}: {r['warnings']}"
    return plant, planner, gap


# ---------------------------------------------------------------- 1. composition and compilation


@pytest.mark.parametrize("task", TASKS)
def test_task_composes_and_compiles(task, compose):
    cfg = compose([f"task={task}"])
    hand = instantiate(cfg.hand)
    tk = instantiate(cfg.task)
    scene = instantiate(cfg.scene)(hand=hand, task=tk)
    assert isinstance(scene, Scene) and scene.task.name == task
    assert type(launch.build_scene(cfg).task) is type(tk)

    obj = mujoco.mjtObj
    for m in (scene.plant_model, scene.planner_model):
        for kind, names in (
            (obj.mjOBJ_JOINT, hand.joint_names),
            (obj.mjOBJ_BODY, hand.link_names),
            (obj.mjOBJ_ACTUATOR, hand.actuator_names),
            (obj.mjOBJ_JOINT, [j.name for j in tk.object_joints]),
            (obj.mjOBJ_BODY, tk.object_bodies),
        ):
            missing = [n for n in names if mujoco.mj_name2id(m, kind, n) < 0]
            assert not missing, f"{task}: unresolved {kind.name} names {missing}"
        assert m.nu == len(hand.actuator_names) == 22
        # 22 hand joints + q_o (+ at most a couple of hidden mechanism joints, e.g. the latch bolt).
        assert 22 + tk.layout.width <= m.nq <= 22 + tk.layout.width + 2
        assert m.nv <= m.nq
    assert len(scene.index.object_qpos) == tk.layout.width
    np.testing.assert_array_equal(scene.index.actuators, np.arange(22))

    # The two models are one spec compiled twice: identical in everything but the timestep...
    plant, planner = scene.plant_model, scene.planner_model
    assert plant.opt.timestep == pytest.approx(cfg.scene.plant_timestep) == 0.001
    assert planner.opt.timestep == pytest.approx(cfg.scene.planner_timestep) == 0.01
    arrays = [n for n in dir(plant) if not n.startswith("_") and isinstance(getattr(plant, n), np.ndarray)]
    assert len(arrays) > 100
    differ = [n for n in arrays if not np.array_equal(getattr(plant, n), getattr(planner, n))]
    assert not differ, f"{task}: plant and planner models differ in {differ}"
    opts = [n for n in dir(plant.opt) if not n.startswith("_") and not callable(getattr(plant.opt, n))]
    differ = [
        n for n in opts if not np.array_equal(np.asarray(getattr(plant.opt, n)), getattr(planner.opt, n))
    ]
    # ...and in the options the scene sets on the planning model only (the free savings by default)
    changed = {k for k, v in scene.planner_options.items() if getattr(plant.opt, k) != v}
    assert set(differ) == {"timestep"} | changed and "ccd_iterations" in changed
    assert scene.planner_options == FREE_PLANNER_OPTIONS


def _launch(*args: str, cwd) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "launch.py", *args], cwd=cwd, capture_output=True, text=True, timeout=60
    )


@pytest.mark.parametrize("task", TASKS)
def test_launch_prints_config(task, repo_root):
    out = _launch("--cfg", "job", f"task={task}", cwd=repo_root)
    assert out.returncode == 0, out.stderr
    cls = {"apple": "AppleTask", "bottle": "BottleTask", "stapler": "StaplerTask", "doorknob": "DoorknobTask"}
    assert f"_target_: contactmpc.tasks.{cls[task]}" in out.stdout


def test_launch_rejects_misspelt_key(repo_root):
    out = _launch("--cfg", "job", "task.radiuss=1", cwd=repo_root)
    assert out.returncode != 0
    assert "radiuss" in out.stderr


# ------------------------------------------------------------------------------- 2. stability


@pytest.mark.parametrize("task", TASKS)
def test_scene_rests_stably(task, scene_for):
    """2 s passive at 1 ms (and 10 ms), servos holding ``hand_home``: nothing moves, nothing warns."""
    scene = scene_for(task)
    idx = scene.index
    for model in (scene.plant_model, scene.planner_model):
        d = scene.make_data(model)
        np.testing.assert_allclose(d.ctrl[idx.actuators], scene.task.hand_home)
        start = {b: d.xpos[b].copy() for b in idx.object_bodies}
        qo0 = scene.object_qpos(d)
        for _ in range(int(round(2.0 / model.opt.timestep))):
            mujoco.mj_step(model, d)
        dt = model.opt.timestep
        assert np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()
        assert not _warnings(d), f"{task} @ {dt}: {_warnings(d)}"
        np.testing.assert_allclose(scene.hand_qpos(d), scene.task.hand_home, atol=2e-3)
        qo = scene.object_qpos(d)
        col = 0
        for j in scene.task.object_joints:
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            if j.kind == "free":
                body = model.jnt_bodyid[jid]
                dof = model.jnt_dofadr[jid]
                speed = np.linalg.norm(d.qvel[dof : dof + 3])
                moved = np.linalg.norm(d.xpos[body] - start[body])
                assert speed < 1e-2, f"{task} @ {dt}: {j.name} still moving at {speed:.4f} m/s"
                assert moved < 5e-3, f"{task} @ {dt}: {j.name} drifted {moved * 1e3:.2f} mm"
                assert d.xpos[body][2] > scene.task.table_height, f"{task}: {j.name} fell through"
                col += 7
            else:
                assert abs(qo[col] - qo0[col]) < 0.01, f"{task} @ {dt}: {j.name} moved to {qo[col]:.4f}"
                col += 1
        if task == "doorknob":
            door, knob = qo
            assert abs(door) < 0.01 and abs(knob) < 0.01
        if task == "stapler":
            assert abs(qo[-1] - scene.task.open_angle) < 0.01, f"stapler arm at {qo[-1]:.4f}"


# -------------------------------------------------------------------------------------- 3. latch

PULL_N = 30.0  # pull on the knob towards the hand (-y), applied for 1 s
PLAY_BOUND = 0.015  # rad; geometric play is 2 mm at the bolt / 0.5 m = 0.004 rad, plus contact give
OPEN_BOUND = 0.3  # rad


def _pull_door(scene: Scene, model: mujoco.MjModel, knob_torque: float) -> tuple[float, float, dict]:
    """Pull the door by its knob for 1 s while a torque twists the knob; (max opening, knob angle)."""
    d = mujoco.MjData(model)
    home = scene.task.hand_home.copy()
    home[0] += 0.6  # park the hand clear of the door's swing
    scene.reset(d, hand_qpos=home)
    knob = model.body("knob").id
    door_q = model.joint("door_hinge").qposadr[0]
    knob_j = model.joint("knob_hinge")
    opening = 0.0
    for _ in range(int(round(1.0 / model.opt.timestep))):
        d.xfrc_applied[knob, :3] = [0.0, -PULL_N, 0.0]
        d.qfrc_applied[knob_j.dofadr[0]] = knob_torque
        mujoco.mj_step(model, d)
        opening = max(opening, -float(d.qpos[door_q]))
        assert not scene.link_contacts(d).any(), "the parked hand touched the door"
    assert np.isfinite(d.qpos).all()
    return opening, float(d.qpos[knob_j.qposadr[0]]), _warnings(d)


def test_latch_holds_until_knob_twisted(scene_for):
    scene = scene_for("doorknob")
    task = scene.task
    # Torque that holds the knob past its unlock angle against the return spring (it ends on its stop),
    # and one that holds it at only half the unlock angle.
    full = 1.2 * task.knob_stiffness * task.max_knob_angle
    half = task.knob_stiffness * 0.5 * task.unlock_angle
    for model in (scene.plant_model, scene.planner_model):
        dt = model.opt.timestep
        closed, knob0, w0 = _pull_door(scene, model, 0.0)
        partial, knob_half, w1 = _pull_door(scene, model, half)
        opened, knob1, w2 = _pull_door(scene, model, full)
        print(
            f"\n[latch @ {dt * 1e3:.0f} ms] {PULL_N:.0f} N pull for 1 s: untwisted opens {closed:.4f} rad, "
            f"knob at {knob_half:.2f} rad opens {partial:.4f} rad, knob at {knob1:.2f} rad opens "
            f"{opened:.3f} rad"
        )
        assert not (w0 or w1 or w2), (w0, w1, w2)
        assert abs(knob0) < 0.01
        assert closed < PLAY_BOUND, f"latched door opened {closed:.4f} rad @ {dt}"
        assert knob_half < task.unlock_angle and partial < PLAY_BOUND
        assert knob1 > task.unlock_angle
        assert opened > OPEN_BOUND, f"unlatched door opened only {opened:.3f} rad @ {dt}"


# ---------------------------------------------------------------- 4. planner-vs-plant agreement

POS_TOL = 5e-3  # m, object position plant vs planner at matching 10 ms instants
SPEED_BOUND = 0.5  # m/s
PENETRATION_BOUND = 3e-3  # m


def _finger_pose(q: np.ndarray, flex: tuple[float, float, float]) -> np.ndarray:
    """``q`` with joints 1-3 of the first, middle and ring fingers set to ``flex``."""
    q = q.copy()
    for f in range(3):
        q[6 + 4 * f + 1 : 6 + 4 * f + 4] = flex
    return q


def test_apple_squeeze_plant_matches_planner(scene_for):
    """Fingers curled over the apple, then the wrist pushes down and the fingers close at full torque:
    the apple is squeezed between fingers and table (the fingertips of ff/rf hit the table)."""
    scene = scene_for("apple")
    home = scene.task.hand_home
    pre = _finger_pose(home, (0.3, 0.4, 0.4))
    pre[0] -= 0.02  # wrist x: middle finger over the apple
    pre[2] -= 0.055  # wrist z: fingers just touching the apple
    state = _settle(scene, pre)
    squeeze = _finger_pose(pre, (1.6, 1.7, 1.6))  # beyond reach: the servos saturate at their limit
    squeeze[2] -= 0.025
    knots = [(0.0, pre), (0.2, squeeze), (0.5, squeeze)]
    plant, planner, gap = _compare(scene, state, knots, "apple squeeze")
    for r in (plant, planner):
        assert _hand_object_force(scene, r["data"]) > 3.0, "the hand is not squeezing the apple"
        assert r["speed"] < SPEED_BOUND
        assert r["penetration"] < PENETRATION_BOUND
    assert gap < POS_TOL


def test_stapler_press_plant_matches_planner(scene_for):
    """Palm and fingers press the stapler's arm shut against its spring."""
    scene = scene_for("stapler")
    home = scene.task.hand_home
    pre = _finger_pose(home, (0.0, 0.0, 0.0))
    pre[2] -= 0.07  # middle finger resting on the open arm
    state = _settle(scene, pre)
    press = _finger_pose(pre, (0.6, 0.6, 0.6))
    press[2] -= 0.05
    knots = [(0.0, pre), (0.25, press), (0.5, press)]
    plant, planner, gap = _compare(scene, state, knots, "stapler press")
    hinge_gap = float(np.abs(plant["qo"][:, -1] - planner["qo"][:, -1]).max())
    print(
        f"[stapler press] max |arm angle plant - planner| = {hinge_gap:.4f} rad; "
        f"arm at end plant {plant['qo'][-1, -1]:.3f} / planner {planner['qo'][-1, -1]:.3f} rad"
    )
    assert plant["qo"][0, -1] > 0.1  # starts open
    for r in (plant, planner):
        assert r["qo"][-1, -1] < 0.03, "the arm was not pressed shut"
        assert r["speed"] < SPEED_BOUND
        assert r["penetration"] < PENETRATION_BOUND
    assert gap < POS_TOL
    assert hinge_gap < 0.02


# ------------------------------------------------------------------------------------ a squeeze


def test_the_hand_squeezing_the_apple_touches_it_with_force(scene_for):
    """The fingers closed on the apple from a pre-grasp pose: several contacts, pressing (a state whose step
    cost ``job=benchmark`` and ``job=profile`` measure; a timed assertion here would test the machine's
    load, not the code)."""
    scene = scene_for("apple")
    m = scene.plant_model
    pre = _finger_pose(scene.task.hand_home, (0.3, 0.4, 0.4))
    pre[0] -= 0.02
    pre[2] -= 0.055
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, _settle(scene, pre), FULL)
    d.ctrl[scene.index.actuators] = _finger_pose(pre, (1.6, 1.7, 1.6))
    for _ in range(300):
        mujoco.mj_step(m, d)
    assert d.ncon >= 3 and _hand_object_force(scene, d) > 1.0


# -------------------------------------------------------------------------------------- render


def test_render_scene_writes_png(scene_for, tmp_path):
    scene = scene_for("stapler")
    path = render_scene(lambda: scene, tmp_path, size=(120, 160))
    assert path == tmp_path / "scene_stapler.png" and path.exists()
    img = iio.imread(path)
    assert img.shape == (120, 160, 3) and img.dtype == np.uint8
    assert img.reshape(-1, 3).std(axis=0).max() > 5.0, "the rendered image is uniform"


def test_planner_options_change_only_the_planning_model():
    """scene.planner_options: mjOption fields on the planning model; the plant keeps the scene's."""
    from contactmpc.scene import SceneError
    from tests.conftest import build_scene

    scene = build_scene(("task=apple", "+scene.planner_options={ccd_iterations: 10, cone: pyramidal}"))
    assert scene.planner_model.opt.ccd_iterations == 10
    assert scene.planner_model.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL
    assert (
        scene.plant_model.opt.ccd_iterations == 35
        and scene.plant_model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    )
    for bad, words in (("{bogus: 1}", "'bogus' is not an mjOption field"), ("{cone: round}", "cone='round'")):
        with pytest.raises(SceneError, match=words):
            build_scene(("task=apple", f"+scene.planner_options={bad}"))


def test_tilt_angle_leaves_out_the_turn_about_the_vertical():
    """tilt_angle: a turn about the world's vertical tilts nothing; a tilt about a horizontal axis is its
    angle, after a spin about the vertical too, and whichever way round the two are compared."""
    from scipy.spatial.transform import Rotation

    from contactmpc.tasks.layout import quat_angle, tilt_angle

    def quat(r: Rotation) -> np.ndarray:
        return r.as_quat(scalar_first=True)

    upright = quat(Rotation.identity())
    spun = quat(Rotation.from_euler("z", 40, degrees=True))
    tilted = Rotation.from_euler("x", 25, degrees=True)
    assert tilt_angle(upright, spun) == pytest.approx(0.0, abs=1e-9)
    assert quat_angle(upright, spun) == pytest.approx(np.radians(40))
    both = quat(Rotation.from_euler("z", 70, degrees=True) * tilted)
    assert tilt_angle(both, upright) == pytest.approx(np.radians(25))
    assert tilt_angle(upright, both) == pytest.approx(np.radians(25))
    # a body lying on its side is 90 degrees off, vectorised over leading axes
    side = quat(Rotation.from_euler("y", 90, degrees=True))
    np.testing.assert_allclose(tilt_angle(np.stack([side, both]), upright), np.radians([90, 25]))
