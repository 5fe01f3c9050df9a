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
        [--task apple,stapler] [--variant full,wrist_acquire] [--fidelity paper]

``--task``, ``--variant`` and ``--fidelity`` keep only those rows (comma-separated, the task without its
``paper_`` prefix): e.g. ``studies/fig3_paper/records``'s full-method apple and bottle beside the map's sweep.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from analysis._cli import fail, sweep_parser
from analysis.aggregate import TASK_ORDER, ordered, select
from analysis.paper_fig3 import FIDELITY_ORDER, fidelities, fidelity_of
from analysis.paper_fig3 import load as fig3_load
from analysis.summarize import Stat, summarize

PAPER_POINT = (128, 2.5)  # samples, horizon (s)


def load(*dirs: str | Path) -> pd.DataFrame:
    """One row per trial record of ``dirs`` with a planner config (:func:`points`)."""
    for d in dirs:
        if not Path(d).is_dir():
            raise FileNotFoundError(f"no such sweep directory: {d}")
    try:
        return points(fig3_load(*dirs))
    except ValueError as err:
        raise ValueError(f"{err} under {', '.join(map(str, dirs))}") from None


def readings(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` (:func:`analysis.aggregate.load_records`) with the ``fidelity`` each record's config holds
    (:func:`analysis.paper_fig3.fidelity_of`) as its ``condition`` and the ``paper_`` prefix dropped from
    task names: what :func:`analysis.paper_fig3.load` makes of directories, made of a loaded table."""
    df = df.copy()
    if "fidelity" not in df:
        known = fidelities()
        df["fidelity"] = [fidelity_of(_config(p), known) for p in df["record_path"]]
    df["condition"] = df["fidelity"]
    df["task"] = df["task"].str.removeprefix("paper_")
    return df


def points(df: pd.DataFrame) -> pd.DataFrame:
    """One row per trial record (:func:`analysis.paper_fig3.load`, or :func:`readings` of a loaded table:
    variant, fidelity, the task without its ``paper_`` prefix) with a planner config: task, variant,
    fidelity, samples, horizon, interval (s), latency (s), seed, status, completed, finished cleanly (NaN
    where an older record lacks it), ttf, errors, compute seconds, milestones reached (name -> bool)."""
    df = readings(df)
    df = df[df["num_samples"].notna()].reset_index(drop=True) if len(df) else df
    if df.empty:
        raise ValueError("no trial records with a planner config")
    ok = df["status"] == "ok"

    def column(name: str) -> pd.Series:
        values = df[name] if name in df else pd.Series(np.nan, index=df.index)
        return pd.to_numeric(values, errors="coerce").where(ok)

    # a record that did not finish (diverged, error) has no replan_interval / latency: its config's
    planner = [_planner(path) for path in df["record_path"]]
    fixed = pd.Series([p.get("latency") or 0.0 for p in planner], index=df.index, dtype=float)
    recorded = pd.to_numeric(df.get("latency", pd.Series(np.nan, index=df.index)), errors="coerce")
    latency = recorded.fillna(fixed)
    interval = pd.to_numeric(df.get("replan_interval"), errors="coerce")
    interval = interval.fillna(np.maximum(df["replan_period"].astype(float), latency))
    clean = df["finished_cleanly"] if "finished_cleanly" in df else pd.Series(None, index=df.index)
    milestones = [c for c in df.columns if c.startswith("milestone_")]
    cpu = column("cpu_seconds") if "cpu_seconds" in df else pd.Series(np.nan, index=df.index)
    return pd.DataFrame(
        {
            "task": df["task"],
            "variant": df["variant"],
            "fidelity": df["fidelity"],
            "samples": df["num_samples"].astype(int),
            "horizon": df["horizon"].astype(float),
            "interval": interval.astype(float).round(4),
            "latency": latency.astype(float).round(4),
            "seed": df["seed"],
            "status": df["status"],
            "completed": df["completed"].fillna(False).astype(bool) & ok,
            "finished_cleanly": [  # NaN: an ok record from before the field existed
                False if not ok_ else bool(c) if isinstance(c, bool | np.bool_) else np.nan
                for c, ok_ in zip(clean, ok, strict=True)
            ],
            "ttf": column("ttf"),
            "failure_time": column("failure_time") if "failure_time" in df else np.nan,
            "error_span": column("object_position_error_span_mean"),
            "error_after": column("object_position_error_after_mean"),
            "error_mean": column("object_position_error_mean"),
            "error_final": column("final_object_position_error"),
            "compute": cpu.fillna(pd.to_numeric(df["wall_seconds"], errors="coerce")),
            "cpu": df["cpu"] if "cpu" in df else None,
            "record_path": df["record_path"],
            "git_revision": df["git_revision"] if "git_revision" in df else None,
            "milestones": [
                {c[10:]: bool(v) for c, v in row.items() if isinstance(v, bool | np.bool_)}
                for row in df[milestones].to_dict("records")
            ],
        }
    )


def _config(path: str) -> dict:
    """The ``config`` of the record at ``path`` (``{}`` where it has none)."""
    try:
        return json.loads(Path(path).read_text()).get("config") or {}
    except (OSError, ValueError):
        return {}


def _planner(path: str) -> dict:
    """The ``config.planner`` node of the record at ``path`` (``{}`` where it has none)."""
    return _config(path).get("planner") or {}


def steps_per_second(samples: int, horizon: float, interval: float, planner_dt: float = 0.01) -> float:
    """Rollout steps the point simulates per second of control: the compute it asks for."""
    return samples * max(1, round(horizon / planner_dt)) / interval


def at_point(df: pd.DataFrame, point: tuple) -> pd.Series:
    """Which rows of ``df`` (:func:`points`) are at ``point``, ``(samples, horizon, interval, latency)``
    (the interval and latency to the millisecond)."""
    s, h, i, lat = point
    return (
        (df["samples"] == s)
        & (df["horizon"] == h)
        & (df["interval"].round(3) == round(i, 3))
        & (df["latency"].round(3) == round(lat, 3))
    )


#: The map's keys: a point of one task, variant and reading.
POINT_KEYS = ["task", "variant", "fidelity", "samples", "horizon", "interval", "latency"]
#: Per point (:func:`summary`): column -> how it is reduced over the point's trials.
POINT_STATS: dict[str, Stat] = {
    "trials": Stat("seed", "n"),
    "errors": Stat("_error", "sum"),
    "completed": Stat("completed", "sum"),
    "finished_cleanly": Stat("finished_cleanly", "sum"),  # NaN (unrecorded) counts 0
    "cleanly_known": Stat("_cleanly_known", "sum"),
    "ttf_median": Stat("ttf", "median"),
    "error_span_mm": Stat("error_span", "median", scale=1e3),
    "error_after_mm": Stat("error_after", "median", scale=1e3),
    "error_mean_mm": Stat("error_mean", "median", scale=1e3),
    "error_final_mm": Stat("error_final", "median", scale=1e3),
    "compute_s": Stat("compute", "median"),
}


def summary(df: pd.DataFrame) -> pd.DataFrame:
    """Per task, variant, fidelity and point (:data:`POINT_STATS` on :func:`analysis.summarize.summarize`):
    trials, completed, finished cleanly, milestones, TTF, errors (medians over the trials: in the span,
    after it, whole trial, final), compute (median); sorted by task, variant, fidelity and cost."""
    df = df.assign(_error=df["status"] != "ok", _cleanly_known=df["finished_cleanly"].notna())
    out = summarize(df, by=POINT_KEYS, stats=POINT_STATS)
    for c in ("errors", "completed", "finished_cleanly", "cleanly_known"):
        out[c] = out[c].fillna(0).astype(int)
    keys = df[POINT_KEYS].astype(object)
    out["milestones"] = [
        _reached(df[(keys == pd.Series(dict(zip(POINT_KEYS, row, strict=True)))).all(axis=1)]["milestones"])
        for row in out[POINT_KEYS].itertuples(index=False)
    ]
    out["cost"] = [steps_per_second(int(s), float(h), float(i)) for s, h, i in
                   zip(out["samples"], out["horizon"], out["interval"], strict=True)]  # fmt: skip
    task_rank = {t: i for i, t in enumerate(ordered(out["task"], TASK_ORDER))}
    fid_rank = {f: i for i, f in enumerate(ordered(out["fidelity"], FIDELITY_ORDER))}
    out["_t"], out["_f"] = out["task"].map(task_rank), out["fidelity"].map(fid_rank)
    order = ["_t", "variant", "_f", "cost"]
    return out.sort_values(order).drop(columns=["_t", "_f"]).reset_index(drop=True)


def _reached(milestones: pd.Series) -> str:
    """``lifted 3, handed_off 2``: how many trials reached each milestone."""
    reached: dict[str, int] = {}
    for m in milestones:
        for name, hit in m.items():
            reached[name] = reached.get(name, 0) + int(hit)
    return ", ".join(f"{k} {v}" for k, v in reached.items())


def cheapest(table: pd.DataFrame, need: float = 5 / 6) -> pd.DataFrame:
    """Per task, variant and fidelity, the cheapest point completing at least ``need`` of its trials, next
    to the paper point's completion (``None`` where no point does)."""
    rows = []
    for (task, variant, fid), g in table.groupby(["task", "variant", "fidelity"], sort=False):
        works = g[g["completed"] >= np.ceil(need * g["trials"] - 1e-9)]
        paper = g[(g["samples"] == PAPER_POINT[0]) & (g["horizon"] == PAPER_POINT[1])]
        best = works.sort_values("cost").head(1)
        rows.append(
            {
                "task": task,
                "variant": variant,
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
        "| task | variant | fidelity | samples x horizon | interval | latency | completed | finished cleanly "
        "| milestones | median TTF | median object error in span / after span / whole trial / final (mm) "
        "| median compute per trial (s) | rollout steps per s |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in table.itertuples():
        lines.append(
            f"| {r.task} | {r.variant} | {r.fidelity} | {r.samples} x {r.horizon:g} s "
            f"| {1e3 * r.interval:.0f} ms | {1e3 * r.latency:.0f} ms | {r.completed}/{r.trials}"
            + (f" ({r.errors} diverged or failed)" if r.errors else "")
            + f" | {_cleanly(r)} | {r.milestones} | {_num(r.ttf_median, '{:.2f}')} | "
            + " / ".join(
                _num(e, "{:.0f}")
                for e in (r.error_span_mm, r.error_after_mm, r.error_mean_mm, r.error_final_mm)
            )
            + f" | {_num(r.compute_s, '{:.0f}')} | {r.cost:,.0f} |"
        )
    head = "| task | variant | fidelity | paper point(s) | cheapest point that completes | completed |"
    lines += ["", head]
    lines.append("|---|---|---|---|---|---|")
    for r in best.itertuples():
        point = r.cheapest if isinstance(r.cheapest, str) else "none of these"  # None, or NaN in a frame
        done = r.completed if isinstance(r.completed, str) else "-"
        lines.append(f"| {r.task} | {r.variant} | {r.fidelity} | {r.paper_point or '-'} | {point} | {done} |")
    return "\n".join(lines) + "\n"


def _cleanly(row) -> str:
    """``k/n`` finished cleanly; ``k/m (n - m unrecorded)`` where older records lack the field."""
    if row.cleanly_known == 0:
        return "-"
    missing = row.trials - row.cleanly_known
    return f"{row.finished_cleanly}/{row.cleanly_known}" + (f" ({missing} unrecorded)" if missing else "")


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
    for column in ("task", "variant", "fidelity"):
        parser.add_argument(f"--{column}", help=f"keep only these {column}s (comma-separated)")
    args = parser.parse_args(argv)
    try:
        num, _, den = args.need.partition("/")
        need = float(num) / float(den or 1)
        df = select(load(*args.sweep_dirs), task=args.task, variant=args.variant, fidelity=args.fidelity)
        path = write_operating_point(df, args.out_dir or Path(args.sweep_dirs[0]) / "analysis", need)
    except (ValueError, OSError) as err:
        return fail(err)
    print(path.read_text(), end="")
    print(f"wrote {path} and operating_point.csv")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
