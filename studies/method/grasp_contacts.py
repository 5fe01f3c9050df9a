"""Which links are on the object while the grasp is won (the method study's "Who is on the object while the
grasp is won"): for every kept trial of the study on a free object whose time series is here (the levers'
and the held-out trials keep theirs in git), over the :data:`GRASP` s from the reference's first expected
contact, the share of the logged samples on which a thumb link touches the object, on which an index link
does and no other link (the index alone), and on which any link does; when any link first touches it (s
after that expected contact); with the trial's option (its method, a lever's overrides on top) and
outcome. Writes ``figures/grasp_contacts.csv``, which the report reads:

    python studies/method/grasp_contacts.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from release_replay import series_rows  # this folder's script

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository's root: analysis/
from analysis.timeline import link_names  # noqa: E402
from contactmpc.labels import method_labels, method_name

HERE = Path(__file__).resolve().parent
CSV = HERE / "figures" / "grasp_contacts.csv"
FOLDERS = ("records", "heldout", "levers")
TASKS = ("paper_apple", "paper_bottle", "paper_stapler")
GRASP = 2.0  # s from the first expected contact: effort=acquire's window, where the grasp is won
THUMB, INDEX = "th_", "ff_"  # the Allegro hand's link name prefixes


def option(run: Path, record: dict) -> str:
    """The trial's method, with a lever's overrides (its run folder's name less the experiment, seed, task
    and variant, and the groups the method's name already sets so) after a ``+``."""
    name = method_name(record) or str(record.get("variant"))
    if run.parent.name != "levers":
        return name
    keep = ("experiment", "seed", "task", "variant")
    extra = [p for p in run.name.split(",") if p.split("=", 1)[0] not in keep]
    own = method_labels({"variant": name})  # (a group the named method already sets to that member)
    return name + "".join(f"+{p}" for p in extra if own.get(p.split("=", 1)[0]) != p.split("=", 1)[1])


def row(run: Path) -> dict | None:
    """One trial's row, or None without a finished record, an expected contact or the link names."""
    record = json.loads((run / "trial.json").read_text())
    if record.get("status") != "ok" or record.get("task") not in TASKS:
        return None
    start = record.get("contact_span_start")
    if start is None:
        return None
    with np.load(run / "timeseries.npz") as z:
        t, contacts = z["time"], z["contacts"].astype(bool)
    names, note = link_names(record, contacts.shape[-1])
    if note is not None:
        return None
    window = (t >= start) & (t < start + GRASP)
    if not window.any():
        return None
    c = contacts[window]
    thumb = np.array([n.startswith(THUMB) for n in names])
    index = np.array([n.startswith(INDEX) for n in names])
    alone = c[:, index].any(axis=1) & ~c[:, ~index].any(axis=1)
    touched = np.flatnonzero(contacts.any(axis=1))
    return {
        "record": str(run.relative_to(HERE)),
        "task": record["task"],
        "option": option(run, record),
        "seed": int(record["seed"]),
        "thumb": float(c[:, thumb].any(axis=1).mean()),
        "index_alone": float(alone.mean()),
        "any": float(c.any(axis=1).mean()),
        "first_touch": float(t[touched[0]] - start) if len(touched) else float("nan"),
        "lifted": bool(record.get("milestone_lifted")),
        "completed": bool(record.get("completed")),
        "finished_cleanly": bool(record.get("finished_cleanly")),
        "grasp": GRASP,
    }


def main() -> int:
    return series_rows("grasp_contacts", HERE, FOLDERS, row, CSV)


if __name__ == "__main__":
    raise SystemExit(main())
