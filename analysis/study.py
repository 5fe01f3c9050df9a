"""Studies: one folder per research question, its report generated from its kept records.

Layout (at the repository root)::

    studies/<name>/report.py    the study's spec: TITLE, EXPERIMENTS, RECORDS (optional), QUESTION
                                (optional; else the docstring's first line), report(study) -> str,
                                glance(study) -> list[dict] (optional)
    studies/<name>/records/     its kept trial records (<job dir>/trial.json)
    studies/<name>/figures/     the figures the generator draws (PNG)
    studies/<name>/README.md    the report, GENERATED: never edit it by hand
    studies/README.md           the index of the studies, GENERATED

Every number a report shows, in its tables or its prose, is computed from the records by its
``report()``; ``tests/test_studies.py`` fails when a committed report differs from what its records make.

Command line (from the repository root)::

    python -m analysis.study [NAME ...] [--check] [--readme]

re-makes the reports of the named studies (all by default) and the index; ``--check`` writes nothing
and exits 1 naming each stale report (figures are drawn only without it); ``--readme`` also re-makes
the "results at a glance" table in ``README.md`` (between ``<!-- glance:begin -->`` and
``<!-- glance:end -->``; with ``--check``, checks it).
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import json
import sys
from collections.abc import Callable
from functools import cached_property
from pathlib import Path
from types import ModuleType

import pandas as pd

from analysis.aggregate import load_records
from analysis.prose import ALL_TASKS
from analysis.summarize import Fmt
from contactmpc.labels import GROUPS, method_name
from contactmpc.records import RECORD_NAME

REPO = Path(__file__).resolve().parent.parent
STUDIES = REPO / "studies"
README = REPO / "README.md"
GLANCE_BEGIN, GLANCE_END = "<!-- glance:begin -->", "<!-- glance:end -->"
#: Columns of the README's "results at a glance" table: the keys of each row ``glance()`` returns.
GLANCE_COLUMNS: tuple[str, ...] = (
    "task",
    "configuration",
    "completed",
    "finished cleanly",
    "median CPU-s per trial",
    "study",
)


class Study:
    """One study folder (``studies/<name>``) and its spec (``report.py``).

    Attributes:
        name: the folder's name.
        dir: the folder.
        spec: the loaded ``report.py`` module.
        drawing: whether figures are drawn (``False`` under ``--check`` and in tests).
        fmt: number formats for the prose (:class:`analysis.summarize.Fmt`).
    """

    fmt = Fmt

    def __init__(self, name: str, root: Path = STUDIES, drawing: bool = False) -> None:
        self.name = name
        self.root = Path(root)
        self.dir = self.root / name
        if not (self.dir / "report.py").is_file():
            raise FileNotFoundError(f"no study {name!r}: {self.dir / 'report.py'} does not exist")
        self.drawing = drawing
        self._tables: dict[tuple, pd.DataFrame] = {}  # records(): the tables made, by folders and files

    @cached_property
    def spec(self) -> ModuleType:
        path = self.dir / "report.py"
        spec = importlib.util.spec_from_file_location(f"studies.{self.name}.report", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        for attr in ("TITLE", "EXPERIMENTS", "report"):
            if not hasattr(module, attr):
                raise ValueError(f"{path} defines no {attr}")
        return module

    @property
    def title(self) -> str:
        return self.spec.TITLE

    @property
    def question(self) -> str:
        """One line: ``QUESTION``, else the first paragraph of the spec's docstring."""
        q = getattr(self.spec, "QUESTION", None) or (self.spec.__doc__ or "").strip().split("\n\n")[0]
        return " ".join(q.split())

    def record_dirs(self, *extra: str, own: bool = True) -> list[Path]:
        """The folders of records it reads: its own ``records/``, each of ``RECORDS`` and ``extra``
        (``"other_study"`` or ``"other_study/records"``), those that exist; ``own=False``: ``extra`` only."""
        names = [*getattr(self.spec, "RECORDS", []), *extra] if own else list(extra)
        dirs = [self.dir / "records"] if own else []
        for n in names:
            d = self.root / n
            dirs.append(d / "records" if (d / "records").is_dir() else d)
        return [d for d in dict.fromkeys(dirs) if d.is_dir()]

    def record_paths(self, *extra: str) -> list[Path]:
        """Every ``trial.json`` it reads (see :meth:`record_dirs`), sorted."""
        return sorted(p for d in self.record_dirs(*extra) for p in d.rglob(RECORD_NAME) if p.is_file())

    def records(self, *extra: str, own: bool = True) -> pd.DataFrame:
        """Its records (:meth:`record_dirs`; ``own=False``: those of ``extra`` only) as
        :func:`analysis.aggregate.load_records` tables them, with a ``fidelity`` column (the
        ``conf/fidelity`` member each trial ran under) and old labels mapped by the project's label map
        where it has one. Empty (no rows) where there are none."""
        dirs = self.record_dirs(*extra, own=own)
        if not any(d.rglob(RECORD_NAME) for d in dirs):
            return pd.DataFrame(columns=["task", "variant", "fidelity", "status", "ttf", "git_revision"])
        dirs = [d for d in dirs if any(d.rglob(RECORD_NAME))]
        # a report asks for the same folders many times: tabled once per study while their files are the
        # same (paths, modification times and texts), each caller given its own copy
        digest = hashlib.blake2b(digest_size=20)
        for path in sorted(p for d in dirs for p in d.rglob(RECORD_NAME) if p.is_file()):
            digest.update(f"{path}\0{path.stat().st_mtime_ns}\0".encode())
            digest.update(path.read_bytes())
        key = (tuple(dirs), digest.digest())
        if key not in self._tables:
            self._tables[key] = _relabel(_with_fidelity(load_records(*dirs)))
        return self._tables[key].copy()

    def figure(self, name: str) -> Path:
        """The path of figure ``name`` (``figures/`` created)."""
        path = self.dir / "figures" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        return path

    def draw(
        self, name: str, make: Callable[[Path], object], alt: str, data: Path | None = None
    ) -> str | None:
        """Draw figure ``name`` with ``make(path)`` when :attr:`drawing`; the Markdown image link.

        ``data``: a file the figure is drawn from that only some machines have (a trial's time series,
        which is not kept in git): the figure is drawn only where it exists, and the link is given where it
        exists or the kept figure does; ``None`` (no link) where neither does.
        """
        if data is not None and not Path(data).is_file():
            return f"![{alt}](figures/{name})" if (self.dir / "figures" / name).is_file() else None
        if self.drawing:
            make(self.figure(name))
        return f"![{alt}](figures/{name})"

    def provenance(self, df: pd.DataFrame) -> str:
        """One line: how many records, from which code revisions and on which machines; a warning
        sentence where they span more than one revision."""
        if not len(df):
            return "No records yet."
        revs = df["git_revision"].fillna("unknown").astype(str).value_counts()
        revs = revs.sort_index().sort_values(ascending=False, kind="stable")
        rev_text = ", ".join(f"`{r[:7]}` ({n})" for r, n in revs.items())
        machines = _machines(df)
        line = (
            f"{Fmt.plural(len(df), 'record')} from {Fmt.plural(len(revs), 'code revision')} "
            f"({rev_text}) on {machines}."
        )
        if len(revs) > 1:
            line += (
                f" **The records span {len(revs)} code revisions**: a trial run again at another revision "
                "can differ (a change of 1e-12 in a rollout can flip a trial's outcome)."
            )
        return line

    def header(self) -> str:
        """The generated header: title, where the report comes from, the commands that made the records."""
        n = len(self.record_paths())
        lines = [
            f"# {self.title}",
            "",
            f"*Generated by `python -m analysis.study {self.name}` from {Fmt.plural(n, 'record')}; "
            "do not edit.*",
            "",
        ]
        experiments = list(self.spec.EXPERIMENTS)
        if experiments:
            lines += ["The records were made by:", "", "```"]
            lines += [
                e if e.startswith(("python", "bash")) or " " in e else f"python launch.py experiment={e}"
                for e in experiments
            ]
            lines += ["```", ""]
        return "\n".join(lines) + "\n"

    def render(self) -> str:
        """The whole report (header and body) as it would be written."""
        body = self.spec.report(self)
        return self.header() + body.rstrip("\n") + "\n"

    def glance(self) -> list[dict]:
        rows = getattr(self.spec, "glance", None)
        return list(rows(self)) if rows is not None else []


def sweep_params(experiment: str, root: Path = REPO / "conf" / "experiment") -> dict[str, list[str]]:
    """The values each of ``experiment``'s sweeper parameters takes (``a,b,c`` -> 3 values, ``range(n)``
    or ``range(a, b)`` -> the integers as text); empty where it has no such config."""
    import re

    from omegaconf import OmegaConf

    path = Path(root) / f"{experiment}.yaml"
    if not path.is_file():
        return {}
    params = OmegaConf.select(OmegaConf.load(path), "hydra.sweeper.params", default=None) or {}
    out = {}
    for key, value in params.items():
        text = str(value).strip()
        m = re.fullmatch(r"range\((\d+)(?:,\s*(\d+))?\)", text)
        if m:
            lo, hi = (int(m[1]), int(m[2])) if m[2] else (0, int(m[1]))
            out[str(key)] = [str(i) for i in range(lo, hi)]
        else:
            out[str(key)] = [v.strip() for v in text.split(",")]
    return out


def planned(experiment: str, root: Path = REPO / "conf" / "experiment") -> int | None:
    """How many jobs ``experiment``'s sweep runs: the product of the sizes of its sweeper's parameters;
    ``None`` where it has no such config."""
    params = sweep_params(experiment, root)
    if not params:
        return None
    total = 1
    for values in params.values():
        total *= len(values)
    return total


def _machines(df: pd.DataFrame) -> str:
    """The machines the records ran on: CPU model with logical CPUs (and the host where recorded)."""
    cols = [c for c in ("host", "cpu", "logical_cpus") if c in df]
    if not cols:
        return "unrecorded machines"
    parts = df[cols].astype(object).where(df[cols].notna(), None)
    names = []
    for row in parts.itertuples(index=False):
        d = dict(zip(cols, row, strict=True))
        text = str(d.get("cpu") or "unknown CPU")
        if d.get("logical_cpus") is not None:
            text += f" ×{int(d['logical_cpus'])}"
        if d.get("host"):
            text = f"{d['host']} ({text})"
        names.append(text)
    counts = pd.Series(names).value_counts()
    counts = counts.sort_index().sort_values(ascending=False, kind="stable")
    return Fmt.listing([f"{m} ({n})" for m, n in counts.items()])


def _with_fidelity(df: pd.DataFrame) -> pd.DataFrame:
    from analysis.paper_fig3 import fidelities, fidelity_of

    known = fidelities()
    df = df.copy()
    df["fidelity"] = [
        fidelity_of(json.loads(Path(p).read_text()).get("config"), known) for p in df["record_path"]
    ]
    return df


def _relabel(df: pd.DataFrame) -> pd.DataFrame:
    """Variant labels by the project's label map (:func:`contactmpc.labels.method_name`: a record's
    ``variant`` and method groups -> the method's name), so that an old record (``variant=release_flat``)
    and a new one of the same method (``release=flat``) group together."""
    if "variant" not in df or not len(df):
        return df
    groups = [c for c in ("variant", *GROUPS) if c in df]
    rows = df[groups].astype(object).where(df[groups].notna(), None).to_dict("records")
    return df.assign(variant=[method_name(r) or r["variant"] for r in rows])


def names(root: Path = STUDIES) -> list[str]:
    """The studies under ``root``: folders with a ``report.py``, sorted."""
    return sorted(p.parent.name for p in Path(root).glob("*/report.py"))


def index(root: Path = STUDIES) -> str:
    """The index of the studies (``studies/README.md``)."""
    lines = [
        "# Studies",
        "",
        "*Generated by `python -m analysis.study`; do not edit.* Each study is a folder: its spec "
        "(`report.py`), its kept records (`records/`), its figures and its report (`README.md`), "
        "generated from the records. `python -m analysis.study [NAME ...]` re-makes them (`--check`: "
        "write nothing, exit 1 if one is stale). A new study is a folder with a `report.py` that defines "
        "`TITLE`, `EXPERIMENTS` (the commands that made its records), optionally `RECORDS` (other "
        "studies whose records it reads too) and `glance(study)`, and `report(study) -> str`, which "
        "computes every number it shows from `study.records()` (tables with `analysis.summarize`); see "
        "`analysis/study.py`.",
        "",
        "| study | title | records | question |",
        "|---|---|--:|---|",
    ]
    for name in names(root):
        s = Study(name, root)
        lines.append(f"| [{name}]({name}/README.md) | {s.title} | {len(s.record_paths())} | {s.question} |")
    return "\n".join(lines) + "\n"


def glance_table(root: Path = STUDIES) -> str:
    """The README's "results at a glance": of every study's ``glance()`` rows, the best per task (the
    highest lower bound of the 95 % Wilson interval of its completion rate, so that 9/10 beats 1/1, then
    the same of finishing cleanly, then the fewest median CPU-s; ties keep the study first by name),
    tasks in the order they first appear; below it the task's default (a row whose configuration says
    ``(the default)``) where the default is not the best, so the table shows what a user gets by default,
    and the row of the one method that does every task best (whose configuration says :data:`ALL_TASKS`)
    where it is neither."""
    best: dict[str, tuple[tuple, dict]] = {}
    default: dict[str, tuple[tuple, dict]] = {}
    every: dict[str, dict] = {}
    for name in names(root):
        for row in Study(name, root).glance():
            row = {**row, "study": row.get("study") or f"[{name}](studies/{name}/README.md)"}
            key = (
                _fraction(row.get("completed")),
                _fraction(row.get("finished cleanly")),
                -_number(row.get("median CPU-s per trial")),
            )
            task = str(row.get("task"))
            if task not in best or key > best[task][0]:
                best[task] = (key, row)
            if "(the default)" in str(row.get("configuration")) and (
                task not in default or key > default[task][0]
            ):
                default[task] = (key, row)
            if ALL_TASKS in str(row.get("configuration")):
                every.setdefault(task, row)
    lines = [
        "| " + " | ".join(GLANCE_COLUMNS) + " |",
        "|---|---|--:|--:|--:|---|",
    ]
    for task, (_, row) in best.items():
        rows = [row] + ([default[task][1]] if task in default and default[task][1] is not row else [])
        rows += [every[task]] if task in every and all(every[task] is not r for r in rows) else []
        lines += ["| " + " | ".join(str(r.get(c, "—")) for c in GLANCE_COLUMNS) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def _fraction(text: object) -> float:
    """``"k/n"`` -> the lower bound of the Wilson 95 % interval of k of n; anything else -> -1."""
    from analysis.inference import wilson

    try:
        k, n = (int(x) for x in str(text).split("/"))
    except ValueError:
        return -1.0
    return wilson(k, n)[0] if n else -1.0


def _number(text: object) -> float:
    try:
        return float(str(text))
    except ValueError:
        return float("inf")


def with_glance(readme: str, table: str) -> str:
    """``readme`` with the table between the glance markers replaced by ``table``.

    Raises:
        ValueError: the README has no glance markers.
    """
    if GLANCE_BEGIN not in readme or GLANCE_END not in readme:
        raise ValueError(f"README.md has no {GLANCE_BEGIN} ... {GLANCE_END} block")
    a = readme.index(GLANCE_BEGIN) + len(GLANCE_BEGIN)
    b = readme.index(GLANCE_END)
    return readme[:a] + "\n" + table + readme[b:]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m analysis.study", description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="studies to re-make (default: all)")
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if a report is stale")
    parser.add_argument("--readme", action="store_true", help="also the README's results-at-a-glance table")
    args = parser.parse_args(argv)
    known = names()
    unknown = [n for n in args.names if n not in known]
    if unknown:
        print(f"no such study: {', '.join(unknown)} (studies: {', '.join(known)})", file=sys.stderr)
        return 2
    outputs: dict[Path, str] = {}
    for name in args.names or known:
        study = Study(name, drawing=not args.check)
        outputs[study.dir / "README.md"] = study.render()
    outputs[STUDIES / "README.md"] = index()
    if args.readme:
        try:
            outputs[README] = with_glance(README.read_text(), glance_table())
        except ValueError as err:
            print(err, file=sys.stderr)
            return 2
    stale = [p for p, text in outputs.items() if not p.is_file() or p.read_text() != text]
    if args.check:
        for p in stale:
            print(f"stale: {p.relative_to(REPO)} (run python -m analysis.study)")
        if not stale:
            print(f"{len(outputs)} reports are current")
        return int(bool(stale))
    for p in stale:
        p.write_text(outputs[p])
    print(
        f"wrote {len(stale)} of {len(outputs)} reports" + "".join(f"\n  {p.relative_to(REPO)}" for p in stale)
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
