"""Online runs (``job=online``): the slowdown each ran at, and per task and method the runs completed at
each slowdown and the smallest at which every run completed (real time on 2 x that many threads of the
CPU that ran them, a slowdown s on 2 planning threads standing in for 2s threads)."""

from __future__ import annotations

import pandas as pd

from analysis.prose import of


def slowdown(record: dict) -> float | None:
    """An online run's ``job.slowdown``, from its record's config (``None``: not an online run)."""
    return ((record.get("config") or {}).get("job") or {}).get("slowdown")


def by_slowdown(records: list[dict], name=None) -> tuple[dict[str, list], list[str], pd.DataFrame]:
    """Per run label (``name(record)``; default ``"<task> <variant>"``) and slowdown: the runs completed and
    the median replan interval.

    Returns:
        ``(table, prose, runs)``: the table as columns (header -> values, one row a label), one clause a
        label saying from which slowdown every run completes, and the runs (label, slowdown, completed,
        interval (s)); all empty where no record is an online run.
    """
    name = name or (lambda r: f"{r.get('task')} {r.get('variant')}")
    rows = [
        {
            "run": name(r),
            "slowdown": slowdown(r),
            "completed": bool(r.get("completed")),
            "interval": r.get("replan_interval_median"),
        }
        for r in records
    ]
    df = pd.DataFrame(rows, columns=["run", "slowdown", "completed", "interval"]).dropna(subset=["slowdown"])
    if not len(df):
        return {}, [], df
    slowdowns = sorted(df["slowdown"].unique())
    runs = list(dict.fromkeys(sorted(df["run"].unique())))
    table: dict[str, list] = {"task and variant": runs}
    for x in slowdowns:
        table[f"slowdown {x:g} ({2 * x:g} threads): completed, replan ms"] = [
            (
                f"{of(int(g['completed'].sum()), len(g))}, {1e3 * g['interval'].median():.0f}"
                if len(g := df[(df["run"] == run) & (df["slowdown"] == x)])
                else "—"
            )
            for run in runs
        ]
    prose = []
    for run in runs:
        g = df[df["run"] == run]
        every = [x for x in slowdowns if len(h := g[g["slowdown"] == x]) and h["completed"].all()]
        if every:
            x = every[0]
            prose.append(
                f"{run}: every run completes from slowdown {x:g} (real time on {2 * x:g} threads of this CPU)"
                if x > 1
                else f"{run}: every run completes in real time on 2 threads"
            )
        else:
            prose.append(
                f"{run}: no slowdown tried ({', '.join(f'{x:g}' for x in sorted(g['slowdown'].unique()))}) "
                "completes every run"
            )
    return table, prose, df
