"""When each paper task's reference closes its grasp (the method study's "When the reference closes its
grasp"): from the reference's expected contacts on the planning grid (as the planner's track has them), how
many fingers it expects on the object over the first :data:`WINDOW` s after its first expected contact
(a finger: the hand links named ``<finger>_*``; the palm is none), when it first expects each number of
fingers, and how long it expects one finger alone; where ``planner.reuse_grasp`` (reuse=elites_expected,
3 fingers) opens. Writes ``figures/reference_grasp.csv``, which the report reads:

    CONTACTMPC_PAPER_DATA=... python studies/method/reference_grasp.py
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
from release_replay import scene_of, write_rows  # this folder's script
from settle import record_of  # this folder's script

from contactmpc.control.planners.base import expected_fingers
from contactmpc.control.track import ReferenceTrack
from contactmpc.reference.source import get_reference

HERE = Path(__file__).resolve().parent
CSV = HERE / "figures" / "reference_grasp.csv"
TASKS = ("paper_doorknob", "paper_apple", "paper_bottle", "paper_stapler")
WINDOW = 2.0  # s after the first expected contact (effort=acquire's window)


def rows_of(task: str, paper_data: str) -> list[dict]:
    """``task``'s rows: per step of the planning grid in the window, its time after the first expected
    contact and the fingers the reference expects on the object."""
    scene = scene_of(record_of(task), paper_data)
    reference = get_reference(scene)
    track = ReferenceTrack.build(
        reference, scene.task.layout, scene.task.time_scale, scene.planner_timestep, 0.0
    )
    fingers = expected_fingers(track.contact_active, scene.hand.link_names)
    first = int(np.flatnonzero(fingers > 0)[0])
    steps = range(first, min(len(fingers), first + int(round(WINDOW / track.dt)) + 1))
    return [
        {"task": task, "time": round((k - first) * track.dt, 6), "fingers": int(fingers[k])} for k in steps
    ]


def main() -> None:
    paper_data = os.environ.get("CONTACTMPC_PAPER_DATA")
    if not paper_data:
        sys.exit("reference_grasp: set CONTACTMPC_PAPER_DATA to the paper authors' mjpc/tasks directory")
    write_rows([row for task in TASKS for row in rows_of(task, paper_data)], CSV)


if __name__ == "__main__":
    main()
