"""Success under mismatch: completion and TTF against the size of a plant-model error, per task and method.

Reads the records of a sweep such as ``experiment=robustness``: each record's method (its ``variant``
label and groups, named by :func:`contactmpc.labels.method_name`: ``replay``, ``full``, ``joint_space``,
``wrist``, ``robust``) and its drawn ``perturbation``. The error on the x axis (``--axis``) is the object's
initial offset (``offset``: the offset's length, rounded to the millimetre; ``experiment=robustness``) or
its mass error (``mass``: the drawn mass factor minus one, rounded to a tenth of a per cent;
``experiment=robustness_mass``). Per task, method and
error it reports the success rate (share of trials completed) and the mean TTF, each with a bootstrap
90 % confidence interval over the trials, how many trials reached each milestone, and per task and
method the largest error at which at least 80 % of the trials succeed.

Outputs (:func:`write_robustness`): ``robustness.png`` (one column per task: success rate and mean TTF
against the error, a line and a 90 % band per method), ``robustness.csv`` and ``robustness.md``.

Command line::

    python -m analysis.robustness SWEEP_DIR [SWEEP_DIR ...] --out-dir DIR [--axis offset|mass]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from analysis.aggregate import TASK_ORDER, ordered
from analysis.summarize import Stat, summarize

#: Methods in the order of tables and legends; others follow, sorted.
METHOD_ORDER: tuple[str, ...] = ("replay", "full", "joint_space", "wrist", "robust")
METHOD_COLORS = {
    "replay": "0.45",
    "full": "#2ca02c",
    "joint_space": "#d62728",
    "wrist": "#9467bd",
    "robust": "#ff7f0e",
}
SURVIVAL = 0.8  # the share of trials that must succeed at an error for a method to "survive" it
#: The errors a sweep may vary: axis -> (x-axis label, factor to the printed unit, its format).
AXES = {
    "offset": ("initial object offset (cm)", 100, "{:.0f} cm"),
    "mass": ("object mass error (%)", 100, "{:+.0f} %"),
}


def load(*dirs: str | Path) -> pd.DataFrame:
    """One row per record: task, method, offset (m), mass (mass factor - 1), seed, status, completed, ttf,
    milestones (name -> reached)."""
    rows = []
    for d in dirs:
        for path in sorted(Path(d).rglob("trial.json")):
            try:
                r = json.loads(path.read_text())
            except (OSError, ValueError):
                continue
            drawn = r.get("perturbation") or {}
            offset = float(np.linalg.norm(drawn.get("object_offset", [0.0, 0.0, 0.0])))
            rows.append(
                {
                    "task": r.get("task"),
                    "method": r.get("variant") or r.get("planner"),
                    "offset": round(offset, 3),
                    "mass": round(float(drawn.get("mass_scale", 1.0)) - 1.0, 3),
                    "seed": r.get("seed"),
                    "status": r.get("status"),
                    "completed": bool(r.get("completed")) if r.get("status") == "ok" else False,
                    "ttf": r.get("ttf"),
                    "milestones": {
                        k[len("milestone_") :]: bool(v) for k, v in r.items() if k.startswith("milestone_")
                    },
                }
            )
    if not rows:
        raise ValueError(f"no trial.json records under {', '.join(map(str, dirs))}")
    return pd.DataFrame(rows)


def bootstrap(values: np.ndarray, rng: np.random.Generator, draws: int = 2000) -> tuple[float, float]:
    """90 % bootstrap interval of the mean of ``values`` (successes 0/1, or TTFs), resampling trials."""
    if len(values) == 0:
        return (np.nan, np.nan)
    means = rng.choice(values, size=(draws, len(values)), replace=True).mean(axis=1)
    return float(np.percentile(means, 5)), float(np.percentile(means, 95))


#: Per task, method and error level (:func:`summary`): column -> how it is reduced over the trials; the
#: 90 % bootstrap intervals of the success rate and the mean TTF are added by :func:`summary`.
ROBUSTNESS_STATS: dict[str, Stat] = {
    "trials": Stat("seed", "n"),
    "errors": Stat("_error", "sum"),
    "success": Stat("completed", "mean"),
    "ttf_median": Stat("ttf", "median"),
    "ttf_mean": Stat("ttf", "mean"),
}


def summary(df: pd.DataFrame, seed: int = 0, axis: str = "offset") -> pd.DataFrame:
    """Per task, method and error (column ``axis`` of :data:`AXES`; :data:`ROBUSTNESS_STATS` on
    :func:`analysis.summarize.summarize`): trials, success rate and mean TTF with their 90 % bootstrap
    intervals, median TTF, and how many trials reached each milestone."""
    rng = np.random.default_rng(seed)
    by = ["task", "method", axis]
    order = {"task": TASK_ORDER, "method": METHOD_ORDER, axis: sorted(df[axis].unique())}
    out = summarize(df.assign(_error=df["status"] != "ok"), by=by, stats=ROBUSTNESS_STATS, order=order)
    out["errors"] = out["errors"].astype(int)
    bands: dict[str, list] = {
        "success_lo": [],
        "success_hi": [],
        "ttf_lo": [],
        "ttf_hi": [],
        "milestones": [],
    }
    for task, method, level in out[by].itertuples(index=False):  # rng drawn in the table's order
        g = df[(df["task"] == task) & (df["method"] == method) & (df[axis] == level)]
        lo, hi = bootstrap(g["completed"].to_numpy(float), rng)
        ttf_lo, ttf_hi = bootstrap(pd.to_numeric(g["ttf"], errors="coerce").dropna().to_numpy(float), rng)
        reached: dict[str, int] = {}
        for milestones in g["milestones"]:
            for name, hit in milestones.items():
                reached[name] = reached.get(name, 0) + int(hit)
        reached_text = " · ".join(f"{n} {k}/{len(g)}" for n, k in reached.items())
        for k, v in zip(bands, (lo, hi, ttf_lo, ttf_hi, reached_text), strict=True):
            bands[k].append(v)
    for k, v in bands.items():
        out[k] = v
    cols = [*by, "trials", "errors", "success", "success_lo", "success_hi", "ttf_median", "ttf_mean"]
    cols += ["ttf_lo", "ttf_hi", "milestones"]
    return out[cols]


def survives(table: pd.DataFrame, axis: str = "offset") -> pd.DataFrame:
    """Per task and method, the largest error with a success rate of at least :data:`SURVIVAL` (NaN if
    none)."""
    good = table[table["success"] >= SURVIVAL]
    out = good.groupby(["task", "method"], sort=False)[axis].max()
    return out.reindex(pd.MultiIndex.from_frame(table[["task", "method"]].drop_duplicates())).reset_index()


def figure(table: pd.DataFrame, path: str | Path | None = None, axis: str = "offset") -> Figure:
    """One column per task: the success rate (top) and the mean TTF (bottom) against the error, a line
    and a 90 % bootstrap band per method; methods are drawn a hair apart (1 % of the axes) so that
    coinciding lines stay visible."""
    label, factor, _ = AXES[axis]
    tasks = ordered(table["task"], TASK_ORDER)
    fig = Figure(figsize=(4.0 * len(tasks), 6.2), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(2, len(tasks), sharey="row", sharex="col", squeeze=False)
    rows = (("success", "success rate (completed)"), ("ttf", "time to failure (mean)"))
    for col, task in enumerate(tasks):
        t = table[table["task"] == task]
        methods = ordered(t["method"], METHOD_ORDER)
        levels = factor * t[axis].to_numpy()
        # methods drawn side by side (x) and a hair apart (y) where their lines coincide
        dodge = 0.012 * (levels.max() - levels.min() or 1.0)
        for row, (key, ylabel) in enumerate(rows):
            ax = axes[row, col]
            for i, method in enumerate(methods):
                m = t[t["method"] == method].sort_values(axis)
                shift = i - (len(methods) - 1) / 2
                x = factor * m[axis].to_numpy() + dodge * shift
                color = METHOD_COLORS.get(method, "0.6")
                y = (m["success"] if key == "success" else m["ttf_mean"]) + 0.012 * shift
                ax.plot(x, y, marker="o", color=color, label=method)
                ax.fill_between(x, m[f"{key}_lo"], m[f"{key}_hi"], color=color, alpha=0.15, linewidth=0)
            ax.set_ylim(-0.05, 1.05)
            ax.grid(alpha=0.3)
            if col == 0:
                ax.set_ylabel(ylabel)
        axes[0, col].set_title(task)
        axes[1, col].set_xlabel(label)
    axes[0, -1].legend(fontsize=8)
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def markdown(table: pd.DataFrame, axis: str = "offset") -> str:
    """The table (success and mean TTF with their intervals) and the largest error each method survives."""
    _, factor, fmt = AXES[axis]
    lines = [
        f"| task | method | {axis} | success (90 % CI) | mean TTF (90 % CI) | milestones reached |",
        "|---|---|---|---|---|---|",
    ]
    for r in table.to_dict("records"):
        lines.append(
            f"| {r['task']} | {r['method']} | {fmt.format(factor * r[axis])} | {r['success']:.2f} "
            f"({r['success_lo']:.2f}–{r['success_hi']:.2f}) | {r['ttf_mean']:.2f} ({r['ttf_lo']:.2f}–"
            f"{r['ttf_hi']:.2f}) | {r['milestones'] or '–'} |"
        )
    lines += ["", f"Largest {axis} error with at least {SURVIVAL:.0%} of the trials completed:", ""]
    lines += [f"| task | method | {axis} |", "|---|---|---|"]
    for r in survives(table, axis).to_dict("records"):
        where = "none" if np.isnan(r[axis]) else fmt.format(factor * r[axis])
        lines.append(f"| {r['task']} | {r['method']} | {where} |")
    return "\n".join(lines) + "\n"


def write_robustness(df: pd.DataFrame, out_dir: str | Path, axis: str = "offset") -> Path:
    """Write ``robustness.png``, ``robustness.csv`` and ``robustness.md`` into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    table = summary(df, axis=axis)
    figure(table, out / "robustness.png", axis)
    table.to_csv(out / "robustness.csv", index=False)
    (out / "robustness.md").write_text(markdown(table, axis))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m analysis.robustness", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("sweep_dirs", nargs="+", metavar="SWEEP_DIR")
    parser.add_argument("--out-dir", required=True)
    parser.add_argument("--axis", choices=sorted(AXES), default="offset", help="the error on the x axis")
    args = parser.parse_args(argv)
    try:
        out = write_robustness(load(*args.sweep_dirs), args.out_dir, args.axis)
    except (ValueError, OSError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(f"wrote {out / 'robustness.png'}, robustness.csv, robustness.md")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
