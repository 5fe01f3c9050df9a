"""The cheap screen's table (issue 33): per lever x task, completed / lifted / TTF / CPU-s / rise over seeds.

    python studies/method_screen/table.py studies/method_screen/records [--full RESULTS_DIR ...]

A lever is named from the record's config: the variant, then each lever option that differs from its
default (planner.iterations, anneal, early_stop, update; sampler.noise_ramp). With ``--full`` the same
table of the full trials in those directories (text's reading, preset=paper_32samples) is printed
beside it, for the ranking. ``rise``: the object's highest rise over its start (mm, the first free
body's z), where the record's ``timeseries.npz`` is at hand (not kept in git).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

LEVER_KEYS = (
    ("planner", "iterations", 1, "it"),
    ("planner", "anneal", 1.0, "anneal"),
    ("planner", "early_stop", 0.0, "stop"),
    ("planner", "update", "max", ""),
    ("sampler", "noise_ramp", 1.0, "ramp"),
)


def lever(record: dict) -> str:
    """The record's lever: its variant and the lever options it sets."""
    config = record.get("config") or {}
    parts = [str(record.get("variant"))]
    for group, key, default, short in LEVER_KEYS:
        value = (config.get(group) or {}).get(key, default)
        if value is not None and value != default:
            parts.append(f"{short}{value}" if short else str(value))
    return " ".join(parts)


def load(root: Path, paper_32: bool = False) -> dict[tuple[str, str], list[dict]]:
    cells: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for path in sorted(root.glob("*/trial.json")):
        record = json.loads(path.read_text())
        if record.get("task") not in ("paper_stapler", "paper_bottle"):
            continue
        if paper_32:  # the full trials: text's reading at the 32-sample point
            config = record.get("config") or {}
            if record.get("preset") != "paper_32samples" or record.get("operating_point"):
                continue
            if (config.get("fidelity") or {}).get("failure_gap", 0.3) != 0.3 or "authors_code" in str(path):
                continue
        series = path.parent / "timeseries.npz"  # kept locally only: the object's highest rise
        if series.exists():
            z = np.load(series)["object_qpos"][:, 2]
            record["rise_mm"] = 1000 * float(z.max() - z[0])
        cells[(lever(record), record["task"])].append(record)
    return cells


def row(records: list[dict]) -> str:
    ok = [r for r in records if r.get("status") in ("ok", "diverged")]
    ttf = [r["ttf"] for r in ok if r.get("ttf") is not None]
    cpu = [r["cpu_seconds"] for r in ok if r.get("cpu_seconds") is not None]
    rise = [r["rise_mm"] for r in ok if "rise_mm" in r]
    seeds = ",".join(str(r["seed"]) for r in sorted(ok, key=lambda r: r["seed"]))
    return (
        f"{sum(bool(r.get('completed')) for r in ok)}/{len(ok):<3} "
        f"{sum(bool(r.get('milestone_lifted')) for r in ok)}/{len(ok):<3} "
        f"{np.median(ttf) if ttf else float('nan'):6.2f} {np.median(cpu) if cpu else float('nan'):7.0f} "
        f"{np.median(rise) if rise else float('nan'):7.0f}  "
        f"seeds {seeds}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("records", type=Path)
    parser.add_argument("--full", type=Path, nargs="*", default=[])
    args = parser.parse_args(argv)
    if not args.records.is_dir():
        print(f"table: error: {args.records} is not a directory", file=sys.stderr)
        return 1
    for title, cells in [("screen", load(args.records))] + [
        (f"full trials {d}", load(d, paper_32=True)) for d in args.full
    ]:
        print(f"## {title}\n{'lever':<60} {'task':<14} completed lifted TTF(med) CPU-s(med) rise-mm(med)")
        for (name, task), records in sorted(cells.items(), key=lambda kv: (kv[0][1], kv[0][0])):
            print(f"{name:<60} {task:<14} {row(records)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
