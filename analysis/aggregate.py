"""Collect trial records (``trial.json``) from sweep directories into one table.

Each trial writes one flat ``trial.json`` (see :mod:`contactmpc.records` and :mod:`contactmpc.jobs`);
a Hydra multirun writes each job to its own subdirectory of the sweep directory. This module globs
them, keeps the flat fields as columns, derives the paper's variant names, and tells trials apart by
their config.

**A trial's identity** is its resolved config (the record's ``config``) without the keys in
:data:`VOLATILE_CONFIG_KEYS` (where it wrote, how fast it ran, what it showed) and the trial job's
copies of root nodes (:data:`COPIED_CONFIG_KEYS`), together with the config choices (task, hand,
cost, sampler, planner). Two records of the same identity are the same trial run twice: the newest is
kept and a :class:`RecordWarning` names both. Records that differ in any other config value (a
``duration``, a cost weight, a planner size) are different trials: all are kept, and the values that
differ between trials of the same task and variant (other than the seed) become columns of their own
and the ``condition`` label (``"duration=2.0, cost.lambda_v=0.001"``; empty when there is one
condition), by which the tables, figures and tests group next to task and variant.

Command line::

    python -m analysis.aggregate SWEEP_DIR [SWEEP_DIR ...] --out results.csv
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import json
import warnings
from collections.abc import Iterable
from pathlib import Path

import pandas as pd

from analysis._cli import run, sweep_parser
from contactmpc.labels import GROUPS, method_labels, method_name, upgrade_config
from contactmpc.records import NOT_THE_TRIAL, RECORD_NAME, one_line, option_default, with_defaults

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
#: Config keys (and everything under them) that are not part of a trial's identity: paths and
#: settings that change where a trial writes, how fast it runs or what it shows, never its result
#: (:data:`contactmpc.records.NOT_THE_TRIAL`, which resuming uses too). Paths that name an input,
#: such as ``task.reference_path``, stay part of it.
VOLATILE_CONFIG_KEYS: tuple[str, ...] = NOT_THE_TRIAL
#: Nodes the trial job copies from the root by interpolation (``conf/job/trial.yaml``): they vary with
#: their originals, so they are left out of the identity and of the condition columns.
COPIED_CONFIG_KEYS: tuple[str, ...] = (
    "job.sampler",
    "job.cost",
    "job.planner",
    "job.duration",
    "job.perturbation",
)
#: Config choices that are part of a trial's identity besides its config (records name them; a
#: record's config is enough to tell them apart, these make sure of it).
IDENTITY_LABELS: tuple[str, ...] = ("task", "hand", "cost", "sampler", "planner")
#: Record fields that are not scalars and stay out of the table.
DROPPED_FIELDS: tuple[str, ...] = ("config", "versions", "traceback")
#: Columns of the table, in this order, with the type each is coerced to (``None``: left as read);
#: fields a record has beyond these follow them.
COLUMN_TYPES: dict[str, str | None] = {
    "task": None,
    "variant": None,
    "condition": None,
    "wrist": None,
    "shaping": None,
    "release": None,
    "compensation": None,
    "effort": None,
    "place": None,
    "pacing": None,
    "carry": None,
    "grip": None,
    "retarget": None,
    "rollout": None,
    "reuse": None,
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
    "settled": "boolean",
    "finished_cleanly": "boolean",
    "settled_time": "float",
    "reference_lets_go": "boolean",
    # the object's errors over the contact span and after it (records before them: NaN), then over
    # the whole trial
    **{
        f"object_{q}_error_{window}_{stat}": "float"
        for q in ("position", "rotation", "articulation")
        for window in ("span", "after")
        for stat in ("mean", "final")
    },
    "object_position_error_mean": "float",
    "object_rotation_error_mean": "float",
    "object_articulation_error_mean": "float",
    "final_object_position_error": "float",
    "final_object_rotation_error": "float",
    "final_object_articulation_error": "float",
    "contact_fraction": "float",
    "first_contact_time": "float",
    "last_contact_time": "float",
    "plan_seconds_mean": "float",
    "plan_seconds_p95": "float",
    "simulated_seconds": "float",
    "wall_seconds": "float",
    "real_time_factor": "float",
    "num_control_points": "Int64",
    "num_plans": "Int64",
    "diverged_rollouts": "Int64",
    "switch_time": "float",
    "switch_back_time": "float",
    "num_samples": "Int64",
    "horizon": "float",
    "replan_period": "float",
    "schema": "Int64",
    "git_revision": None,
    "cpu": None,
    "processor": None,
    "logical_cpus": "Int64",
    "threads": "Int64",
    "trial_id": None,
    "sweep_dir": None,
    "record_path": None,
    "record_mtime": "datetime",
}
COLUMNS: tuple[str, ...] = tuple(COLUMN_TYPES)
#: The identity of a record without a ``config`` (an older record): these columns, as before configs
#: were recorded.
FALLBACK_KEY: tuple[str, ...] = (
    "task",
    "variant",
    "planner",
    "seed",
    "sweep_dir",
    "hand",
    "preset",
    *CONFIG_COLUMNS,
)
_CONFIG = "_config"  # private column: a record's identity config, flattened (dropped after loading)


class RecordWarning(UserWarning):
    """A record that was skipped: unreadable, lacking required fields, or a second run of a trial."""


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


#: Rows already made, by the digest of their record's text (:func:`read_record`): a report reads each of
#: its records many times, and making a row (the identity's defaults) costs far more than reading the file.
_ROWS: dict[bytes, dict] = {}
_ROWS_KEPT = 50_000


def read_record(path: str | Path) -> dict:
    """One record as a flat row: scalar fields, the planner settings of ``config``, no nested values;
    and ``trial_id``, a digest of the trial's identity (see the module's docstring).

    A record read before with the same text gives a copy of the row made then.

    Raises:
        OSError: the file cannot be read.
        ValueError: it is not JSON, not an object, or has no ``task``.
    """
    text = Path(path).read_bytes()
    key = hashlib.blake2b(text, digest_size=20).digest()
    if (row := _ROWS.get(key)) is None:
        row = _row(text)
        if len(_ROWS) >= _ROWS_KEPT:
            _ROWS.clear()
        _ROWS[key] = row
    return {**row, _CONFIG: dict(row[_CONFIG])} if _CONFIG in row else dict(row)


def _row(text: bytes) -> dict:
    """:func:`read_record`'s row of a record's text."""
    data = json.loads(text)
    if not isinstance(data, dict):
        raise ValueError(f"expected a JSON object, got {type(data).__name__}")
    if _missing(data.get("task")):
        raise ValueError("record has no 'task'")
    config = data.get("config")
    planner_cfg = config.get("planner") if isinstance(config, dict) else None
    row = {k: v for k, v in data.items() if k not in DROPPED_FIELDS and not isinstance(v, dict | list)}
    # the processor as the host names it (brand, family, model: two of one brand string differ in speed)
    host = data.get("host")
    row["processor"] = host["cpu"] if isinstance(host, dict) and host.get("cpu") else data.get("cpu")
    if isinstance(planner_cfg, dict):
        for key in CONFIG_COLUMNS:
            if key in planner_cfg and not isinstance(planner_cfg[key], dict | list):
                row[key] = planner_cfg[key]
    if isinstance(config, dict):
        row[_CONFIG] = identity_config(config)
        labels = {k: data.get(k) for k in IDENTITY_LABELS}
        # an option at its default is left out: a record that predates the option is the same trial
        canonical = sorted(
            (k, v)
            for k, v in row[_CONFIG].items()
            if json.dumps(v, default=str) != json.dumps(option_default(row[_CONFIG], k), default=str)
        )
        text = json.dumps([labels, canonical], sort_keys=True, default=str)
        row["trial_id"] = hashlib.sha1(text.encode()).hexdigest()[:12]
    return row


def identity_config(config: dict) -> dict[str, object]:
    """The part of a record's ``config`` that makes the trial what it is, flattened to dotted keys
    (today's keys: :func:`contactmpc.labels.upgrade_config`).

    Keys under :data:`VOLATILE_CONFIG_KEYS` and :data:`COPIED_CONFIG_KEYS` are left out; a list is one
    value (as a tuple, so it can be compared and hashed).
    """
    skip = VOLATILE_CONFIG_KEYS + COPIED_CONFIG_KEYS
    out: dict[str, object] = {}

    def walk(node: dict, prefix: str) -> None:
        for k, v in node.items():
            key = f"{prefix}{k}"
            if key in skip:
                continue
            if isinstance(v, dict):
                walk(v, key + ".")
            else:
                out[key] = _hashable(v)

    walk(upgrade_config(config), "")
    return out


def _hashable(v):
    return tuple(_hashable(x) for x in v) if isinstance(v, list | tuple) else v


def load_records(*dirs: str | Path, dedupe: bool = True) -> pd.DataFrame:
    """Load every ``trial.json`` under the given sweep directories into one table.

    Unreadable records are skipped with a :class:`RecordWarning` naming the file. Columns are the
    record's flat fields (:data:`COLUMNS` first), ``num_samples``/``horizon``/``replan_period`` from
    ``config.planner`` when present, the derived ``variant``, ``condition`` and one column per config
    value that tells trials of the same task and variant apart (:func:`add_conditions`), ``trial_id``,
    ``sweep_dir`` (the Hydra sweep root, see :func:`sweep_root`), ``record_path`` and
    ``record_mtime``. A file reached through two overlapping directories is counted once; with
    ``dedupe``, of the records of one trial (:func:`drop_duplicates`) only the newest (by file
    modification time) is kept, with a :class:`RecordWarning`.

    Args:
        *dirs: sweep directories (or any directories above them).
        dedupe: drop second runs of a trial, keeping the newest.

    Returns:
        One row per record kept, sorted by task (paper order), variant, condition, seed; empty (with
        :data:`COLUMNS`) when no record was found.

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
                warnings.warn(f"skipping unreadable record {path}: {one_line(err)}", RecordWarning, 2)
                continue
            row["sweep_dir"] = str(sweep_root(path, root))
            row["record_path"] = str(path)
            row["record_mtime"] = pd.Timestamp(mtime, unit="s")
            rows.append(row)
    df = pd.DataFrame(rows)
    for col in COLUMNS:
        if col not in df:
            df[col] = pd.Series(dtype=object)
    if _CONFIG not in df:
        df[_CONFIG] = pd.Series([None] * len(df), dtype=object)
    if len(df):
        # the method from the record's labels: its variant label (variant=robust, wrist_clearance, or an
        # old record's wrist_acquire, release_flat, ...) and groups (wrist, shaping, release), read
        # through contactmpc.labels, so an old record and a new one of the same method get the same
        # name; without a variant label, the variant is told from the planner, cost and sampler choices
        derived = [variant_name(*x) for x in zip(df["planner"], df["cost"], df["sampler"], strict=True)]
        methods = []
        for labels, name in zip(_labels(df), derived, strict=True):
            found = method_labels(labels)
            found["variant"] = found["variant"] or name
            methods.append(found)
        for key in ("variant", *GROUPS):
            df[key] = [m[key] for m in methods]
        df["variant"] = [method_name(m) for m in methods]
    df = df[list(COLUMNS) + [c for c in df.columns if c not in COLUMNS]]
    df = _coerce(df)
    if dedupe and len(df):
        df = drop_duplicates(df)
    df = add_conditions(df)
    return sort_table(df)


def _labels(df: pd.DataFrame) -> list[dict]:
    """Each row's method labels as its record has them (``None`` where it has none)."""
    columns = [c for c in ("variant", *GROUPS) if c in df]
    rows = df[columns].astype(object).to_dict("records")
    return [{k: v if isinstance(v, str) and v else None for k, v in row.items()} for row in rows]


def _identity(df: pd.DataFrame) -> pd.Series:
    """A trial's identity per row: its ``trial_id``, or for a record without a config its
    :data:`FALLBACK_KEY` values (missing values compare equal)."""
    key = [c for c in FALLBACK_KEY if c in df]
    fallback = df[key].astype(object).where(df[key].notna(), "<NA>").astype(str).agg("|".join, axis=1)
    has_id = df["trial_id"].notna()
    return ("id:" + df["trial_id"].astype(str)).where(has_id, "key:" + fallback)


def drop_duplicates(df: pd.DataFrame) -> pd.DataFrame:
    """Of the rows of one trial (the same identity, see the module's docstring), keep the newest.

    Warns:
        RecordWarning: once per trial found more than once, naming the record kept and those dropped.
    """
    newest_first = df.sort_values(["record_mtime", "record_path"], ascending=[False, True], kind="stable")
    identity = _identity(newest_first)
    repeated = identity.duplicated(keep="first")
    for ident in dict.fromkeys(identity[repeated]):
        paths = newest_first.loc[identity == ident, "record_path"].tolist()
        warnings.warn(
            f"the same trial (same config and seed) is recorded {len(paths)} times: keeping the newest, "
            f"{paths[0]}; dropping {', '.join(paths[1:])}",
            RecordWarning,
            2,
        )
    return newest_first[~repeated]


def add_conditions(df: pd.DataFrame) -> pd.DataFrame:
    """Tell apart the trials of one task and variant that ran under different config values.

    Within each (task, variant), the identity-config keys (see :func:`identity_config`) whose value is
    not the same in every row, the seed aside, are that group's condition keys. Each becomes a column
    named by its dotted key (``duration``, ``cost.lambda_v``; ``config.<key>`` where that name is
    already a column), filled for every row; each row's ``condition`` is ``"key=value, ..."`` over
    its group's keys, sorted, and empty where the group has a single condition.

    Returns:
        The table with ``condition`` filled and the condition columns added after :data:`COLUMNS`;
        the private flattened-config column is dropped.
    """
    df = df.copy()
    configs = df[_CONFIG] if _CONFIG in df else pd.Series([None] * len(df), index=df.index, dtype=object)
    labels = pd.Series("", index=df.index, dtype=object)
    varying: dict[str, None] = {}
    for _, group in df.groupby(["task", "variant"], dropna=False, sort=False):
        rows = [c if isinstance(c, dict) else {} for c in configs[group.index]]
        every = set().union(*rows)
        # a record made before an option existed lacks it: it ran the option's default
        rows = [with_defaults(r, every) for r in rows]
        keys = sorted(
            k
            for k in every
            if k != "seed" and len({json.dumps(r.get(k, "<absent>"), default=str) for r in rows}) > 1
        )
        varying.update(dict.fromkeys(keys))
        for i, row in zip(group.index, rows, strict=True):
            labels[i] = ", ".join(f"{k}={_show(row[k]) if k in row else '?'}" for k in keys)
    df["condition"] = labels
    added = []
    for key in sorted(varying):
        column = key if key not in df else f"config.{key}"
        df[column] = [_cell(c.get(key)) if isinstance(c, dict) else None for c in configs]
        added.append(column)
    df = df.drop(columns=[_CONFIG], errors="ignore")
    return df[list(COLUMNS) + added + [c for c in df.columns if c not in COLUMNS and c not in added]]


def _show(value) -> str:
    """A config value as it is written on Hydra's command line (``null``, ``true``, ``[0, 0.1]``)."""
    return value if isinstance(value, str) else json.dumps(_cell(value))


def _cell(value):
    return list(value) if isinstance(value, tuple) else value


def sort_table(df: pd.DataFrame) -> pd.DataFrame:
    """Rows sorted by task (paper order), variant (paper order), condition, seed, sweep; a fresh index."""
    if not len(df):
        return df.reset_index(drop=True)
    tasks = {t: i for i, t in enumerate(ordered(df["task"], TASK_ORDER))}
    variants = {v: i for i, v in enumerate(ordered(df["variant"], VARIANT_ORDER))}
    keys = pd.DataFrame(
        {
            "t": df["task"].map(tasks),
            "v": df["variant"].map(variants),
            "c": df["condition"].fillna("").astype(str),
            "s": pd.to_numeric(df["seed"], errors="coerce"),
            "d": df["sweep_dir"].astype(str),
            "p": df["record_path"].astype(str),
        },
        index=df.index,
    )
    order = keys.sort_values(["t", "v", "c", "s", "d", "p"], kind="stable").index
    return df.loc[order].reset_index(drop=True)


def conditions(df: pd.DataFrame, task: str, variant: str) -> list[str]:
    """The conditions of ``task`` and ``variant`` in the table, sorted: ``[""]`` for a variant run
    under one condition, ``[]`` for one not in the table."""
    sel = df.loc[(df["task"] == task) & (df["variant"] == variant), "condition"]
    return sorted(set(sel.fillna("").astype(str)))


def groups(df: pd.DataFrame) -> list[tuple[str, str, str]]:
    """The ``(task, variant, condition)`` groups of the table: tasks and variants in paper order,
    conditions sorted. Tables, figures and tests count trials per group."""
    return [
        (task, variant, condition)
        for task in ordered(df["task"], TASK_ORDER)
        for variant in ordered(df["variant"], VARIANT_ORDER)
        for condition in conditions(df, task, variant)
    ]


#: Statuses whose records count for TTF, completion and errors when they have a TTF: a finished trial,
#: and one whose plant diverged (measured on what it logged; a divergence inside the contact span is its
#: failure, :func:`contactmpc.jobs.trial.summarize`; diverged records from before that have no TTF).
COUNTED_STATUSES: tuple[str, ...] = ("ok", "diverged")


def select(df: pd.DataFrame, **keep: str | None) -> pd.DataFrame:
    """The rows of ``df`` whose columns have one of the comma-separated values given per column
    (``select(df, task="apple,bottle")``); ``None`` keeps every value of that column. A value that no
    row has raises ``ValueError`` naming it, so a misspelt filter does not silently empty the table."""
    for column, values in keep.items():
        if values is None:
            continue
        wanted = [v.strip() for v in values.split(",") if v.strip()]
        have = set(df[column].astype(str)) if column in df else set()
        missing = [v for v in wanted if v not in have]
        if missing:
            raise ValueError(
                f"--{column} {', '.join(missing)}: no such {column} in the records ({sorted(have)})"
            )
        df = df[df[column].astype(str).isin(wanted)]
    return df


def ok_trials(df: pd.DataFrame) -> pd.DataFrame:
    """The rows that count for TTF: status in :data:`COUNTED_STATUSES`, with a TTF."""
    return df[df["status"].isin(COUNTED_STATUSES) & df["ttf"].notna()]


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
