"""When the hand first touches the object, against when the reference first expects it to (the method study's
"When the hand reaches the object"): for every kept trial of the study whose time series is on this machine
(``timeseries.npz`` next to its ``trial.json``; the series are not kept in git), the first logged instant of
any hand-object contact less the reference's first expected contact (``contact_span_start``), and how far
the object had moved from where it started by :data:`AFTER` s after that expected contact; with the trial's
outcome. Writes ``figures/first_touch.csv``, which the report reads:

    python studies/method/first_touch.py
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from release_replay import series_rows  # this folder's script

from contactmpc.labels import method_name

HERE = Path(__file__).resolve().parent
CSV = HERE / "figures" / "first_touch.csv"
FOLDERS = ("records", "heldout", "levers", "latency", "loop")
AFTER = 0.5  # s after the first expected contact at which the object's displacement is read


def row(run: Path) -> dict | None:
    """One trial's row, or None without its series, a finished record or an expected contact."""
    record = json.loads((run / "trial.json").read_text())
    if record.get("status") != "ok" or record.get("contact_span_start") is None:
        return None
    with np.load(run / "timeseries.npz") as z:
        t, touching, qo = z["time"], z["contacts"].any(axis=-1), z["object_qpos"]
    start = float(record["contact_span_start"])
    i = min(int(np.searchsorted(t, start + AFTER - 1e-9)), len(t) - 1)
    return {
        "record": str(run.relative_to(HERE)),
        "task": record.get("task"),
        "method": method_name(record) or record.get("variant"),
        "shaping": record.get("shaping"),
        "latency": record.get("latency"),
        "loop": record.get("loop"),
        "seed": record.get("seed"),
        "first_touch": float(t[int(touching.argmax())]) - start if touching.any() else None,
        "displaced_mm": 1e3 * float(np.linalg.norm(qo[i, :3] - qo[0, :3])),
        "lifted": record.get("milestone_lifted"),
        "completed": record.get("completed"),
        "finished_cleanly": record.get("finished_cleanly"),
    }


def main() -> int:
    return series_rows("first_touch", HERE, FOLDERS, row, CSV)


if __name__ == "__main__":
    raise SystemExit(main())
