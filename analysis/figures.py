"""Figures of a sweep: the paper's Fig. 3, time to failure per task and variant.

Figures are drawn on :class:`matplotlib.figure.Figure` objects with the Agg canvas, never through
``pyplot``: nothing here changes the backend of the caller (a notebook keeps its own), and the command
line runs headless.

Command line::

    python -m analysis.figures SWEEP_DIR [SWEEP_DIR ...] --out fig3.png
"""

from __future__ import annotations

import argparse
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from matplotlib.transforms import blended_transform_factory

from analysis._cli import sweep_parser
from analysis.aggregate import (
    COUNTED_STATUSES,
    TASK_ORDER,
    VARIANT_ORDER,
    conditions,
    groups,
    ok_trials,
    ordered,
    run_records,
)

#: Colours of the paper's variants (Fig. 3); other variants get shades of grey.
VARIANT_COLORS: dict[str, str] = {"full": "#2ca02c", "no_contact": "#1f77b4", "joint_space": "#d62728"}
#: Hatches that tell the conditions of one variant apart (see :func:`analysis.aggregate.add_conditions`).
CONDITION_HATCHES: tuple[str, ...] = ("", "//", "..", "xx", "\\\\", "++", "oo", "--")
#: Legend labels of the paper's variants.
VARIANT_LABELS: dict[str, str] = {
    "full": "full (contact cost + PC splines)",
    "no_contact": "no contact cost",
    "joint_space": "joint-space splines",
}


def variant_colors(variants: list[str]) -> dict[str, str]:
    """A colour per variant: the paper's for ``full``/``no_contact``/``joint_space``, greys otherwise."""
    others = [v for v in variants if v not in VARIANT_COLORS]
    greys = np.linspace(0.3, 0.75, len(others)) if len(others) > 1 else [0.5] * len(others)
    colors = {v: VARIANT_COLORS[v] for v in variants if v in VARIANT_COLORS}
    colors.update({v: str(round(float(g), 3)) for v, g in zip(others, greys, strict=True)})
    return colors


def _in(df: pd.DataFrame, task: str, variant: str, condition: str) -> pd.Series:
    return (df["task"] == task) & (df["variant"] == variant) & (df["condition"].fillna("") == condition)


def series_label(variant: str, condition: str) -> str:
    """The legend label of a variant under a condition."""
    label = VARIANT_LABELS.get(variant, variant)
    return f"{label} [{condition}]" if condition else label


def excluded_note(df: pd.DataFrame) -> str:
    """One line naming the trials that do not count for TTF (status not in
    :data:`~analysis.aggregate.COUNTED_STATUSES`, or without a TTF), counted per task/variant (and
    condition)."""
    counted = df["status"].isin(COUNTED_STATUSES)
    bad = df[~counted]
    missing = df[counted & df["ttf"].isna()]
    if not len(bad) and not len(missing):
        diverged = int((df["status"] == "diverged").sum())
        return f"All {len(df)} trials count" + (f" ({diverged} diverged)." if diverged else ".")
    parts = []
    for task, variant, condition in groups(df):
        counts = bad.loc[_in(bad, task, variant, condition), "status"].fillna("no status").value_counts()
        if len(counts):
            what = ", ".join(f"{n} {status}" for status, n in sorted(counts.items()))
            parts.append(f"{task}/{variant}{f' [{condition}]' if condition else ''}: {what}")
    if len(missing):
        parts.append(f"{len(missing)} without TTF")
    return f"Not counted for TTF ({len(bad) + len(missing)} of {len(df)} trials): " + "; ".join(parts)


def ttf_boxplot(df: pd.DataFrame, path: str | Path | None = None, *, title: str | None = None) -> Figure:
    """The paper's Fig. 3: time to failure as a percentage of the contact span, per task and variant.

    One grouped axis: tasks left to right in the paper's order (doorknob, apple, bottle, stapler, then
    any other), one box per variant within a task (full green, no_contact blue, joint_space red, other
    variants grey) and per condition of a variant run under several (one hatch each, named in the
    legend), every trial as a jittered point on its box, ``n`` above each box. Only trials with status
    ``ok`` count; the others are counted in a note under the axis.

    Args:
        df: the table of :func:`analysis.aggregate.load_records`.
        path: where to save the figure (format from the extension); ``None`` does not save.
        title: figure title; ``None`` for a default.

    Returns:
        The figure (displayable in a notebook).
    """
    tasks = ordered(df["task"], TASK_ORDER)
    variants = ordered(df["variant"], VARIANT_ORDER)
    colors = variant_colors(variants)
    # One slot per (variant, condition) found in any task; a condition's hatch is its rank in its variant.
    series = sorted({(v, c) for _, v, c in groups(df)}, key=lambda s: (variants.index(s[0]), s[1]))
    hatches = {}
    for variant, condition in series:
        rank = sum(v == variant for v, _ in hatches)
        hatches[(variant, condition)] = CONDITION_HATCHES[rank % len(CONDITION_HATCHES)]
    good = ok_trials(df)
    nv = max(len(series), 1)
    slot = 0.8 / nv
    rng = np.random.default_rng(0)  # deterministic jitter

    fig = Figure(figsize=(max(4.0, 1.0 + len(tasks) * (0.35 * nv + 0.4)) + 2.4, 4.6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    top = blended_transform_factory(ax.transData, ax.transAxes)
    for i, task in enumerate(tasks):
        for j, (variant, condition) in enumerate(series):
            x = i + (j - (nv - 1) / 2) * slot
            if condition not in conditions(df, task, variant):
                continue  # no trial of this variant and condition on this task: leave the slot empty
            ttf = 100.0 * good.loc[_in(good, task, variant, condition), "ttf"].to_numpy(float)
            ax.text(x, 1.01, f"n={len(ttf)}", transform=top, ha="center", va="bottom", fontsize=7)
            if not len(ttf):
                continue
            box = ax.boxplot(
                [ttf],
                positions=[x],
                widths=0.75 * slot,
                patch_artist=True,
                showfliers=False,
                manage_ticks=False,
                medianprops={"color": "black", "linewidth": 1.5},
            )
            for patch in box["boxes"]:
                patch.set(
                    facecolor=colors[variant],
                    alpha=0.45,
                    edgecolor=colors[variant],
                    hatch=hatches[(variant, condition)],
                )
            for line in box["whiskers"] + box["caps"]:
                line.set_color(colors[variant])
            jitter = rng.uniform(-0.28 * slot, 0.28 * slot, len(ttf))
            ax.scatter(
                x + jitter,
                ttf,
                s=12,
                color=colors[variant],
                edgecolor="black",
                linewidth=0.3,
                alpha=0.8,
                zorder=3,
            )
    ax.set_xticks(range(len(tasks)), tasks)
    ax.set_xlim(-0.6, max(len(tasks), 1) - 0.4)
    ax.set_ylim(-3, 103)
    ax.set_yticks(range(0, 101, 20))
    ax.set_ylabel("time to failure (% of contact span)")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(
        handles=[
            Patch(
                facecolor=colors[v],
                edgecolor=colors[v],
                alpha=0.6,
                hatch=hatches[(v, c)],
                label=textwrap.fill(series_label(v, c), 60),
            )
            for v, c in series
        ],
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        frameon=False,
        fontsize=8,
    )
    ax.set_title(title or "Time to failure per task (paper Fig. 3)", pad=16)
    fig.supxlabel(textwrap.fill(excluded_note(df), 130), fontsize=7, x=0.01, ha="left")
    if path is not None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=150)
    return fig


def build_parser() -> argparse.ArgumentParser:
    """Parser of ``python -m analysis.figures``."""
    parser = sweep_parser(
        "python -m analysis.figures",
        "Draw the time-to-failure box plot (paper Fig. 3) of the trials under sweep directories.",
    )
    parser.add_argument(
        "--out", default="fig3.png", help="output image (.png, .pdf, .svg); default %(default)s"
    )
    parser.add_argument("--title", default=None, help="figure title")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m analysis.figures``; returns the exit status."""
    args = build_parser().parse_args(argv)

    def action(df: pd.DataFrame) -> str:
        ttf_boxplot(df, args.out, title=args.title)
        return f"wrote {args.out} ({len(ok_trials(df))} of {len(df)} trials counted)"

    return run_records(args.sweep_dirs, action, (OSError, ValueError))


if __name__ == "__main__":
    raise SystemExit(main())
