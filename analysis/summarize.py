"""One group-and-reduce for every study: ``summarize(records, by=..., stats=...)`` and its pipe table.

A :class:`Stat` names a column of the records and how to reduce it over a group (a count of true values
"5/6", a rate, the median, the mean, the quartiles, the range, a sum ...). Its header says which
statistic it is ("median TTF %", "mean object error (mm)"), so no table leaves a reader guessing whether
a number is a median or a mean. :func:`summarize` returns the values (numbers, or the "k/n" text of a
count); :func:`markdown` writes them as a pipe table with each stat's own format.

    from analysis.summarize import Stat, markdown, summarize
    table = summarize(df, by=["task", "variant"], stats=[
        Stat("completed", "count", name="completed"),
        Stat("ttf", "median", name="TTF %", scale=100),
        Stat("object_position_error_span_mean", "mean", name="error in span (mm)", scale=1000, digits=0),
    ])
    print(markdown(table))
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

#: The reductions a :class:`Stat` knows, each with the word its header starts with ("" for none).
HOW: dict[str, str] = {
    "n": "",  # rows in the group (the column is not read)
    "count": "",  # "k/n": true values of a boolean column among those recorded
    "rate": "rate",  # fraction of true values among those recorded
    "sum": "total",
    "median": "median",
    "mean": "mean",
    "min": "min",
    "max": "max",
    "q25": "25th pct",
    "q75": "75th pct",
    "iqr": "IQR",  # "q25–q75"
    "range": "range",  # "min–max"
    "median_iqr": "median (IQR)",  # "median (q25–q75)"
    "median_range": "median (range)",  # "median (min–max)"
    "values": "",  # every value, in the records' order: "1.00, 0.57, 0.01"
}


@dataclass(frozen=True)
class Stat:
    """How one column is reduced over a group, and how the result is shown.

    Attributes:
        column: the records' column it reads (unused for ``how="n"``).
        how: one of :data:`HOW`.
        name: what the column is, in the header ("TTF %"); the header is the statistic's word and the
            name ("median TTF %"); defaults to ``column``.
        label: the whole header, overriding the statistic's word and ``name`` (use it for a column of
            machine-readable tables, e.g. ``"ttf_median"``; a table shown to readers keeps the word).
        scale: values are multiplied by it before reducing (100: fractions as %, 1000: m as mm).
        digits: decimals shown by :func:`markdown`.
        where: rows of the group it reads (e.g. :func:`analysis.aggregate.ok_trials`); ``None``: all.
        blank: what :func:`markdown` shows where the value is missing.
    """

    column: str
    how: str = "median"
    name: str | None = None
    label: str | None = None
    scale: float = 1.0
    digits: int = 1
    where: Callable[[pd.DataFrame], pd.DataFrame] | None = None
    blank: str = "—"

    def __post_init__(self) -> None:
        if self.how not in HOW:
            raise ValueError(f"unknown statistic {self.how!r} (one of {', '.join(HOW)})")

    @property
    def header(self) -> str:
        """The header of the column: ``label``, else the statistic's word and the name."""
        if self.label is not None:
            return self.label
        word, name = HOW[self.how], self.name or self.column
        return f"{word} {name}".strip() if word else name

    def reduce(self, group: pd.DataFrame) -> object:
        """The statistic over the rows of ``group`` (NaN, or ``"0/0"`` for a count, where none)."""
        rows = self.where(group) if self.where is not None else group
        if self.how == "n":
            return len(rows)
        values = rows[self.column] if self.column in rows else pd.Series(dtype=float)
        if self.how in ("count", "rate"):
            known = values.dropna().astype(bool)
            if self.how == "count":
                return f"{int(known.sum())}/{len(known)}"
            return float(known.mean()) if len(known) else math.nan
        x = pd.to_numeric(values, errors="coerce").dropna().to_numpy(float) * self.scale
        if self.how == "values":
            return ", ".join(f"{v:.{self.digits}f}" for v in x) if len(x) else None
        if not len(x):
            return math.nan if self.how not in ("iqr", "range", "median_iqr", "median_range") else None
        if self.how == "sum":
            return float(x.sum())
        one = {
            "median": np.median,
            "mean": np.mean,
            "min": np.min,
            "max": np.max,
            "q25": lambda v: np.percentile(v, 25),
            "q75": lambda v: np.percentile(v, 75),
        }
        if self.how in one:
            return float(one[self.how](x))
        lo, hi = (
            (float(np.percentile(x, 25)), float(np.percentile(x, 75)))
            if self.how in ("iqr", "median_iqr")
            else (float(x.min()), float(x.max()))
        )
        return (lo, hi) if self.how in ("iqr", "range") else (float(np.median(x)), lo, hi)

    def show(self, value: object) -> str:
        """``value`` (what :meth:`reduce` made) as the table shows it."""
        if value is None or (isinstance(value, float) and not math.isfinite(value)):
            return self.blank
        if isinstance(value, str | int | np.integer):
            return str(value)
        if isinstance(value, tuple):
            parts = [f"{v:.{self.digits}f}" for v in value]
            return f"{parts[0]}–{parts[1]}" if len(parts) == 2 else f"{parts[0]} ({parts[1]}–{parts[2]})"
        return f"{value:.{self.digits}f}"


def summarize(
    records: pd.DataFrame,
    by: Sequence[str],
    stats: Iterable[Stat] | Mapping[str, Stat],
    order: Mapping[str, Sequence] | None = None,
) -> pd.DataFrame:
    """One row per group of ``records`` (by the columns ``by``), one column per stat.

    Groups are ordered column by column: the values named in ``order[column]`` first, in that order,
    then the others sorted; a missing key value is the group ``""``. The result's columns are ``by``
    and each stat's :attr:`Stat.header` (``stats`` may also be a mapping header -> stat, whose keys
    then name the columns); ``result.attrs["stats"]`` maps each header to its stat, for :func:`markdown`.

    Raises:
        ValueError: a ``by`` column is not in the records.
    """
    named = (
        {header: stat for header, stat in stats.items()}
        if isinstance(stats, Mapping)
        else {stat.header: stat for stat in stats}
    )
    missing = [c for c in by if c not in records]
    if missing:
        raise ValueError(f"no column {', '.join(missing)} in the records to group by")
    keys = records[list(by)].astype(object).where(records[list(by)].notna(), "")
    rows = []
    if len(records):
        for key, group in records.groupby([keys[c] for c in by], sort=False):
            key = key if isinstance(key, tuple) else (key,)
            rows.append({**dict(zip(by, key, strict=True)), **{h: s.reduce(group) for h, s in named.items()}})
    out = pd.DataFrame(rows, columns=[*by, *named])
    out = sort_groups(out, by, order or {})
    out.attrs["stats"] = named
    return out


def sort_groups(table: pd.DataFrame, by: Sequence[str], order: Mapping[str, Sequence]) -> pd.DataFrame:
    """``table``'s rows ordered column by column of ``by``: ``order``'s values first, then sorted."""
    if not len(table):
        return table.reset_index(drop=True)
    ranks = {}
    for c in by:
        head = [v for v in order.get(c, ()) if v in set(table[c])]
        rest = sorted(set(table[c]).difference(head), key=lambda v: (not isinstance(v, int | float), str(v)))
        ranks[c] = {v: i for i, v in enumerate([*head, *rest])}
    ranked = table.sort_values(list(by), key=lambda col: col.map(ranks[col.name]), kind="stable")
    return ranked.reset_index(drop=True)


def markdown(df: pd.DataFrame, align: str | None = None) -> str:
    """``df`` as a pipe table; columns made by a :class:`Stat` (``df.attrs["stats"]``) in its format,
    numbers right-aligned (``align``: one ``l``/``r`` per column, to choose)."""
    stats: Mapping[str, Stat] = df.attrs.get("stats", {})
    cols = list(df.columns)
    if align is None:
        align = "".join("r" if c in stats else "l" for c in cols)
    rows = []
    for row in df.itertuples(index=False):
        cells = [stats[c].show(v) if c in stats else _cell(v) for c, v in zip(cols, row, strict=True)]
        rows.append("| " + " | ".join(cells) + " |")
    return pipe_table(map(str, cols), align, rows)


def pipe_table(columns: Iterable[str], align: str, rows: Iterable[str]) -> str:
    """A pipe table: its header of ``columns``, their alignment (one ``l``/``r`` per column) and the body
    ``rows``, each a table row already written (``| a | b |``)."""
    marks = {"l": "---", "r": "--:"}
    lines = ["| " + " | ".join(columns) + " |", "|" + "|".join(marks[a] for a in align) + "|", *rows]
    return "\n".join(lines) + "\n"


def _cell(v: object) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "—"
    return str(v)


class Fmt:
    """Numbers in a report's prose, formatted one way everywhere (``study.fmt.pct(0.5)`` -> ``"50.0"``)."""

    @staticmethod
    def num(x: float | None, digits: int = 1) -> str:
        """``x`` with ``digits`` decimals; "—" where missing."""
        return f"{x:.{digits}f}" if x is not None and math.isfinite(x) else "—"

    @staticmethod
    def pct(x: float | None, digits: int = 1) -> str:
        """A fraction as a percentage (no sign)."""
        return f"{100.0 * x:.{digits}f}" if x is not None and math.isfinite(x) else "—"

    @staticmethod
    def p(p: float | None) -> str:
        """A p-value, three significant digits."""
        return f"{p:.3g}" if p is not None and math.isfinite(p) else "—"

    @staticmethod
    def frac(k: int, n: int) -> str:
        """``"k of n"``."""
        return f"{k} of {n}"

    @staticmethod
    def plural(n: int, word: str, many: str | None = None) -> str:
        """``"1 trial"``, ``"3 trials"``."""
        return f"{n} {word if n == 1 else many or word + 's'}"

    @staticmethod
    def listing(items: Sequence[str], conj: str = "and") -> str:
        """``"a"``, ``"a and b"``, ``"a, b and c"``."""
        items = list(items)
        if len(items) <= 1:
            return "".join(items)
        return f"{', '.join(items[:-1])} {conj} {items[-1]}"

    @staticmethod
    def span(lo: float, hi: float, digits: int = 0) -> str:
        """``"lo–hi"`` (one number where they round alike)."""
        a, b = f"{lo:.{digits}f}", f"{hi:.{digits}f}"
        return a if a == b else f"{a}–{b}"
