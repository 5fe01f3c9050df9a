"""Where a seed's outcome is decided (the method study's "Where a seed's outcome is decided").

Every levers' (or variants') trials of one paper task and seed on one processor start from the same state
and draw the same random numbers, so until their options first act they follow the same path. For each
kept trial that did not finish cleanly and has a trial of the same task and seed on the same processor that
did, this finds the clean trial that follows it longest (the hand within :data:`HAND` and the object within
:data:`OBJECT` of it at every sample) and records when their paths part, and when the failed trial first
leaves the reference (position error past :data:`POSITION` or rotation error past :data:`ROTATION` for
:data:`HOLD`, as ``analysis.timeline`` reads it), each against the reference's first expected contact, with
the reference's lift (the object :data:`LIFT` from where it starts) beside them. Writes
``figures/decided.csv`` (one row per failed trial with a clean twin), which the report reads, so a clone
without the time series (they are not all kept in git) makes the same report:

    python studies/method/decided.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from release_replay import write_rows  # this folder's script

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository's root: analysis/
from analysis.timeline import POSITION_THRESHOLD as POSITION  # noqa: E402
from analysis.timeline import ROTATION_THRESHOLD as ROTATION  # noqa: E402
from analysis.timeline import first_run  # noqa: E402

HERE = Path(__file__).resolve().parent
CSV = HERE / "figures" / "decided.csv"
FOLDERS = ("records", "heldout", "levers")
HAND = 0.01  # rad (or m): the most two paths' hand joints may differ and be the same path
OBJECT = 0.001  # m (or rad): the most two paths' object coordinates may differ
HOLD = 0.3  # s an error stays past its threshold before the object counts as off the reference
LIFT = 0.02  # m: the reference has lifted the object once it is this far from where it starts
FREE = 7  # coordinates of a free object (position, quaternion)


def trials() -> list[dict]:
    """The kept trials of the paper tasks that ran to their end and have their time series."""
    found = []
    for folder in FOLDERS:
        for path in sorted((HERE / folder).glob("*/trial.json")):
            if not (series := path.parent / "timeseries.npz").is_file():
                continue
            r = json.loads(path.read_text())
            if r.get("status") != "ok" or not str(r.get("task", "")).startswith("paper_"):
                continue
            cpu = (r.get("host") or {}).get("cpu") or r.get("cpu")
            found.append(dict(run=f"{folder}/{path.parent.name}", series=series, task=r["task"],
                              seed=int(r["seed"]), cpu=cpu, clean=bool(r["finished_cleanly"]),
                              completed=bool(r["completed"])))  # fmt: skip
    return found


def load(path: Path) -> dict[str, np.ndarray]:
    keys = ("time", "hand_qpos", "object_qpos", "expected_object_qpos", "expected_contacts")
    with np.load(path) as z:
        out = {k: z[k] for k in keys}
        out["position_error"], out["rotation_error"] = z["object_position_error"], z["object_rotation_error"]
    return out


def parted(a: dict, b: dict) -> float | None:
    """The first instant (s) at which ``a``'s and ``b``'s hand or object differ by more than
    :data:`HAND` / :data:`OBJECT`; ``None`` where their sample times differ (another pacing) or they never
    part over the samples both have."""
    n = min(len(a["time"]), len(b["time"]))
    if not np.array_equal(a["time"][:n], b["time"][:n]):
        return None
    apart = (np.abs(a["hand_qpos"][:n] - b["hand_qpos"][:n]).max(-1) > HAND) | (
        np.abs(a["object_qpos"][:n] - b["object_qpos"][:n]).max(-1) > OBJECT
    )
    return float(a["time"][np.argmax(apart)]) if apart.any() else None


def off(s: dict) -> float | None:
    """When the object first leaves the reference (s), as ``analysis.timeline`` reads it; ``None`` never."""
    t = s["time"]
    at = [first_run(np.asarray(e) > limit, t, HOLD) for e, limit in
          ((s["position_error"], POSITION), (s["rotation_error"], ROTATION))]  # fmt: skip
    return min((float(t[i]) for i in at if i is not None), default=None)


def reference_times(s: dict) -> tuple[float, float | None]:
    """The reference's first expected contact and its lift (:data:`LIFT` from the object's start; ``None``
    for an object on joints), s."""
    t = s["time"]
    first = float(t[np.argmax(s["expected_contacts"].any(-1))])
    if s["expected_object_qpos"].shape[-1] != FREE:  # an object on joints (the doorknob) is not lifted
        return first, None
    moved = np.linalg.norm(s["expected_object_qpos"][:, :3] - s["expected_object_qpos"][0, :3], axis=-1)
    return first, (float(t[np.argmax(moved > LIFT)]) if (moved > LIFT).any() else None)


def main() -> int:
    found = trials()
    groups: dict[tuple, list[dict]] = {}
    for r in found:
        groups.setdefault((r["task"], r["seed"], r["cpu"]), []).append(r)
    rows = []
    for (task, seed, _), group in sorted(groups.items(), key=lambda kv: kv[0][:2]):
        clean = [r for r in group if r["clean"]]
        failed = [r for r in group if not r["clean"]]
        if not clean or not failed:
            continue
        series = {r["run"]: load(r["series"]) for r in group}
        for r in failed:
            mine = series[r["run"]]
            twins = [(p, c) for c in clean if (p := parted(mine, series[c["run"]])) is not None]
            if not twins:
                continue
            when, twin = max(twins, key=lambda x: x[0])
            first, lift = reference_times(mine)
            left = off(mine)
            rows.append(dict(task=task.removeprefix("paper_"), seed=seed, run=r["run"], twin=twin["run"],
                             completed=r["completed"], first_contact=first, lift=lift, parted=when,
                             off=left))  # fmt: skip
        print(f"{task} seed {seed}: {len(failed)} not clean, {len(clean)} clean", file=sys.stderr)
    write_rows(rows, CSV)
    print(f"wrote {CSV} ({len(rows)} rows from {len(found)} trials)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
