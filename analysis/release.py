"""The end of a task, per task, variant and fidelity: is the object left where the reference leaves it?

Reads trial records (:func:`analysis.paper_fig3.load`: the fidelity from each config, the task without its
``paper_`` prefix) and counts, per task x variant x fidelity: trials, completed, *settled* (the final
milestone: at rest where the reference leaves it, let go where the reference lets go) and *finished
cleanly* (both); and gives the median object error after the contact span (release and retreat) and at
the end of the trial, next to the median over the span (tracking). The error is the free body's position
(mm) where the task has one, else the norm of its articulations (mrad, or mm for a slide: the doorknobs).

Command line::

    python -m analysis.release SWEEP_DIR [SWEEP_DIR ...] [--task apple,bottle] [--variant full,release_reset]
        [--fidelity paper] [--out FILE.md]

``--task``, ``--variant`` and ``--fidelity`` keep only those rows (comma-separated; the task without its
``paper_`` prefix; a variant by its method name, :func:`contactmpc.labels.method_name`: ``release_reset``
for ``release=reset``), so a variant's sweep can be read beside another sweep's records of the variant it
is compared with (e.g. ``studies/fig3_paper/records``'s ``full``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from analysis._cli import fail, sweep_parser
from analysis.aggregate import TASK_ORDER, VARIANT_ORDER, ok_trials, ordered, select
from analysis.paper_fig3 import FIDELITY_ORDER
from analysis.paper_fig3 import load as fig3_load
from analysis.summarize import Stat, pipe_table, summarize

#: Which error a task's table shows: the free body's position, or (no free body) its articulations.
ERRORS = {"position": "object_position_error", "articulation": "object_articulation_error"}

#: Variants left to right: the paper's, then the release designs in the order they were built (4-7).
RELEASE_ORDER: tuple[str, ...] = (
    *VARIANT_ORDER,
    "release_reset",
    "release",
    "release_scheduled",
    "release_backoff",
)


def error_kind(df: pd.DataFrame) -> str:
    """``position`` where the trials' position errors are not all zero, else ``articulation``."""
    pos = pd.to_numeric(df.get("object_position_error_mean"), errors="coerce").abs()
    return "position" if (pos > 1e-9).any() else "articulation"


#: Per task x variant x fidelity (:func:`release_table`): column -> how it is reduced over the trials
#: (``_span``, ``_after``, ``_final``: the task's error, :func:`error_kind`).
RELEASE_STATS: dict[str, Stat] = {
    "n": Stat("seed", "n"),
    "completed": Stat("completed", "sum"),  # NaN-valued fields count as not reached
    "settled": Stat("settled", "sum"),
    "finished_cleanly": Stat("finished_cleanly", "sum"),
    "error_span": Stat("_span", "median"),
    "error_after": Stat("_after", "median"),
    "error_final": Stat("_final", "median"),
}


def release_table(df: pd.DataFrame) -> pd.DataFrame:
    """One row per task x variant x fidelity (:data:`RELEASE_STATS` on
    :func:`analysis.summarize.summarize`): ``n`` (ok trials), ``completed``, ``settled``,
    ``finished_cleanly`` (counts; NaN-valued fields count as not reached), ``error`` (its kind), and the
    medians ``error_span``, ``error_after``, ``error_final`` (m or rad)."""
    good = with_errors(ok_trials(df))
    order = {"task": TASK_ORDER, "variant": RELEASE_ORDER, "fidelity": FIDELITY_ORDER}
    out = summarize(good, by=["task", "variant", "fidelity"], stats=RELEASE_STATS, order=order)
    for c in ("completed", "settled", "finished_cleanly"):
        out[c] = out[c].fillna(0).astype(int)
    out.insert(7, "error", out["task"].map(good.attrs["error_kinds"]))
    return out


def with_errors(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with each trial's object error in its task's kind (:func:`error_kind`, judged over the task's
    rows of ``df``): ``_span`` and ``_after`` (means over and after the contact span) and ``_final`` (m, or
    rad / m for an articulation; NaN where the record lacks it); ``attrs["error_kinds"]``: task -> kind."""
    kinds = {task: error_kind(df[df["task"] == task]) for task in df["task"].unique()}

    def values(suffix: str) -> list[float]:
        out = np.full(len(df), math.nan)
        tasks = df["task"].to_numpy()
        for t, k in kinds.items():
            col = f"{ERRORS[k]}_{suffix}" if suffix != "final" else f"final_{ERRORS[k]}"
            if col in df and (rows := np.flatnonzero(tasks == t)).size:
                out[rows] = pd.to_numeric(df[col].iloc[rows], errors="coerce").to_numpy(dtype=float)
        return out.tolist()

    out = df.assign(_span=values("span_mean"), _after=values("after_mean"), _final=values("final"))
    out.attrs["error_kinds"] = kinds
    return out


#: The columns of :func:`markdown`.
COLUMNS = (
    "task", "variant", "fidelity", "n", "completed", "settled", "finished cleanly",
    "median object error: span / after span / final",
)  # fmt: skip


def markdown(table: pd.DataFrame) -> str:
    """The table as markdown (errors in mm, or mrad for an articulation)."""
    return pipe_table(COLUMNS, "l" * len(COLUMNS), map(_row, table.itertuples(index=False)))


def _row(r) -> str:
    unit = "mm" if r.error == "position" else "x 1e-3 (rad, or m for a slide)"
    errs = " / ".join(_milli(e) for e in (r.error_span, r.error_after, r.error_final))
    return (
        f"| {r.task} | {r.variant} | {r.fidelity} | {r.n} | {r.completed}/{r.n} | {r.settled}/{r.n} "
        f"| {r.finished_cleanly}/{r.n} | {errs} {unit} |"
    )


def paired_markdown(
    df: pd.DataFrame, error: str = "after", order: tuple[str, ...] = RELEASE_ORDER, unpaired: bool = False
) -> str:
    """Per task and seed, each variant's trial side by side: the object error after the span (mean, mm, or
    mrad for an articulation) and how it ended (``clean``: finished cleanly; ``done``: completed, not
    settled; ``failed``: not completed). Where the variants differ only in their release (``full``,
    ``release_reset`` and after), trials of one seed are the same until the planner first looks past the
    last contact, so a row is a before/after. Seeds that only one variant has are left out.

    Args:
        error: ``"after"`` (the mean after the span) or ``"final"`` (at the end of the trial).
        order: the variants' columns, left to right (others follow, sorted).
        unpaired: keep the seeds that only one variant has too (the others' cells blank).
    """
    if error not in ("after", "final"):
        raise ValueError(f"error must be 'after' or 'final', not {error!r}")
    good = ok_trials(df)
    variants = ordered(good["variant"], order)
    lines = ["| task | seed | " + " | ".join(variants) + " |", "|---|---|" + "---|" * len(variants)]
    for task in ordered(good["task"], TASK_ORDER):
        at = good[good["task"] == task]
        col = ERRORS[error_kind(at)]
        for seed, g in at.groupby("seed"):
            if g["variant"].nunique() < 2 and not unpaired:
                continue
            cells = []
            for variant in variants:
                r = g[g["variant"] == variant]
                if r.empty:
                    cells.append("")
                    continue
                r = r.iloc[0]
                clean = r.get("finished_cleanly")
                end = "clean" if _true(clean) else "done" if _true(r.get("completed")) else "failed"
                key = f"{col}_after_mean" if error == "after" else f"final_{col}"
                value = pd.to_numeric(pd.Series([r.get(key, math.nan)]), errors="coerce").iloc[0]
                cells.append(f"{_milli(float(value))} {end}")
            lines.append(f"| {task} | {seed} | " + " | ".join(cells) + " |")
    if len(lines) == 2:
        return ""
    return "\n".join(lines) + "\n"


def _true(value) -> bool:
    """A record's boolean field (``True``/``numpy.True_``); missing or NaN is not true."""
    return isinstance(value, bool | np.bool_) and bool(value)


def release_figure(df: pd.DataFrame, path: str | Path | None = None) -> Figure:
    """Per task (a panel) and variant (a column of dots), each trial's object error after the contact
    span (mean, log scale, 3 mm to 3 m on every panel): filled where the trial finished cleanly, hollow
    where it completed but was not settled, a cross where it did not complete.

    Args:
        df: trial records (:func:`analysis.paper_fig3.load`).
        path: where to save the PNG (``None``: not saved).
    """
    good = ok_trials(df)
    tasks = ordered(good["task"], TASK_ORDER)
    fig = Figure(figsize=(4.2 * max(1, len(tasks)), 3.8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, max(1, len(tasks)), squeeze=False)[0]
    for ax, task in zip(axes, tasks, strict=False):
        at = good[good["task"] == task]
        col = ERRORS[error_kind(at)]
        variants = ordered(at["variant"], RELEASE_ORDER)
        for i, variant in enumerate(variants):
            g = at[at["variant"] == variant]
            err = 1e3 * pd.to_numeric(g[f"{col}_after_mean"], errors="coerce").to_numpy(float)
            clean = g["finished_cleanly"].fillna(False).astype(bool).to_numpy()
            done = g["completed"].fillna(False).astype(bool).to_numpy()
            x = i + np.linspace(-0.15, 0.15, len(g)) if len(g) > 1 else np.full(len(g), float(i))
            ax.scatter(x[clean], err[clean], color="tab:green", zorder=3)
            ax.scatter(
                x[done & ~clean], err[done & ~clean], facecolors="none", edgecolors="tab:red", zorder=3
            )
            ax.scatter(x[~done], err[~done], marker="x", color="tab:gray", zorder=3)
        ax.set_xticks(range(len(variants)), variants, rotation=30, ha="right")
        ax.set_yscale("log")
        ax.set_ylim(3, 3000)  # the same on every panel: millimetres to metres
        ax.set_yticks([3, 10, 30, 100, 300, 1000, 3000], ["3", "10", "30", "100", "300", "1000", "3000"])
        ax.minorticks_off()
        ax.set_title(task)
        ax.set_ylabel("error after the span (mm, mean)" if col == ERRORS["position"] else "x 1e-3")
        ax.grid(True, axis="y", alpha=0.3)
    handles = [
        Line2D([], [], ls="", marker="o", color="tab:green", label="finished cleanly"),
        Line2D([], [], ls="", marker="o", mfc="none", mec="tab:red", label="completed, not settled"),
        Line2D([], [], ls="", marker="x", color="tab:gray", label="not completed"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=3, frameon=False)
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def _milli(value: float) -> str:
    return "—" if not np.isfinite(value) else f"{1e3 * value:.0f}"


def main(argv: list[str] | None = None) -> int:
    parser = sweep_parser("python -m analysis.release", __doc__.split("\n\n")[0])
    parser.add_argument("--out", help="also write the table to this markdown file")
    for column in ("task", "variant", "fidelity"):
        parser.add_argument(f"--{column}", help=f"keep only these {column}s (comma-separated)")
    args = parser.parse_args(argv)
    try:
        for d in args.sweep_dirs:
            if not Path(d).is_dir():
                raise FileNotFoundError(f"no such sweep directory: {d}")
        df = select(fig3_load(*args.sweep_dirs), task=args.task, variant=args.variant, fidelity=args.fidelity)
        text = markdown(release_table(df))
        if args.out:
            Path(args.out).write_text(text)
    except (ValueError, OSError) as err:
        return fail(err)
    print(text, end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
