"""Where each of the paper's free objects comes to rest before the hand reaches it (the method study's "Where
the object rests before the hand arrives"): the plant started as a trial starts it (the object at the task's
start, the hand at the reference's first configuration, held there, at rest), then run :data:`SECONDS` of
control time with the hand held (and again from the reference's first configuration itself, without the
task's start offset); every :data:`EVERY` s, the object's distance (mm) and turn (deg) from the
reference's first configuration, the frame the trial's object errors are measured against. The hand does not
reach the object in that time (the reference's first expected contact is seconds later). Writes
``figures/settle.csv``, which the report reads:

    CONTACTMPC_PAPER_DATA=... python studies/method/settle.py
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import mujoco
import numpy as np
from release_replay import scene_of, write_rows  # this folder's script

from contactmpc.reference.source import get_reference

HERE = Path(__file__).resolve().parent
CSV = HERE / "figures" / "settle.csv"
TASKS = ("paper_apple", "paper_bottle", "paper_stapler")
METHOD_RECORD = "variant=grasp_held_eased"  # the kept records whose configs build the scenes
SECONDS = 1.0
EVERY = 0.05
STARTS = ("task", "reference")  # where the object starts: as a trial starts it, or at the reference's pose


def record_of(task: str) -> dict:
    """A kept record of the method on ``task`` (its config builds the scene as the trials had it)."""
    for path in sorted((HERE / "records").glob(f"*task={task},{METHOD_RECORD}/trial.json")):
        return json.loads(path.read_text())
    raise SystemExit(f"settle: no kept record of the method on {task} in {HERE / 'records'}")


def settle(task: str, paper_data: str, start: str = "task") -> list[dict]:
    """The rows of ``task``: the object's offset from the reference's first configuration over time, the
    object started where the task starts it (``start="task"``, as a trial does) or at the reference's first
    configuration itself (``"reference"``: without the task's start offset)."""
    scene = scene_of(record_of(task), paper_data)
    reference = get_reference(scene)
    m = scene.plant_model
    d = mujoco.MjData(m)
    qo = reference.object_qpos[0]
    scene.reset(
        d,
        hand_qpos=reference.hand_qpos[0],
        object_qpos=scene.task.start_object_qpos(qo) if start == "task" else qo,
    )
    every = int(round(EVERY / m.opt.timestep))
    rows = []
    for k in range(int(round(SECONDS / m.opt.timestep)) + 1):
        if k % every == 0:
            error = scene.task.layout.error(scene.object_qpos(d), reference.object_qpos[0])
            rows.append(
                {
                    "task": task,
                    "start": start,
                    "time": round(k * m.opt.timestep, 6),
                    "position_mm": 1e3 * float(error.position),
                    "rotation_deg": float(np.degrees(error.rotation)),
                    "hand_contacts": int(scene.link_contacts(d).sum()),
                }
            )
        mujoco.mj_step(m, d)
    return rows


def main() -> None:
    paper_data = os.environ.get("CONTACTMPC_PAPER_DATA")
    if not paper_data:
        sys.exit("settle: set CONTACTMPC_PAPER_DATA to the paper authors' mjpc/tasks directory")
    rows = [row for task in TASKS for start in STARTS for row in settle(task, paper_data, start)]
    write_rows(rows, CSV)
    for task in TASKS:
        for start in STARTS:
            last = [r for r in rows if r["task"] == task and r["start"] == start][-1]
            print(
                f"{task} from the {start}'s start: {last['position_mm']:.1f} mm, "
                f"{last['rotation_deg']:.1f} deg"
            )
    print(f"settle: wrote {CSV}")


if __name__ == "__main__":
    main()
