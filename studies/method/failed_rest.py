"""Where a free object is once a trial has lost it (the method study's "Where a lost object lies"): could the
grasp be tried again from the reference's approach, the object still where the reference expects it?

For each kept trial of the study's levers and held-out seeds (``levers/``, ``heldout/``: the folders whose
time series are kept) on a free object that did not complete, the object's pose :data:`AFTER` s after the
trial's failure time (or at its end, where it ends sooner), against its pose at the trial's start: how far
it moved across the table (mm), how much it rose (mm), and how far it turned (deg). Writes
``figures/failed_rest.csv`` (one row per trial), which the report reads:

    python studies/method/failed_rest.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from release_replay import series_rows  # this folder's script

from contactmpc.labels import method_name

HERE = Path(__file__).resolve().parent
CSV = HERE / "figures" / "failed_rest.csv"
FOLDERS = ("levers", "heldout")
TASKS = ("paper_apple", "paper_bottle", "paper_stapler")
AFTER = 1.0  # s after the failure time at which the object's pose is read


def rest(record: dict, series) -> dict:
    """The object's move from its start to :data:`AFTER` s after ``record``'s failure time."""
    t, q = series["time"], series["object_qpos"]
    at = min(int(np.searchsorted(t, record["failure_time"] + AFTER)), len(t) - 1)
    w0, w1 = q[0, 3:7], q[at, 3:7]
    turn = 2.0 * np.degrees(np.arccos(min(1.0, abs(float(np.dot(w0, w1))))))
    return {
        "moved": 1e3 * float(np.linalg.norm(q[at, :2] - q[0, :2])),
        "rose": 1e3 * float(q[at, 2] - q[0, 2]),
        "turned": float(turn),
        "at": float(t[at]),
    }


def row(run: Path) -> dict | None:
    """The row of the trial in ``run`` (its folder), or ``None`` where it is not one of a free object that
    did not complete."""
    record = json.loads((run / "trial.json").read_text())
    if record.get("task") not in TASKS or record.get("completed", True) or record.get("failure_time") is None:
        return None
    return {"record": f"{run.parent.name}/{run.name}", "task": record["task"], "seed": record["seed"],
            "method": method_name(record), "lifted": bool(record.get("milestone_lifted")),
            "failure_time": record["failure_time"], "after": AFTER,
            **rest(record, np.load(run / "timeseries.npz"))}  # fmt: skip


def main() -> int:
    return series_rows("failed_rest", HERE, FOLDERS, row, CSV)


if __name__ == "__main__":
    sys.exit(main())
