"""Planner-vs-plant agreement on every task, and what the default planning-model options cost in it.

The plant (1 ms) replays the task's reference splines from its start; at the instants where the most
hand links touch the object (and among those, the object moves fastest), the plant and the planning
model (10 ms) run the same reference controls for 0.5 s and the object's positions are compared
(``object_gap``). The planning model is built as the default config builds it, and with its
``scene.planner_options`` (the free savings, :data:`contactmpc.scene.FREE_PLANNER_OPTIONS`) it must agree
with the plant as well as with MuJoCo's defaults. The paper tasks run when ``CONTACTMPC_PAPER_DATA``
names the authors' data.

Run ``pytest tests/test_agreement.py -s`` to see the gaps.
"""

from __future__ import annotations

import copy
import os

import numpy as np
import pytest
from hydra.utils import instantiate

import launch
from contactmpc.jobs.benchmark import full_state, object_gap, replay
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
# (measured 0.02-5.8 mm over the eight tasks: the apple rolling in the fingers is the largest).
GAP_TOL = 1e-2  # m
# The free savings are free: with them the planning model agrees with the plant as well as without them,
# within a tenth of the gap or 0.05 mm. Measured: the same gap to 0.01 mm on every state but one; there,
# the apple rolling over a fingertip, 10 convex-collision iterations (MuJoCo's 35; 15 or more change
# nothing) take the apple 6.5 mm from where MuJoCo's defaults take it, and the plant's apple is 5.8 mm
# from both.
SHARE = 0.1
FLOOR = 5e-5  # m


def moving_contact_states(scene: Scene, trial: Trial) -> list[tuple[float, np.ndarray]]:
    """Replay ``trial``'s reference in the plant (:func:`~contactmpc.jobs.benchmark.replay`); the full
    states at the :data:`INSTANTS` instants (10 ms grid, :data:`SEPARATION` apart) where the most hand
    links touch the object, and among those the object moves fastest: [(time, state)]."""
    body = int(scene.index.object_bodies[0])
    dt = scene.planner_model.opt.timestep
    found: list[tuple[int, float, float, np.ndarray]] = []  # (links touching, speed, time, state)
    before = None
    for t, d in replay(scene, trial, dt):
        if t > trial.duration:
            break
        touching = int(scene.link_contacts(d).sum())
        if touching and before is not None:
            speed = float(np.linalg.norm(d.xpos[body] - before)) / dt
            found.append((touching, speed, t, full_state(scene.plant_model, d, t)))
        before = d.xpos[body].copy()
    chosen: list[tuple[float, np.ndarray]] = []
    for *_, t, s in sorted(found, key=lambda f: (-f[0], -f[1])):
        if all(abs(t - c) >= SEPARATION for c, _ in chosen):
            chosen.append((t, s))
        if len(chosen) == INSTANTS:
            break
    return chosen


def _setup(task: str) -> tuple[Scene, Trial]:
    cfg = compose_config((f"task={task}", "variant=replay"))
    scene = launch.build_scene(cfg)
    reference = get_reference(scene, "outputs/cache/references")
    planner = instantiate(cfg.planner)
    sampler, cost = instantiate(cfg.sampler), instantiate(cfg.cost)
    trial = Trial(scene, reference, sampler, cost, planner, 0, progress=False)
    planner.close()
    return scene, trial


@pytest.mark.parametrize("task", SYNTHESISED + PAPER)
def test_planning_model_follows_the_plant_and_the_free_savings_cost_nothing(task: str) -> None:
    if task in PAPER and not os.environ.get("CONTACTMPC_PAPER_DATA"):
        pytest.skip("CONTACTMPC_PAPER_DATA is not set (the authors' mjpc/tasks directory)")
    scene, trial = _setup(task)
    assert scene.planner_options == FREE_PLANNER_OPTIONS  # the default config's planning model
    plain = copy.copy(scene.planner_model)  # MuJoCo's defaults: the planning model without the savings
    plain.opt.ccd_iterations = scene.plant_model.opt.ccd_iterations
    plain.opt.ccd_tolerance = scene.plant_model.opt.ccd_tolerance
    states = moving_contact_states(scene, trial)
    assert states, f"{task}: the reference replay never touches the object"
    dt = scene.planner_model.opt.timestep
    for t, state in states:
        controls = trial.planner.targets(t + dt * np.arange(WINDOW))
        gap, before = (object_gap(scene, state, controls, m) for m in (scene.planner_model, plain))
        moved = object_gap(scene, state, controls, scene.planner_model, truth=plain)
        print(
            f"[{task} t={t:.2f}s] object, plant vs planning model: {1e3 * gap:.3f} mm with the free "
            f"savings, {1e3 * before:.3f} mm without; the two planning models {1e3 * moved:.3f} mm apart"
        )
        assert gap < GAP_TOL, f"{task} t={t:.2f}s: plant and planning model part by {1e3 * gap:.1f} mm"
        assert gap <= before + max(FLOOR, SHARE * before), (
            f"{task} t={t:.2f}s: the free savings cost agreement"
        )
