"""Can the planning model keep its 10 ms step and hold the grasps the plant holds, with other physics? The
method's held-out trials on the free objects replayed open-loop, as ``lift_replay.py`` replays them, in the
plant, in the method's planning model (10 ms), in that model with each physics option of :data:`OPTIONS`
(friction, the no-slip solver, the impedance ratio, the integrator, the solver's iterations, the contact's
time constant), and in the model stepped at 5 ms (the method study's "The planning model's physics").

Each option is set on the planning model only, as ``scene.planner_options`` or a model field would set it;
none is an option of the library: this script asks whether one is worth making. A replay lifts the object
where it ends at least ``lift_replay.LIFT`` above where it started. Writes ``figures/model_physics.csv``
(one row per trial and model: the rise, whether it lifted, the replay's CPU seconds), which the report
reads, so a clone without the time series makes the same report:

    CONTACTMPC_PAPER_DATA=... python studies/method/model_physics.py
"""

from __future__ import annotations

import copy
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
from lift_replay import AFTER, BEFORE, LIFT, replay, trials, window  # this folder's scripts
from release_replay import scene_of, write_rows

HERE = Path(__file__).resolve().parent
CSV = HERE / "figures" / "model_physics.csv"
FOLDER = "heldout"  # the default method's held-out trials, whose time series are kept
METHOD = "grasp_held_expected"


def _override(timeconst: float) -> Callable[[mujoco.MjModel], None]:
    """Every contact's time constant set to ``timeconst`` (s; MuJoCo's override of solref, its damping
    ratio and solimp left at the scene's defaults), below the two steps MuJoCo otherwise floors it at."""

    def edit(m: mujoco.MjModel) -> None:
        m.opt.enableflags |= int(mujoco.mjtEnableBit.mjENBL_OVERRIDE)
        m.opt.o_solref[:] = [timeconst, 1.0]
        m.opt.o_solimp[:] = [0.9, 0.95, 0.001, 0.5, 2.0]
        m.opt.o_margin = 0.0
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_REFSAFE)

    return edit


def _friction(scale: float) -> Callable[[mujoco.MjModel], None]:
    def edit(m: mujoco.MjModel) -> None:
        m.geom_friction[:, 0] *= scale

    return edit


def _option(**fields) -> Callable[[mujoco.MjModel], None]:
    def edit(m: mujoco.MjModel) -> None:
        for key, value in fields.items():
            setattr(m.opt, key, value)

    return edit


OPTIONS: dict[str, Callable[[mujoco.MjModel], None]] = {
    "friction x1.5": _friction(1.5),
    "friction x2": _friction(2.0),
    "no-slip solver, 3 iterations": _option(noslip_iterations=3),
    "impedance ratio 100 (the scene's 10)": _option(impratio=100.0),
    "implicit integrator (the scene's implicitfast)": _option(
        integrator=int(mujoco.mjtIntegrator.mjINT_IMPLICIT)
    ),
    "200 solver iterations, tolerance 1e-10": _option(iterations=200, tolerance=1e-10),
    "contact time constant 40 ms (softer)": _override(0.04),
    "contact time constant 16 ms (under 2 steps)": _override(0.016),
    "contact time constant 12 ms (under 2 steps)": _override(0.012),
}
"""The physics options tried on the 10 ms planning model: name -> its edit of a copy of the model."""


def runs(scene) -> list[tuple[str, float, mujoco.MjModel]]:
    """``(name, step, model)`` of every replay of a trial: the plant, the method's planning model, it with
    each of :data:`OPTIONS`, and the model stepped at 5 ms."""
    base = scene.planner_model
    out = [("plant", scene.plant_model.opt.timestep, scene.plant_model), ("10 ms", base.opt.timestep, base)]
    for name, edit in OPTIONS.items():
        m = copy.deepcopy(base)
        edit(m)
        out.append((f"10 ms, {name}", base.opt.timestep, m))
    out.append(("5 ms", 0.005, scene.stepped(0.005).planner_model))
    return out


def main() -> int:
    paper_data = os.environ.get("CONTACTMPC_PAPER_DATA")
    if not paper_data:
        print("model_physics: error: set CONTACTMPC_PAPER_DATA to the authors' mjpc/tasks", file=sys.stderr)
        return 2
    rows = []
    for path, record, series in trials(HERE / FOLDER, METHOD):
        start, end, z0 = window(record, series)
        scene = scene_of(record, paper_data)
        for name, step, model in runs(scene):
            began = time.process_time()
            _, heights = replay(scene, model, series, start, end)
            cpu = time.process_time() - began
            rise = float(heights[-1] - z0)
            rows.append({"record": path.parent.name, "task": record["task"], "seed": record["seed"],
                         "model": name, "step": step, "rise": rise, "lifted": rise >= LIFT,
                         "cpu": cpu, "before": BEFORE, "after": AFTER})  # fmt: skip
        print(f"{record['task']} seed {record['seed']}: {len(OPTIONS) + 3} replays")
    if not rows:
        print(f"model_physics: error: no trial of {METHOD} with its series in {FOLDER}/", file=sys.stderr)
        return 1
    write_rows(rows, CSV)
    print(f"wrote {CSV}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
