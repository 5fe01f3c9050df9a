"""The operating-point map: completion, TTF, error and compute per planner size, on the real data.

Reads the records of ``experiment=operating_point`` (or any sweep over ``planner.num_samples``,
``planner.horizon``, the replan interval and the latency) and groups the trials by task, fidelity (as
:mod:`analysis.paper_fig3` tells it from the config) and operating point: samples x horizon, the replan
interval and the latency each record states (``replan_interval``, ``latency``). Per point: trials,
completed, finished cleanly, the milestones reached, median TTF, the object position error (mean over the
contact span, mean after it, mean over the whole trial, final; NaN where an older record lacks one), and the
compute one trial cost (``cpu_seconds`` where the record has it, else its wall time; single-threaded jobs).

``cheapest`` names, per task and fidelity, the cheapest point (by the rollout steps it simulates per
second of control, samples x horizon steps / interval) that completes at least ``need`` of its trials
wherever the paper point (128 samples, 2.5 s) completes that many too.

Outputs (:func:`write_operating_point`): ``operating_point.csv`` and ``operating_point.md``.

Command line::

    python -m analysis.operating_point SWEEP_DIR [SWEEP_DIR ...] [--out-dir DIR] [--need 5/6]
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis._cli import fail, sweep_parser
from analysis.aggregate import TASK_ORDER, ordered
from analysis.paper_fig3 import FIDELITY_ORDER, fidelities, fidelity_of

PAPER_POINT = (128, 2.5)  # samples, horizon (s)


def load(*dirs: str | Path) -> pd.DataFrame:
    """One row per trial record: task, fidelity, samples, horizon, interval (s), latency (s), seed,
    status, completed, finished cleanly, ttf, errors, compute seconds, milestones reached (name -> bool)."""
    known = fidelities()
    rows = []
    for d in dirs:
        if not Path(d).is_dir():
            raise FileNotFoundError(f"no such sweep directory: {d}")
        for path in sorted(Path(d).rglob("trial.json")):
            try:
                r = json.loads(path.read_text())
            except (OSError, ValueError):
                continue
            planner = (r.get("config") or {}).get("planner") or {}
            if "num_samples" not in planner:
                continue
            ok = r.get("status") == "ok"
            interval = r.get("replan_interval") or planner.get("replan_period")
            rows.append(
                {
                    "task": r.get("task"),
                    "fidelity": fidelity_of(r.get("config"), known),
                    "samples": int(planner["num_samples"]),
                    "horizon": float(planner["horizon"]),
                    "interval": round(float(interval), 4),
                    "latency": round(float(r.get("latency") or planner.get("latency") or 0.0), 4),
                    "seed": r.get("seed"),
                    "status": r.get("status"),
                    "completed": bool(r.get("completed")) if ok else False,
                    "finished_cleanly": bool(r.get("finished_cleanly")) if ok else False,
                    "ttf": r.get("ttf") if ok else np.nan,
                    "error_span": r.get("object_position_error_span_mean") if ok else np.nan,
                    "error_after": r.get("object_position_error_after_mean") if ok else np.nan,
                    "error_mean": r.get("object_position_error_mean") if ok else np.nan,
                    "error_final": r.get("final_object_position_error") if ok else np.nan,
                    "compute": r.get("cpu_seconds") or r.get("wall_seconds"),
                    "milestones": {k[10:]: bool(v) for k, v in r.items() if k.startswith("milestone_")},
                }
            )
    if not rows:
        raise ValueError(f"no trial records with a planner config under {', '.join(map(str, dirs))}")
    return pd.DataFrame(rows)


def steps_per_second(samples: int, horizon: float, interval: float, planner_dt: float = 0.01) -> float:
    """Rollout steps the point simulates per second of control: the compute it asks for."""
    return samples * max(1, round(horizon / planner_dt)) / interval


def summary(df: pd.DataFrame) -> pd.DataFrame:
    """Per task, fidelity and point: trials, completed, finished cleanly, milestones, TTF, errors (medians
    over the trials: in the span, after it, whole trial, final), compute."""
    keys = ["task", "fidelity", "samples", "horizon", "interval", "latency"]
    rows = []
    for key, g in df.groupby(keys, sort=False):
        reached: dict[str, int] = {}
        for m in g["milestones"]:
            for name, hit in m.items():
                reached[name] = reached.get(name, 0) + int(hit)
        row = dict(zip(keys, key, strict=True))
        row.update(
            trials=len(g),
            errors=int((g["status"] != "ok").sum()),
            completed=int(g["completed"].sum()),
            finished_cleanly=int(g["finished_cleanly"].sum()),
            milestones=", ".join(f"{k} {v}" for k, v in reached.items()),
            ttf_median=float(pd.to_numeric(g["ttf"], errors="coerce").median()),
            error_span_mm=1e3 * float(pd.to_numeric(g["error_span"], errors="coerce").median()),
            error_after_mm=1e3 * float(pd.to_numeric(g["error_after"], errors="coerce").median()),
            error_mean_mm=1e3 * float(pd.to_numeric(g["error_mean"], errors="coerce").median()),
            error_final_mm=1e3 * float(pd.to_numeric(g["error_final"], errors="coerce").median()),
            compute_s=float(pd.to_numeric(g["compute"], errors="coerce").median()),
            cost=steps_per_second(int(key[2]), float(key[3]), float(key[4])),
        )
        rows.append(row)
    out = pd.DataFrame(rows)
    task_rank = {t: i for i, t in enumerate(ordered(out["task"], TASK_ORDER))}
    fid_rank = {f: i for i, f in enumerate(ordered(out["fidelity"], FIDELITY_ORDER))}
    out["_t"], out["_f"] = out["task"].map(task_rank), out["fidelity"].map(fid_rank)
    return out.sort_values(["_t", "_f", "cost"]).drop(columns=["_t", "_f"]).reset_index(drop=True)


def cheapest(table: pd.DataFrame, need: float = 5 / 6) -> pd.DataFrame:
    """Per task and fidelity, the cheapest point completing at least ``need`` of its trials, next to the
    paper point's completion (``None`` where no point does)."""
    rows = []
    for (task, fid), g in table.groupby(["task", "fidelity"], sort=False):
        works = g[g["completed"] >= np.ceil(need * g["trials"] - 1e-9)]
        paper = g[(g["samples"] == PAPER_POINT[0]) & (g["horizon"] == PAPER_POINT[1])]
        best = works.sort_values("cost").head(1)
        rows.append(
            {
                "task": task,
                "fidelity": fid,
                "paper_point": "; ".join(
                    f"{1e3 * r.interval:.0f} ms{'' if r.latency else ' (no latency)'}: "
                    f"{r.completed}/{r.trials}"
                    for r in paper.itertuples()
                ),
                "cheapest": None if best.empty else label(best.iloc[0]),
                "completed": None if best.empty else f"{best.iloc[0].completed}/{best.iloc[0].trials}",
            }
        )
    return pd.DataFrame(rows)


def label(row) -> str:
    """``128 x 2.5 s, every 96 ms (latency 96 ms)``."""
    return (
        f"{row['samples']} x {row['horizon']:g} s, every {1e3 * row['interval']:.0f} ms "
        f"(latency {1e3 * row['latency']:.0f} ms)"
    )


def markdown(table: pd.DataFrame, best: pd.DataFrame) -> str:
    """The map and the cheapest points as markdown tables."""
    lines = [
        "| task | fidelity | samples x horizon | interval | latency | completed | finished cleanly "
        "| milestones | TTF median | object error in span / after span / whole trial / final (mm, median) "
        "| compute per trial (s) | rollout steps per s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table.itertuples():
        lines.append(
            f"| {r.task} | {r.fidelity} | {r.samples} x {r.horizon:g} s | {1e3 * r.interval:.0f} ms "
            f"| {1e3 * r.latency:.0f} ms | {r.completed}/{r.trials}"
            + (f" ({r.errors} error)" if r.errors else "")
            + f" | {r.finished_cleanly}/{r.trials} | {r.milestones} | {_num(r.ttf_median, '{:.2f}')} | "
            + " / ".join(
                _num(e, "{:.0f}")
                for e in (r.error_span_mm, r.error_after_mm, r.error_mean_mm, r.error_final_mm)
            )
            + f" | {_num(r.compute_s, '{:.0f}')} | {r.cost:,.0f} |"
        )
    lines += ["", "| task | fidelity | paper point(s) | cheapest point that completes | completed |"]
    lines.append("|---|---|---|---|---|")
    for r in best.itertuples():
        point, done = r.cheapest or "none", r.completed or "-"
        lines.append(f"| {r.task} | {r.fidelity} | {r.paper_point} | {point} | {done} |")
    return "\n".join(lines) + "\n"


def _num(value: float, fmt: str) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else fmt.format(value)


def write_operating_point(df: pd.DataFrame, out_dir: str | Path, need: float = 5 / 6) -> Path:
    """Write ``operating_point.csv`` and ``operating_point.md`` into ``out_dir``; returns the .md path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    table = summary(df)
    table.to_csv(out / "operating_point.csv", index=False)
    path = out / "operating_point.md"
    path.write_text(markdown(table, cheapest(table, need)))
    return path


def main(argv: list[str] | None = None) -> int:
    parser = sweep_parser("python -m analysis.operating_point", __doc__.split("\n\n")[0])
    parser.add_argument("--out-dir", help="where to write (default: <first SWEEP_DIR>/analysis)")
    parser.add_argument("--need", default="5/6", help="share of trials a point must complete (a/b)")
    args = parser.parse_args(argv)
    try:
        num, _, den = args.need.partition("/")
        need = float(num) / float(den or 1)
        path = write_operating_point(
            load(*args.sweep_dirs), args.out_dir or Path(args.sweep_dirs[0]) / "analysis", need
        )
    except (ValueError, OSError) as err:
        return fail(err)
    print(path.read_text(), end="")
    print(f"wrote {path} and operating_point.csv")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
