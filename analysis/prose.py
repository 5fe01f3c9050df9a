"""Numbers for a study's prose, computed from its records: ranges, counts, seed lists.

Each helper turns values taken from trial records into the words a report prints, so that no number in
a report's findings is typed by hand (``studies/<name>/report.py``)."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np


def _finite(values: Iterable) -> list[float]:
    out = []
    for v in values:
        try:
            f = float(v)
        except (TypeError, ValueError):
            continue
        if math.isfinite(f):
            out.append(f)
    return out


def span(values: Iterable, fmt: str = "{:.0f}", scale: float = 1.0, sep: str = "-") -> str:
    """``lo-hi`` of the finite ``values`` times ``scale`` (one value where they agree at ``fmt``; ``-``
    where there is none)."""
    v = [scale * x for x in _finite(values)]
    if not v:
        return "-"
    lo, hi = fmt.format(min(v)), fmt.format(max(v))
    return lo if lo == hi else f"{lo}{sep}{hi}"


def median(values: Iterable, fmt: str = "{:.0f}", scale: float = 1.0) -> str:
    """The median of the finite ``values`` times ``scale``, formatted (``-`` where there is none)."""
    v = _finite(values)
    return fmt.format(scale * float(np.median(v))) if v else "-"


def of(k: int, n: int) -> str:
    """``k of n``."""
    return f"{int(k)} of {int(n)}"


def frac(k: int, n: int) -> str:
    """``k/n``."""
    return f"{int(k)}/{int(n)}"


def seeds(values: Iterable) -> str:
    """Seeds as the prose writes them: ``0``, ``0 and 1``, ``0, 2 and 5``, runs as ``0-2``."""
    s = sorted({int(v) for v in values})
    if not s:
        return "none"
    runs: list[str] = []
    start = prev = s[0]
    for v in [*s[1:], None]:
        if v is not None and v == prev + 1:
            prev = v
            continue
        if prev > start + 1:
            runs.append(f"{start}-{prev}")
        else:
            runs += [str(x) for x in range(start, prev + 1)]
        if v is not None:
            start = prev = v
    return runs[0] if len(runs) == 1 else ", ".join(runs[:-1]) + " and " + runs[-1]


def ratio(a: float, b: float, fmt: str = "{:.1f}") -> str:
    """``a / b`` formatted (``-`` where ``b`` is 0 or either is missing)."""
    v = _finite([a, b])
    return "-" if len(v) < 2 or v[1] == 0 else fmt.format(v[0] / v[1])


def seeds_n(values: Iterable) -> str:
    """``seed 2`` or ``seeds 3-5``: :func:`seeds` with its noun."""
    s = {int(v) for v in values}
    return f"seed{'s' if len(s) != 1 else ''} {seeds(s)}"


def as_recorded(df):
    """``df`` (``Study.records()``) with each variant under the label its records carry: the project's label
    map (``contactmpc.labels.VARIANT_LABELS``, old name -> new), where it exists, undone for the names it
    maps one to one, so that a report written against the records' labels reads the same after a rename."""
    try:
        from contactmpc import labels  # type: ignore[attr-defined]
    except ImportError:
        return df
    mapping = getattr(labels, "VARIANT_LABELS", None)
    if not isinstance(mapping, dict) or "variant" not in df:
        return df
    news = list(mapping.values())
    back = {new: old for old, new in mapping.items() if news.count(new) == 1}
    return df.assign(variant=df["variant"].map(lambda v: back.get(v, v)))


def unchallenged(df):
    """``df`` without the trials run under a challenge (``challenge=...``: the Fig. 3 study's hard cells, a
    task made harder than the paper's), for a study that reads another's records as the paper's tasks."""
    return df[df["challenge"].isna()] if "challenge" in df else df


#: What a glance row's configuration says where it is the one method a study finds best on all its tasks
#: (``analysis.study.glance_table`` shows it beside each task's best and default).
ALL_TASKS = "(one method for every task)"


def glance_row(task: str, configuration: str, trials) -> dict:
    """A row of the README's "results at a glance" (``analysis.study.glance_table``) for ``trials``, a
    frame with boolean ``completed`` and ``finished_cleanly`` and the CPU seconds ``compute``."""
    n = len(trials)
    return {
        "task": task,
        "configuration": configuration,
        "completed": f"{int(trials['completed'].sum())}/{n}",
        "finished cleanly": f"{int(trials['finished_cleanly'].sum())}/{n}",
        "median CPU-s per trial": median(trials["compute"]),
    }
