"""Collect trial records (``trial.json``) from sweep directories into one table.

Each trial writes one flat ``trial.json`` (see :mod:`contactmpc.records` and :mod:`contactmpc.jobs`);
a Hydra multirun writes each job to its own subdirectory of the sweep directory. This module globs
them, keeps the flat fields as columns (the nested ``config`` is reduced to a few planner settings),
derives the paper's variant names and drops duplicate trials.

Command line::

    python -m analysis.aggregate SWEEP_DIR [SWEEP_DIR ...] --out results.csv
"""

from __future__ import annotations

import argparse
import functools
import json
import warnings
from collections.abc import Iterable
from pathlib import Path

import pandas as pd

from analysis._cli import run, sweep_parser

RECORD_NAME = "trial.json"  # == contactmpc.records.RECORD_NAME (not imported: keeps this package light)
SWEEP_MARKER = "multirun.yaml"  # Hydra writes it into the root of a multirun sweep

#: Variants of the paper's ablation (Fig. 3) under the predictive-sampling planner: (cost, sampler).
PAPER_VARIANTS: dict[tuple[str, str], str] = {
    ("contact", "pca_spline"): "full",
    ("object_only", "pca_spline"): "no_contact",
    ("contact", "joint_spline"): "joint_space",
}
PAPER_PLANNER = "predictive_sampling"
#: Order of the variants in tables and figures; other variants follow, sorted by name.
VARIANT_ORDER: tuple[str, ...] = ("full", "no_contact", "joint_space")
#: Tasks left to right by relative complexity of the dynamics (paper Fig. 3); others follow, sorted.
TASK_ORDER: tuple[str, ...] = ("doorknob", "apple", "bottle", "stapler")

#: Planner settings copied from ``config.planner`` into columns of the same name.
CONFIG_COLUMNS: tuple[str, ...] = ("num_samples", "horizon", "replan_period")
#: Record fields that are not scalars and stay out of the table.
DROPPED_FIELDS: tuple[str, ...] = ("config", "versions", "traceback")
#: Columns of the table, in this order, with the type each is coerced to (``None``: left as read);
#: fields a record has beyond these follow them.
COLUMN_TYPES: dict[str, str | None] = {
    "task": None,
    "variant": None,
    "hand": None,
    "cost": None,
    "sampler": None,
    "planner": None,
    "preset": None,
    "experiment": None,
    "seed": "Int64",
    "status": None,
    "error": None,
    "ttf": "float",
    "failed": "boolean",
    "failure_time": "float",
    "contact_span_start": "float",
    "contact_span_end": "float",
    "completed": "boolean",
    "object_position_error_mean": "float",
    "object_rotation_error_mean": "float",
    "object_articulation_error_mean": "float",
    "final_object_position_error": "float",
    "final_object_rotation_error": "float",
    "final_object_articulation_error": "float",
    "contact_fraction": "float",
    "plan_seconds_mean": "float",
    "plan_seconds_p95": "float",
    "simulated_seconds": "float",
    "wall_seconds": "float",
    "real_time_factor": "float",
    "num_control_points": "Int64",
    "num_plans": "Int64",
    "diverged_rollouts": "Int64",
    "num_samples": "Int64",
    "horizon": "float",
    "replan_period": "float",
    "schema": "Int64",
    "git_revision": None,
    "sweep_dir": None,
    "record_path": None,
    "record_mtime": "datetime",
}
COLUMNS: tuple[str, ...] = tuple(COLUMN_TYPES)
#: Columns that identify one trial within a sweep; the newest record of each such group is kept.
#: Beyond (task, variant, planner, seed, sweep_dir), hand, preset and the planner settings are part of
#: the key so that a sweep over, e.g., ``planner.num_samples`` keeps every setting.
DEDUPE_KEY: tuple[str, ...] = (
    "task",
    "variant",
    "planner",
    "seed",
    "sweep_dir",
    "hand",
    "preset",
    *CONFIG_COLUMNS,
)


class RecordWarning(UserWarning):
    """A record that could not be read (or lacks required fields) and was skipped."""


def variant_name(planner: str | None, cost: str | None, sampler: str | None) -> str:
    """Name of the method variant of a trial.

    Args:
        planner: planner choice (``predictive_sampling``, ``mppi``, ``cem``, ``replay``).
        cost: cost choice (``contact`` or ``object_only``).
        sampler: sampler choice (``pca_spline`` or ``joint_spline``).

    Returns:
        ``full``, ``no_contact`` or ``joint_space`` for the paper's ablation under predictive sampling
        (Fig. 3), otherwise ``"{planner}/{cost}/{sampler}"`` (a missing choice reads ``?``).
    """
    if planner == PAPER_PLANNER and (cost, sampler) in PAPER_VARIANTS:
        return PAPER_VARIANTS[(cost, sampler)]
    return "/".join("?" if _missing(x) else str(x) for x in (planner, cost, sampler))


def ordered(values: Iterable[str], order: Iterable[str]) -> list[str]:
    """The distinct ``values``: those named in ``order`` first (in that order), then the rest sorted."""
    present = {v for v in values if not _missing(v)}
    head = [v for v in order if v in present]
    return head + sorted(present.difference(head), key=str)


def find_records(directory: str | Path) -> list[Path]:
    """All ``trial.json`` files under ``directory`` (any depth), sorted.

    Raises:
        FileNotFoundError: ``directory`` does not exist.
        NotADirectoryError: ``directory`` is not a directory.
    """
    root = Path(directory)
    if not root.exists():
        raise FileNotFoundError(f"no such directory: {root}")
    if not root.is_dir():
        raise NotADirectoryError(f"not a directory: {root}")
    return sorted(p for p in root.rglob(RECORD_NAME) if p.is_file())


def sweep_root(record: Path, root: Path) -> Path:
    """The sweep a record belongs to: its nearest ancestor holding Hydra's ``multirun.yaml``, searched up
    to ``root``; ``root`` itself when there is none (e.g. a tree of single runs)."""
    for parent in record.parents:
        if (parent / SWEEP_MARKER).is_file():
            return parent
        if parent == root:
            break
    return root


def read_record(path: str | Path) -> dict:
    """One record as a flat row: scalar fields, the planner settings of ``config``, no nested values.

    Raises:
        OSError: the file cannot be read.
        ValueError: it is not JSON, not an object, or has no ``task``.
    """
    data = json.loads(Path(path).read_text())
    if not isinstance(data, dict):
        raise ValueError(f"expected a JSON object, got {type(data).__name__}")
    if _missing(data.get("task")):
        raise ValueError("record has no 'task'")
    config = data.get("config")
    planner_cfg = config.get("planner") if isinstance(config, dict) else None
    row = {k: v for k, v in data.items() if k not in DROPPED_FIELDS and not isinstance(v, dict | list)}
    if isinstance(planner_cfg, dict):
        for key in CONFIG_COLUMNS:
            if key in planner_cfg and not isinstance(planner_cfg[key], dict | list):
                row[key] = planner_cfg[key]
    return row


def load_records(*dirs: str | Path, dedupe: bool = True) -> pd.DataFrame:
    """Load every ``trial.json`` under the given sweep directories into one table.

    Unreadable records are skipped with a :class:`RecordWarning` naming the file. Columns are the
    record's flat fields (:data:`COLUMNS` first), ``num_samples``/``horizon``/``replan_period`` from
    ``config.planner`` when present, the derived ``variant``, ``sweep_dir`` (the Hydra sweep root, see
    :func:`sweep_root`), ``record_path`` and ``record_mtime``. A file reached through two overlapping
    directories is counted once; with ``dedupe``, of the records that share :data:`DEDUPE_KEY` only the
    newest (by file modification time) is kept.

    Args:
        *dirs: sweep directories (or any directories above them).
        dedupe: drop duplicate trials, keeping the newest.

    Returns:
        One row per trial, sorted by task (paper order), variant, seed; empty (with :data:`COLUMNS`)
        when no record was found.

    Raises:
        FileNotFoundError: a directory does not exist.
        NotADirectoryError: a path is not a directory.
    """
    rows: list[dict] = []
    seen: set[Path] = set()
    for directory in dirs:
        root = Path(directory).resolve()
        for path in find_records(root):
            path = path.resolve()
            if path in seen:
                continue
            seen.add(path)
            try:
                row = read_record(path)
                mtime = path.stat().st_mtime
            except (OSError, ValueError) as err:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
                warnings.warn(f"skipping unreadable record {path}: {_one_line(err)}", RecordWarning, 2)
                continue
            row["sweep_dir"] = str(sweep_root(path, root))
            row["record_path"] = str(path)
            row["record_mtime"] = pd.Timestamp(mtime, unit="s")
            rows.append(row)
    df = pd.DataFrame(rows)
    for col in COLUMNS:
        if col not in df:
            df[col] = pd.Series(dtype=object)
    if len(df):
        df["variant"] = [variant_name(*x) for x in zip(df["planner"], df["cost"], df["sampler"], strict=True)]
    df = df[list(COLUMNS) + [c for c in df.columns if c not in COLUMNS]]
    df = _coerce(df)
    if dedupe and len(df):
        df = drop_duplicates(df)
    return sort_table(df)


def drop_duplicates(df: pd.DataFrame) -> pd.DataFrame:
    """Of the rows that share :data:`DEDUPE_KEY` (missing values compare equal), keep the newest."""
    key = [c for c in DEDUPE_KEY if c in df]
    newest_first = df.sort_values(["record_mtime", "record_path"], ascending=[False, True], kind="stable")
    filled = newest_first[key].astype(object).where(newest_first[key].notna(), "<NA>").astype(str)
    return newest_first[~filled.duplicated(keep="first")]


def sort_table(df: pd.DataFrame) -> pd.DataFrame:
    """Rows sorted by task (paper order), variant (paper order), seed, sweep; a fresh index."""
    if not len(df):
        return df.reset_index(drop=True)
    tasks = {t: i for i, t in enumerate(ordered(df["task"], TASK_ORDER))}
    variants = {v: i for i, v in enumerate(ordered(df["variant"], VARIANT_ORDER))}
    keys = pd.DataFrame(
        {
            "t": df["task"].map(tasks),
            "v": df["variant"].map(variants),
            "s": pd.to_numeric(df["seed"], errors="coerce"),
            "d": df["sweep_dir"].astype(str),
            "p": df["record_path"].astype(str),
        },
        index=df.index,
    )
    order = keys.sort_values(["t", "v", "s", "d", "p"], kind="stable").index
    return df.loc[order].reset_index(drop=True)


def ok_trials(df: pd.DataFrame) -> pd.DataFrame:
    """The rows whose ``status`` is ``ok`` and that have a TTF: the only ones that count for TTF."""
    return df[(df["status"] == "ok") & df["ttf"].notna()]


def write_table(df: pd.DataFrame, path: str | Path) -> Path:
    """Write the table as CSV, or as Parquet when ``path`` ends in ``.parquet``.

    Raises:
        RuntimeError: Parquet was asked for but ``pyarrow`` is not installed.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.suffix.lower() == ".parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise RuntimeError(
                f"{path}: Parquet output needs pyarrow (pip install pyarrow); or use .csv"
            ) from None
        df.to_parquet(path, index=False)
    else:
        df.to_csv(path, index=False)
    return path


def _coerce(df: pd.DataFrame) -> pd.DataFrame:
    df = df.copy()
    for col, kind in COLUMN_TYPES.items():
        if kind == "Int64":
            df[col] = pd.to_numeric(df[col], errors="coerce").astype("Int64")
        elif kind == "float":
            df[col] = pd.to_numeric(df[col], errors="coerce").astype(float)
        elif kind == "boolean":
            df[col] = df[col].map(lambda x: pd.NA if _missing(x) else bool(x)).astype("boolean")
        elif kind == "datetime":
            df[col] = pd.to_datetime(df[col])
    return df


def _missing(x) -> bool:
    return x is None or (isinstance(x, float) and x != x) or x is pd.NA


def _one_line(err: BaseException) -> str:
    return " ".join(f"{type(err).__name__}: {err}".split())


def run_records(
    sweep_dirs: Iterable[str],
    action,
    errors: tuple[type[BaseException], ...],
    dedupe: bool = True,
) -> int:
    """:func:`analysis._cli.run` on the records of ``sweep_dirs`` read by :func:`load_records`: the
    command lines' load -> act -> report step, returning the exit status."""
    load = functools.partial(load_records, dedupe=dedupe)
    return run(list(sweep_dirs), action, errors, load=load, record_name=RECORD_NAME)


def build_parser() -> argparse.ArgumentParser:
    """Parser of ``python -m analysis.aggregate``."""
    parser = sweep_parser(
        "python -m analysis.aggregate",
        "Collect the trial.json records under sweep directories into one table.",
    )
    parser.add_argument(
        "--out",
        default="results.csv",
        help="output table: .csv, or .parquet (needs pyarrow); default %(default)s",
    )
    parser.add_argument(
        "--keep-duplicates", action="store_true", help="keep every record of a repeated trial"
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m analysis.aggregate``; returns the exit status."""
    args = build_parser().parse_args(argv)

    def action(df: pd.DataFrame) -> str:
        return f"wrote {write_table(df, args.out)} ({len(df)} trials)"

    return run_records(args.sweep_dirs, action, (OSError, RuntimeError), dedupe=not args.keep_duplicates)


if __name__ == "__main__":
    raise SystemExit(main())
