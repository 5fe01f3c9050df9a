"""Planner-vs-plant agreement on every task, and what the default planning-model options cost in it.

The plant (1 ms) replays the task's reference controls from its start; at the instants where the hand
touches the object and the object moves fastest, the plant and the planning model (10 ms) run the same
reference controls for 0.5 s and the object's positions are compared (``object_gap``). The planning
model is built as the default config builds it, so its ``scene.planner_options`` (the free savings,
:data:`contactmpc.scene.FREE_PLANNER_OPTIONS`) must leave the gap where MuJoCo's defaults put it. The
paper tasks run when ``CONTACTMPC_PAPER_DATA`` names the authors' data.

Run ``pytest tests/test_agreement.py -s`` to see the gaps.
"""

from __future__ import annotations

import copy
import os

import mujoco
import numpy as np
import pytest
from hydra.utils import instantiate

import launch
from contactmpc.jobs.benchmark import object_gap
from contactmpc.reference.source import get_reference
from contactmpc.scene import FREE_PLANNER_OPTIONS, Scene
from contactmpc.trial import Trial
from tests.conftest import compose_config

SYNTHESISED = ("apple", "bottle", "stapler", "doorknob")
PAPER = ("paper_apple", "paper_bottle", "paper_stapler", "paper_doorknob")
WINDOW = 50  # planning steps (10 ms) compared
INSTANTS = 2  # states compared per task
SEPARATION = 1.0  # s between them
# What the 10 ms planning model may drift from the 1 ms plant in 0.5 s while the hand holds the object
# (measured 0.02-5.6 mm over the eight tasks: the apple rolling in the fingers is the largest).
GAP_TOL = 1e-2  # m
# The free savings are free: the planning model with them stays within a quarter of that drift (or
# 0.1 mm) of the planning model without them. Measured: 0.000-0.06 mm on seven tasks; 0.59 mm on the
# apple rolling in the fingers, where the drift itself is 5.6 mm (any change of the last digits moves a
# rolling apple: it is chaotic there).
SHARE = 0.25
FLOOR = 1e-4  # m


def moving_contact_states(
    scene: Scene, targets, object_qpos: np.ndarray, duration: float
) -> list[tuple[float, np.ndarray]]:
    """Replay ``targets`` (control time -> (T, nu)) in the plant for ``duration`` from the object at
    ``object_qpos`` (the reference's first frame); the full states at the
    :data:`INSTANTS` instants (10 ms grid, :data:`SEPARATION` apart) where the most hand links touch
    the object, and among those the object moves fastest: [(time, state)]."""
    m = scene.plant_model
    d = mujoco.MjData(m)
    hand0 = targets(np.array([0.0]))[0]
    scene.reset(d, hand_qpos=hand0, object_qpos=scene.task.start_object_qpos(object_qpos))
    body = int(scene.index.object_bodies[0])
    per = int(round(scene.planner_model.opt.timestep / m.opt.timestep))
    full = mujoco.mjtState.mjSTATE_FULLPHYSICS
    found: list[tuple[float, float, np.ndarray]] = []  # (speed, time, state)
    state = np.empty(mujoco.mj_stateSize(m, full))
    for k in range(int(duration / scene.planner_model.opt.timestep)):
        t = k * per * m.opt.timestep
        u = targets(np.array([t]))[0]
        before = d.xpos[body].copy()
        mujoco.mj_getState(m, d, state, full)
        d.ctrl[scene.index.actuators] = u
        for _ in range(per):
            mujoco.mj_step(m, d)
        touching = int(scene.link_contacts(d).sum())
        if touching:
            speed = float(np.linalg.norm(d.xpos[body] - before)) / (per * m.opt.timestep)
            saved = state.copy()
            saved[0] = t
            found.append((touching, speed, t, saved))
    chosen: list[tuple[float, np.ndarray]] = []
    for *_, t, s in sorted(found, key=lambda f: (-f[0], -f[1])):
        if all(abs(t - c) >= SEPARATION for c, _ in chosen):
            chosen.append((t, s))
        if len(chosen) == INSTANTS:
            break
    return chosen


def _setup(task: str):
    cfg = compose_config((f"task={task}", "variant=replay"))
    scene = launch.build_scene(cfg)
    reference = get_reference(scene, "outputs/cache/references")
    planner = instantiate(cfg.planner)
    sampler, cost = instantiate(cfg.sampler), instantiate(cfg.cost)
    trial = Trial(scene, reference, sampler, cost, planner, 0, progress=False)
    planner.close()
    return scene, planner, reference.object_qpos[0], trial.duration


@pytest.mark.parametrize("task", SYNTHESISED + PAPER)
def test_planning_model_follows_the_plant_and_the_free_savings_cost_nothing(task: str) -> None:
    if task in PAPER and not os.environ.get("CONTACTMPC_PAPER_DATA"):
        pytest.skip("CONTACTMPC_PAPER_DATA is not set (the authors' mjpc/tasks directory)")
    scene, planner, object_qpos, duration = _setup(task)
    assert scene.planner_options == FREE_PLANNER_OPTIONS  # the default config's planning model
    plain = copy.copy(scene.planner_model)  # MuJoCo's defaults: the planning model without the savings
    plain.opt.ccd_iterations = scene.plant_model.opt.ccd_iterations
    plain.opt.ccd_tolerance = scene.plant_model.opt.ccd_tolerance
    states = moving_contact_states(scene, planner.targets, object_qpos, duration)
    assert states, f"{task}: the reference replay never touches the object"
    dt = scene.planner_model.opt.timestep
    for t, state in states:
        controls = planner.targets(t + dt * np.arange(WINDOW))
        gap = object_gap(scene, state, controls, scene.planner_model)
        moved = object_gap(scene, state, controls, scene.planner_model, truth=plain)
        print(f"[{task} t={t:.2f}s] object: plant vs planning model {1e3 * gap:.3f} mm; "
              f"with vs without the free savings {1e3 * moved:.3f} mm")  # fmt: skip
        assert gap < GAP_TOL, f"{task} t={t:.2f}s: plant and planning model part by {1e3 * gap:.1f} mm"
        assert moved <= max(FLOOR, SHARE * gap), f"{task} t={t:.2f}s: the free savings moved the object"
