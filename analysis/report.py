"""Markdown report of a sweep: per task and variant statistics, and full vs each ablation.

Command line::

    python -m analysis.report SWEEP_DIR... --out results.md [--csv results.csv] [--figure fig3.png]
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import mannwhitneyu

from analysis._cli import sweep_parser
from analysis.aggregate import (
    TASK_ORDER,
    VARIANT_ORDER,
    conditions,
    ok_trials,
    ordered,
    run_records,
    write_table,
)
from analysis.inference import EXACT_PERMUTATIONS, permutation_u, smallest_u_p  # noqa: F401 (re-exported)
from analysis.summarize import Stat, summarize

REFERENCE_VARIANT = "full"
#: The position errors of :func:`summary_table`: the tracking error (over the contact span), after the
#: span, and over the whole trial.
ERROR_COLUMNS: tuple[str, ...] = (
    "object_position_error_span_mean",
    "object_position_error_after_mean",
    "object_position_error_mean",
)


def _mean(values: pd.Series) -> float:
    """Mean of the recorded values, NaN where none is (a field older records lack)."""
    values = pd.to_numeric(values, errors="coerce")
    return float(values.mean()) if values.notna().any() else math.nan


def _in(df: pd.DataFrame, task: str, variant: str, condition: str) -> pd.Series:
    """Rows of one task, variant and condition."""
    return (df["task"] == task) & (df["variant"] == variant) & (df["condition"].fillna("") == condition)


def summary_table(df: pd.DataFrame) -> pd.DataFrame:
    """Statistics per task, variant and condition.

    TTF, completion and tracking error are over the trials that count
    (:func:`analysis.aggregate.ok_trials`: status ``ok``, or ``diverged`` with a TTF) only. The
    tracking error is the object's position error over the contact span, where the reference asks the
    hand to do the task; after the span and over the whole trial are columns of their own. Records
    written before the span errors and ``finished_cleanly`` existed give NaN there.

    Args:
        df: the table of :func:`analysis.aggregate.load_records`.

    Returns:
        One row per (task, variant, condition) in paper order, columns ``task``, ``variant``,
        ``condition`` (the config values that set it apart, empty for a variant run under one
        condition), ``trials`` (all records), ``n`` (those that count), ``errors`` (the others),
        ``diverged`` (counted trials whose plant diverged),
        ``completion_rate`` (mean of ``completed`` where recorded, NaN if never),
        ``finished_cleanly_rate`` (the same of ``finished_cleanly``: completed, and the object left at
        rest where the reference leaves it), ``ttf_median``, ``ttf_q25``, ``ttf_q75`` (fractions of the
        contact span), and the object position error (m, mean over trials of the per-trial mean)
        ``object_position_error_span_mean`` over the contact span, ``object_position_error_after_mean``
        after it and ``object_position_error_mean`` over the whole trial.
    """
    ok = ok_trials
    stats = {
        "trials": Stat("task", "n"),
        "n": Stat("task", "n", where=ok),
        "errors": Stat("task", "n", where=lambda g: g.drop(ok_trials(g).index)),
        "diverged": Stat("task", "n", where=lambda g: ok(g)[ok(g)["status"] == "diverged"]),
        "completion_rate": Stat("completed", "rate", where=ok),
        "finished_cleanly_rate": Stat("finished_cleanly", "rate", where=ok),
        "ttf_median": Stat("ttf", "median", where=ok),
        "ttf_q25": Stat("ttf", "q25", where=ok),
        "ttf_q75": Stat("ttf", "q75", where=ok),
        **{col: Stat(col, "mean", where=ok) for col in ERROR_COLUMNS},
    }
    df = df.assign(condition=df["condition"].fillna("").astype(str))
    if "finished_cleanly" not in df:
        df = df.assign(finished_cleanly=pd.NA)
    table = summarize(
        df,
        by=["task", "variant", "condition"],
        stats=stats,
        order={"task": TASK_ORDER, "variant": VARIANT_ORDER},
    )
    table.attrs.clear()
    return table


def holm(p: Sequence[float]) -> np.ndarray:
    """Holm–Bonferroni adjusted p-values (NaN entries are left out of the family and stay NaN)."""
    p = np.asarray(p, float)
    out = np.full_like(p, np.nan)
    idx = np.flatnonzero(np.isfinite(p))
    m = len(idx)
    running = 0.0
    for rank, i in enumerate(idx[np.argsort(p[idx], kind="stable")]):
        running = max(running, min(1.0, (m - rank) * p[i]))
        out[i] = running
    return out


def significance_tests(
    df: pd.DataFrame,
    reference: str = REFERENCE_VARIANT,
    alpha: float = 0.05,
    family: str | None = None,
    same_condition: bool = False,
) -> pd.DataFrame:
    """Two-sided Mann–Whitney U tests of TTF: ``reference`` against every other variant, per task.

    Trials run under different conditions (see :func:`analysis.aggregate.add_conditions`) are not
    pooled: a condition of the reference is tested against the same condition of the other variant,
    and against the other variant's only condition where that variant was run under one (and the
    other way round). Only the trials that count (:func:`analysis.aggregate.ok_trials`) do. ``U`` is the
    statistic of the reference sample, so ``prob_superiority`` = U / (n_ref n_other) estimates
    P(TTF_ref > TTF_other) + ½ P(tie). ``p_holm`` is Holm-adjusted over all the tests of the table, or
    over each ``family``; the ``reading`` uses it at level ``alpha``.

    Args:
        df: the table of :func:`analysis.aggregate.load_records`.
        reference: the variant the others are compared with.
        alpha: significance level of the reading.
        family: a column of the result (e.g. ``"condition"``) whose values are separate families for
            Holm's correction (each experiment its own); ``None``: one family, every test.
        same_condition: test only a condition against the same condition (never a variant's only
            condition against another one of the reference, e.g. two readings of the method).

    Returns:
        One row per (task, other variant, pair of conditions) with columns ``task``, ``reference``,
        ``reference_condition``, ``variant``, ``condition``, ``n_ref``, ``n_other``, ``median_ref``,
        ``median_other``, ``U``, ``p``, ``p_holm``, ``prob_superiority``, ``hl_shift`` (the
        Hodges–Lehmann shift, :func:`hodges_lehmann`), ``method`` (:func:`mann_whitney`), ``reading``,
        ``p_min`` (the smallest p the test could give on these pooled values, :func:`smallest_p`).
        Empty when no task has the reference variant.
    """
    good = ok_trials(df)
    pairs = [
        (task, ref_condition, variant, condition)
        for task in ordered(df["task"], TASK_ORDER)
        for variant in ordered(df.loc[df["task"] == task, "variant"], VARIANT_ORDER)
        if variant != reference
        for ref_condition, condition in _paired(
            conditions(df, task, reference), conditions(df, task, variant)
        )
        if ref_condition == condition or not same_condition
    ]
    rows = []
    for task, ref_condition, variant, condition in pairs:
        a = good.loc[_in(good, task, reference, ref_condition), "ttf"].to_numpy(float)
        b = good.loc[_in(good, task, variant, condition), "ttf"].to_numpy(float)
        row = {
            "task": task,
            "reference": reference,
            "reference_condition": ref_condition,
            "variant": variant,
            "condition": condition,
            "n_ref": len(a),
            "n_other": len(b),
            "median_ref": float(np.median(a)) if len(a) else math.nan,
            "median_other": float(np.median(b)) if len(b) else math.nan,
            "U": math.nan,
            "p": math.nan,
            "prob_superiority": math.nan,
            "hl_shift": math.nan,
            "method": "",
            "p_min": math.nan,
        }
        if len(a) and len(b):
            u, p, method = mann_whitney(a, b)
            row.update(U=u, p=p, method=method, hl_shift=hodges_lehmann(a, b), p_min=smallest_p(a, b))
            row["prob_superiority"] = row["U"] / (len(a) * len(b))
        rows.append(row)
    columns = [
        "task",
        "reference",
        "reference_condition",
        "variant",
        "condition",
        "n_ref",
        "n_other",
        "median_ref",
        "median_other",
        "U",
        "p",
        "p_holm",
        "prob_superiority",
        "hl_shift",
        "method",
        "reading",
        "p_min",
    ]
    out = pd.DataFrame(rows, columns=columns)
    if family is None:
        out["p_holm"] = holm(out["p"]) if len(out) else []
    else:
        out["p_holm"] = out.groupby(family, sort=False)["p"].transform(lambda p: holm(p.to_numpy()))
    out["reading"] = [_reading(r, alpha) for r in out.itertuples(index=False)]
    return out


def mann_whitney(a: np.ndarray, b: np.ndarray) -> tuple[float, float, str]:
    """Two-sided Mann–Whitney U of ``a`` (n,) against ``b`` (m,), as exact as the samples allow.

    Without ties, the exact null distribution of U (``exact``). With ties (TTF = 1 for every trial that
    completes), the exact permutation distribution of U over all C(n + m, n) arrangements of the
    pooled values (``exact permutation``, :func:`analysis.inference.permutation_u`; one trial a side
    too) while there are at most :data:`analysis.inference.EXACT_PERMUTATIONS` of them, else the normal
    approximation with the tie correction and continuity correction (``normal``), which small samples
    never reach.

    Returns:
        U of ``a``, the p-value, and the method's name.
    """
    pooled = np.concatenate([a, b])
    if len(np.unique(pooled)) == len(pooled):
        res = mannwhitneyu(a, b, alternative="two-sided", method="exact")
        return float(res.statistic), float(res.pvalue), "exact"
    exact = permutation_u(a, b)
    if exact is not None:
        return exact[0], exact[1], "exact permutation"
    res = mannwhitneyu(a, b, alternative="two-sided", method="asymptotic")
    return float(res.statistic), float(res.pvalue), "normal"


def smallest_p(a: np.ndarray, b: np.ndarray) -> float:
    """The smallest p :func:`mann_whitney` could give for any arrangement of these pooled values (what
    the test can detect at this n; 2 / C(n + m, n) without ties); NaN where the test is not exact."""
    pooled = np.concatenate([a, b])
    if len(np.unique(pooled)) == len(pooled):
        return smallest_u_p(len(a), len(b))
    exact = permutation_u(a, b)
    return exact[2] if exact is not None else math.nan


def hodges_lehmann(a: np.ndarray, b: np.ndarray) -> float:
    """The Hodges–Lehmann shift of ``a`` (n,) against ``b`` (m,): the median of the n m differences
    ``a_i - b_j``, the effect size that goes with Mann–Whitney's U (in TTF units)."""
    return float(np.median(np.subtract.outer(np.asarray(a, float), np.asarray(b, float))))


def _paired(ref_conditions: list[str], other_conditions: list[str]) -> list[tuple[str, str]]:
    """The (reference condition, other condition) pairs to test: equal ones, and every condition of
    one side against the other side's only condition; none where either side has no trial."""
    if len(other_conditions) == 1:
        return [(c, other_conditions[0]) for c in ref_conditions]
    if len(ref_conditions) == 1:
        return [(ref_conditions[0], c) for c in other_conditions]
    return [(c, c) for c in ref_conditions if c in other_conditions]


def _named(variant: str, condition: str) -> str:
    """A variant with its condition, ``"full [duration=2.0]"``, or the bare variant."""
    return f"{variant} [{condition}]" if condition else variant


def _reading(r, alpha: float) -> str:
    if not (r.n_ref and r.n_other):
        missing = (
            _named(r.reference, r.reference_condition) if not r.n_ref else _named(r.variant, r.condition)
        )
        return f"not tested: no ok trial of {missing}"
    medians = f"median {_pct(r.median_ref)} % vs {_pct(r.median_other)} %"
    small = " (small samples)" if min(r.n_ref, r.n_other) < 5 else ""
    if r.p_holm < alpha:
        direction = "longer" if r.prob_superiority > 0.5 else "shorter"
        ref, other = _named(r.reference, r.reference_condition), _named(r.variant, r.condition)
        return f"{ref} lasts {direction} than {other} ({medians}; Holm p = {_p(r.p_holm)}){small}"
    return f"no significant difference at α = {alpha:g} ({medians}; Holm p = {_p(r.p_holm)}){small}"


def markdown_report(
    df: pd.DataFrame,
    *,
    sweep_dirs: Sequence[str | Path] = (),
    figure: str | None = None,
    alpha: float = 0.05,
) -> str:
    """The report as Markdown: provenance, a table per task × variant, and full vs each ablation.

    Args:
        df: the table of :func:`analysis.aggregate.load_records`.
        sweep_dirs: the directories read, listed in the report (defaults to the table's ``sweep_dir``).
        figure: a path (relative to the report) of the TTF figure to embed; ``None`` for none.
        alpha: significance level of the readings.

    Returns:
        The Markdown text.
    """
    summary = summary_table(df)
    tests = significance_tests(df, alpha=alpha)
    status = df["status"].fillna("no status").value_counts()
    dirs = [str(d) for d in sweep_dirs] or sorted(df["sweep_dir"].dropna().astype(str).unique())
    lines = [
        "# ContactMPC results",
        "",
        f"- Sweeps: {', '.join(f'`{d}`' for d in dirs) or '—'}",
        f"- Trials: {len(df)} ({', '.join(f'{n} {s}' for s, n in sorted(status.items())) or 'none'})",
    ]
    for col, label in (("preset", "Presets"), ("hand", "Hands"), ("planner", "Planners")):
        counts = df[col].fillna("?").astype(str).value_counts()
        lines.append(f"- {label}: {', '.join(f'{k} ({n})' for k, n in sorted(counts.items()))}")
    revisions = sorted(df["git_revision"].dropna().astype(str).unique())
    lines.append(f"- Git revisions: {', '.join(f'`{r}`' for r in revisions) or 'unknown'}")
    conditioned = bool(summary["condition"].astype(bool).any())
    if conditioned:
        lines.append(
            "- Conditions: trials of one task and variant ran under different config values; each "
            "condition is a row of its own, named by those values"
        )
    lines += ["", "## Per task and variant", ""]
    lines += _table(
        [
            "task",
            "variant",
            *(["condition"] if conditioned else []),
            "n",
            "errors",
            "completion",
            "finished cleanly",
            "median TTF %",
            "IQR TTF %",
            "obj. pos. err. in span (mm)",
            "after span (mm)",
            "whole trial (mm)",
        ],
        [
            [
                r.task,
                r.variant,
                *([r.condition or "—"] if conditioned else []),
                r.n,
                r.errors,
                _pct(r.completion_rate, 0, suffix=" %"),
                _pct(r.finished_cleanly_rate, 0, suffix=" %"),
                _pct(r.ttf_median),
                f"{_pct(r.ttf_q25)}–{_pct(r.ttf_q75)}" if np.isfinite(r.ttf_q25) else "—",
                _num(1000.0 * r.object_position_error_span_mean, 1),
                _num(1000.0 * r.object_position_error_after_mean, 1),
                _num(1000.0 * r.object_position_error_mean, 1),
            ]
            for r in summary.itertuples(index=False)
        ],
        align="ll" + "l" * conditioned + "rrrrrrrrr",
    )
    lines += [
        "",
        "TTF is the time to failure as a percentage of the span between the first and last expected contact;",
        "`n` counts the trials that count for TTF, completion and error (status ok, or diverged with a TTF:",
        "a plant that diverged inside the contact span failed there), `errors` the others (error, older",
        "diverged records, unfinished). Completion is the rate of the task's own success predicate,",
        "where recorded: TTF overestimates success (paper §III). *Finished cleanly*: completed, and at the",
        "end the object at rest where the reference leaves it, let go where the reference lets go. Object",
        "position errors are means over trials of each trial's mean: over the contact span (the tracking",
        "error), after it (release and retreat), and over the whole trial; — where no record has them.",
        "",
        f"## {REFERENCE_VARIANT} vs each ablation (Mann–Whitney U on TTF, two-sided)",
        "",
    ]
    if len(tests):
        lines += _table(
            [
                "task",
                "comparison",
                "n",
                "U",
                "p",
                "p (Holm)",
                f"P({REFERENCE_VARIANT} > other)",
                "HL shift (TTF %)",
                "test",
            ],
            [
                [
                    r.task,
                    f"{_named(r.reference, r.reference_condition)} vs {_named(r.variant, r.condition)}",
                    f"{r.n_ref} vs {r.n_other}",
                    _num(r.U, 1),
                    _p(r.p),
                    _p(r.p_holm),
                    _num(r.prob_superiority, 2),
                    _num(100 * r.hl_shift, 1),
                    r.method,
                ]
                for r in tests.itertuples(index=False)
            ],
            align="llrrrrrrl",
        )
        lines += [
            "",
            f"Readings (Holm-adjusted over the {int(np.isfinite(tests['p']).sum())} tests, α = {alpha:g}):",
            "",
        ]
        lines += [
            f"- **{r.task}**, {_named(r.reference, r.reference_condition)} vs "
            f"{_named(r.variant, r.condition)}: {r.reading}."
            for r in tests.itertuples(index=False)
        ]
    else:
        lines.append(f"No task has trials of the `{REFERENCE_VARIANT}` variant: nothing to compare.")
    if figure:
        lines += [
            "",
            "## Time to failure (paper Fig. 3)",
            "",
            f"![Time to failure per task and variant]({figure})",
        ]
    return "\n".join(lines) + "\n"


def write_report(
    df: pd.DataFrame,
    out: str | Path,
    *,
    sweep_dirs: Sequence[str | Path] = (),
    csv: str | Path | None = None,
    figure: str | Path | None = None,
    alpha: float = 0.05,
) -> list[Path]:
    """Write the Markdown report to ``out``, and optionally the table (``csv``) and the figure (``figure``).

    Returns:
        The paths written.
    """
    from analysis.figures import ttf_boxplot

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    written = []
    if csv is not None:
        written.append(write_table(df, csv))
    link = None
    if figure is not None:
        ttf_boxplot(df, figure)
        written.append(Path(figure))
        link = Path(os.path.relpath(Path(figure).resolve(), out.resolve().parent)).as_posix()
    out.write_text(markdown_report(df, sweep_dirs=sweep_dirs, figure=link, alpha=alpha))
    written.append(out)
    return written


def write_all(
    df: pd.DataFrame,
    out_dir: str | Path,
    *,
    sweep_dirs: Sequence[str | Path] = (),
    table_name: str = "results.csv",
    alpha: float = 0.05,
) -> list[Path]:
    """Write ``results.csv`` (or ``table_name``), ``fig3.png`` and ``results.md`` into ``out_dir``.

    Returns:
        The paths written.
    """
    out_dir = Path(out_dir)
    return write_report(
        df,
        out_dir / "results.md",
        sweep_dirs=sweep_dirs,
        csv=out_dir / table_name,
        figure=out_dir / "fig3.png",
        alpha=alpha,
    )


def _table(header: list[str], rows: list[list], align: str) -> list[str]:
    marks = {"l": ":--", "r": "--:"}
    out = ["| " + " | ".join(header) + " |", "| " + " | ".join(marks[a] for a in align) + " |"]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return out


def _pct(x: float, digits: int = 1, suffix: str = "") -> str:
    return f"{100.0 * x:.{digits}f}{suffix}" if x is not None and np.isfinite(x) else "—"


def _num(x: float, digits: int) -> str:
    return f"{x:.{digits}f}" if x is not None and np.isfinite(x) else "—"


def _p(p: float) -> str:
    return f"{p:.3g}" if p is not None and np.isfinite(p) else "—"


def build_parser() -> argparse.ArgumentParser:
    """Parser of ``python -m analysis.report``."""
    parser = sweep_parser(
        "python -m analysis.report",
        "Write a Markdown report (per task × variant statistics, full vs ablation tests).",
    )
    parser.add_argument("--out", default="results.md", help="Markdown report; default %(default)s")
    parser.add_argument("--csv", default=None, help="also write the table here (.csv or .parquet)")
    parser.add_argument("--figure", default=None, help="also draw the TTF box plot here and embed it")
    parser.add_argument("--alpha", type=float, default=0.05, help="significance level; default %(default)s")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m analysis.report``; returns the exit status."""
    args = build_parser().parse_args(argv)

    def action(df: pd.DataFrame) -> str:
        written = write_report(
            df, args.out, sweep_dirs=args.sweep_dirs, csv=args.csv, figure=args.figure, alpha=args.alpha
        )
        return f"wrote {', '.join(map(str, written))} ({len(df)} trials)"

    return run_records(args.sweep_dirs, action, (OSError, RuntimeError, ValueError))


if __name__ == "__main__":
    raise SystemExit(main())
